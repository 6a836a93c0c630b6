"""The fixed-interval IMM smoother of Kim (1994) over the filtered states of K tracks of T
steps of :mod:`fasttrack.core.imm`'s filters (one kernel call for linear models; models
built from a function linearised at the filtered states)."""
import numpy as np

from .. import _jit
from .. import threads as _threads
from . import kalman as _kalman
from .imm import _mask, _matrices, converted

_kernels = _jit.lazy("imm_smooth")


def smooth(transition_models, matrix, means, covars, mode_probs, intervals, has=None,
           single=False):
    """The IMM fixed-interval smoother of K tracks of T filtered steps (see
    :func:`fasttrack._jit.imm_smooth.imm_smooth`). A model built from a function is
    linearised at each model's filtered mean (forward differences, as the extended Kalman
    filter predicts): the extended form of the smoother.

    Parameters
    ----------
    transition_models : sequence of M TransitionModel
        Linear, or built from a function.
    matrix : (M, M) ndarray
        The validated switching matrix (:func:`transition_matrix`).
    means, covars, mode_probs : ndarray
        Validated filtered (K, T, M, d), (K, T, M, d, d) and (K, T, M) arrays.
    intervals : (T - 1,) ndarray
        Seconds from each step to the next, >= 0.
    has : (M, d) bool ndarray, optional
        Each model's state components (:func:`components`); None: all.
    single : bool
        Whether the arrays are the caller's one track (K = 1; errors name its states
        without a track index).

    Returns
    -------
    means, covars, mode_probs, status : ndarray
        The smoothed arrays (shapes of the inputs) and each track's (K,) status (0, or
        where the pass failed: see :func:`fasttrack._jit.imm_smooth.imm_smooth`).

    Raises
    ------
    ValueError
        Naming the user's function and the filtered state where it returns a bad output,
        or the first filtered step whose mode probabilities ``matrix`` cannot reach.
    """
    _reachable(matrix, mode_probs, single)
    values, step = np.unique(intervals, return_inverse=True)
    values = values if values.size else np.zeros(1)
    step = np.ascontiguousarray(np.append(step, 0), dtype=np.int64)
    arrays = [np.require(a, np.float64, ["C"]) for a in (means, covars, mode_probs)]
    out = [np.empty_like(a) for a in arrays]
    status = np.empty(means.shape[0], dtype=np.int64)
    kernel = _kernels.imm_smooth_kernel(means.shape[-1])
    k, n, models = mode_probs.shape
    mask = _mask(has, means.shape[2:])
    if all(hasattr(model, "matrix") for model in transition_models):
        banks = [_matrices(transition_models, float(dt)) for dt in values]
        transitions = np.array([f for f, _ in banks])
        fixed = (transitions, np.zeros(transitions.shape[:3]), np.array([q for _, q in banks]),
                 np.ascontiguousarray(np.broadcast_to(step[None, :, None], (k, n, models))))
        _threads.in_chunks(lambda lo, hi: kernel(
            *fixed[:3], fixed[3][lo:hi], step, matrix, mask, *(a[lo:hi] for a in arrays),
            *(a[lo:hi] for a in out), status[lo:hi]), k, serial_below=2)
        return (*out, status)
    noises = np.array([[model.spec(float(dt)).noise for model in transition_models]
                       for dt in values])
    chunk = max(1, LINEARISED_STATES // (n * models))
    for lo in range(0, k, chunk):  # the linearisations of a chunk of tracks at a time
        hi = min(lo + chunk, k)
        transitions, offsets = _linearised(transition_models, *(a[lo:hi] for a in arrays[:2]),
                                           values, step, has, None if single else lo)
        kernel(transitions, offsets, noises, np.arange(transitions.shape[0]).reshape(
            hi - lo, n, models), step, matrix, mask, *(a[lo:hi] for a in arrays),
            *(a[lo:hi] for a in out), status[lo:hi])
    return (*out, status)


def _reachable(matrix, mode_probs, single):
    """ValueError naming the first filtered step that gives a model a probability although
    no model of the step before can switch into it (its predicted probability
    ``sum_i p_ij mu_i`` is 0, and the smoother's ratio by it is undefined)."""
    bad = (mode_probs[:, 1:] > 0.0) & (mode_probs[:, :-1] @ matrix == 0.0)
    if bad.any():
        k, t, j = np.argwhere(bad)[0]
        track = "" if single else f"{k}, "
        raise ValueError(f"mode_probs[{track}{t + 1}] gives model {j} a probability, but no "
                         f"model with a probability at mode_probs[{track}{t}] can switch "
                         f"into it through transition_matrix: these filtered probabilities "
                         f"cannot come from this switching matrix")


#: How many filtered states :func:`smooth` linearises the models at in one batch (the
#: tracks' chunk: some 30 MB of Jacobians for 3 models of 5 components).
LINEARISED_STATES = 16384


def _linearised(transition_models, means, covars, values, step, has, first_track):
    """``(F, b)`` (U, M, d, d) and (U, M, d): each model j's transition ``x -> F x + b``
    from each filtered state (U = K T M of the (K, T, M, d) ``means``, in their order;
    track 0 is the caller's ``first_track``, None for the caller's one track), for the
    step's interval (``values[step[t]]`` seconds): a linear model's own F (b = 0), a
    function's Jacobian F at the state (:func:`converted` into model j's components, by
    ``has``) and ``b = f(x) - F x``."""
    k, n, models, d = means.shape
    flat = means.reshape(-1, models, d)
    sources = converted(flat, covars.reshape(-1, models, d, d), has)[0] \
        if has is not None else None  # (K T, i, j, d)
    interval = np.broadcast_to(step[None, :, None], (k, n, models)).reshape(-1)
    transitions = np.empty((flat.shape[0] * models, models, d, d))
    offsets = np.zeros((flat.shape[0] * models, models, d))

    def where(row):
        track, t, i = np.unravel_index(row, (k, n, models))
        return f"means[{t}, {i}]" if first_track is None else \
            f"means[{first_track + track}, {t}, {i}]"
    for j, model in enumerate(transition_models):
        for v, dt in enumerate(values):
            rows = np.flatnonzero(interval == v)
            if hasattr(model, "matrix"):
                transitions[rows, j] = model.spec(float(dt)).matrix
                continue
            points = (flat if sources is None else sources[:, :, j]).reshape(-1, d)[rows]
            try:
                jacobians, images = _kalman.linearise(model, float(dt), points,
                                                      name=lambda i, rows=rows: where(rows[i]))
            except ValueError as error:
                raise ValueError(f"model {j} ({type(model).__name__}) {error}") from None
            transitions[rows, j] = jacobians
            offsets[rows, j] = images - np.einsum("nab,nb->na", jacobians, points)
    return transitions, offsets
