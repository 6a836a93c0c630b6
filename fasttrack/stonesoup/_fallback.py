"""Where a drop-in runs Stone Soup's own code instead of fasttrack's, it says so: a debug
record on the ``fasttrack.stonesoup`` logger naming the class, the method and the reason,
and a count per reason over the process (:func:`fallbacks`)."""
import collections
import logging
import threading

from ._convert import fast_model

logger = logging.getLogger("fasttrack.stonesoup")

_counts = collections.Counter()
_lock = threading.Lock()

#: Distinct (class, method, reason) counts kept; later ones are counted together (a reason
#: may quote an error message, and a long run must not grow without bound).
MAX_REASONS = 1000


def fall_back(component, method, reason):
    """Record that ``component``'s ``method`` runs Stone Soup's code because of ``reason``
    (text completing "runs Stone Soup's code: ...")."""
    key = (type(component).__name__, method, reason)
    logger.debug("%s.%s runs Stone Soup's code: %s", *key)
    with _lock:
        if key not in _counts and len(_counts) >= MAX_REASONS:
            key = ("(any)", "(any)", f"other reasons, beyond the first {MAX_REASONS}")
        _counts[key] += 1


def fallbacks(clear=False):
    """How often the drop-ins ran Stone Soup's own code in this process, and why.

    Parameters
    ----------
    clear : bool
        Start counting afresh after this call.

    Returns
    -------
    collections.Counter
        ``{(class name, method, reason): calls}``; ``.most_common()`` lists the most
        frequent first. Empty when every call took fasttrack's path.

    Raises
    ------
    TypeError
        If ``clear`` is not a bool.
    """
    if not isinstance(clear, bool):
        raise TypeError(f"clear must be a bool, got {type(clear).__name__}")
    with _lock:
        found = collections.Counter(_counts)
        if clear:
            _counts.clear()
    return found


#: The keyword arguments that Stone Soup's built-in models and its Kalman and particle
#: methods read (the extended filters' ``linearisation_point``, which its iterated updaters
#: pass); they accept any other and ignore it (e.g. the ``measurement`` a
#: ``DistanceHypothesiser`` passes its predictor), and so do the drop-ins.
READ_KEYWORDS = frozenset({"time_interval", "noise", "linearisation_point", "random_state",
                           "num_samples"})


def keywords(kwargs, *components):
    """The reason Stone Soup's code must run for keyword arguments, or None: those the
    built-in models read, and any at all for ``components`` of a user's subclass (whose own
    methods may read them, as Stone Soup's recursive updaters read ``scale_factor``)."""
    read = set(READ_KEYWORDS.intersection(kwargs))
    if any(not type(c).__module__.startswith(__package__) for c in components):
        read = set(kwargs)
    return f"keyword arguments {', '.join(sorted(read))}" if read else None


def unknown_model(model):
    """The reason for a model that fasttrack does not compute (naming the first such part
    of a combined model)."""
    for part in getattr(model, "model_list", ()):
        if fast_model(part) is None:
            return unknown_model(part)
    return f"{type(model).__name__} is not a model fasttrack computes"


def unknown_kernel(kernel):
    """The reason for a kernel that fasttrack does not compute."""
    return f"kernel {type(kernel).__name__} is not one fasttrack computes"


def overridden(component, stonesoup_class, hooks):
    """The reason for a subclass that overrides one of Stone Soup's ``hooks`` (methods of
    ``stonesoup_class`` that the fast path computes itself), or None."""
    for hook in hooks:
        if getattr(type(component), hook) is not getattr(stonesoup_class, hook):
            return f"a subclass's own {hook}"
    return None
