"""Random generators: the package default and the ``rng`` argument convention."""
import numbers

import numpy as np

__all__ = ["seed"]

_default = np.random.default_rng()


def seed(n):
    """Reset the package default generator, used wherever ``rng=None``.

    Parameters
    ----------
    n : int or None
        Seed of the new default generator (``None`` seeds it from the operating system).
    """
    global _default
    if n is not None and (not isinstance(n, numbers.Integral) or isinstance(n, bool)):
        raise TypeError(f"n must be an int seed or None, got {type(n).__name__}")
    if n is not None and n < 0:
        raise ValueError(f"n must be a non-negative seed, got {n}")
    _default = np.random.default_rng(None if n is None else int(n))


def check_rng(rng, name="rng"):
    """Validate an ``rng`` argument: ``None``, an int seed, a ``numpy.random.Generator``, or a
    legacy ``numpy.random.RandomState`` (such as the global one that ``np.random.seed``
    seeds).

    Returns
    -------
    None, numpy.random.Generator or numpy.random.RandomState
        ``None`` is kept, so that :func:`generator` finds the default at each call; an int
        becomes a new Generator seeded with it.
    """
    if rng is None or isinstance(rng, (np.random.Generator, np.random.RandomState)):
        return rng
    if isinstance(rng, numbers.Integral) and not isinstance(rng, bool):
        if rng < 0:
            raise ValueError(f"{name} must be a non-negative seed, got {rng}")
        return np.random.default_rng(int(rng))
    raise TypeError(f"{name} must be None, an int seed, a numpy.random.Generator or a "
                    f"RandomState, got {type(rng).__name__}")


def generator(rng, name="rng"):
    """The generator an ``rng`` argument stands for (``None``: the package default)."""
    rng = check_rng(rng, name)
    return _default if rng is None else rng


def stream_key(rng, name="rng"):
    """A fresh 63-bit key for the counter-based uniform stream of the kernels, drawn from
    the generator that ``rng`` stands for."""
    source = generator(rng, name)
    if isinstance(source, np.random.RandomState):
        return int(source.randint(0, 2**63 - 1, dtype=np.int64))
    return int(source.integers(0, 2**63 - 1))
