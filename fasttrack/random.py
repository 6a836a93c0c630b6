"""Random generators: the package default and the ``rng`` argument convention."""
import numbers

import numpy as np

_default = np.random.default_rng()


def seed(n):
    """Reset the package default generator, used wherever ``rng=None``.

    Parameters
    ----------
    n : int or None
        Seed of the new default generator (``None`` seeds it from the operating system).
    """
    global _default
    _default = np.random.default_rng(n)


def check_rng(rng, name="rng"):
    """Validate an ``rng`` argument (``None``, an int seed or a ``numpy.random.Generator``).

    Returns
    -------
    None or numpy.random.Generator
        ``None`` is kept, so that :func:`generator` finds the default at each call; an int
        becomes a new Generator seeded with it.
    """
    if rng is None or isinstance(rng, np.random.Generator):
        return rng
    if isinstance(rng, numbers.Integral) and not isinstance(rng, bool):
        if rng < 0:
            raise ValueError(f"{name} must be a non-negative seed, got {rng}")
        return np.random.default_rng(int(rng))
    raise TypeError(f"{name} must be None, an int seed or a numpy.random.Generator, "
                    f"got {type(rng).__name__}")


def generator(rng, name="rng"):
    """The Generator an ``rng`` argument stands for (``None``: the package default)."""
    rng = check_rng(rng, name)
    return _default if rng is None else rng


def stream_key(rng, name="rng"):
    """A fresh 63-bit key for the counter-based uniform stream of the kernels, drawn from
    the Generator that ``rng`` stands for."""
    return int(generator(rng, name).integers(0, 2**63 - 1))
