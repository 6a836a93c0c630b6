"""Scores of a track against the truth."""
import numpy as np


def position_rmse(track, truth, mapping=(0, 2)):
    """Root-mean-square position error over the states of ``track`` and ``truth``, paired
    in order: ``sqrt(mean over steps of |mean[mapping] - truth[mapping]|^2)``.

    Parameters
    ----------
    track, truth : sequences of states (with ``mean`` or ``state_vector``)
    mapping : sequence of int
        The position components.
    """
    if len(track) != len(truth) or len(track) == 0:
        raise ValueError(f"track and truth must be non-empty and of the same length, "
                         f"got {len(track)} and {len(truth)}")
    index = list(mapping)
    errors = [np.ravel(getattr(s, "mean", s.state_vector))[index]
              - np.ravel(t.state_vector)[index] for s, t in zip(track, truth)]
    return float(np.sqrt(np.mean(np.sum(np.square(errors), axis=1))))
