"""Scores of a track against the truth."""
import numpy as np


def position_rmse(track, truth, mapping=(0, 2), pair="order"):
    """Root-mean-square position error over the states of ``track`` and ``truth``:
    ``sqrt(mean over steps of |mean[mapping] - truth[mapping]|^2)``.

    Parameters
    ----------
    track, truth : sequences of states (with ``mean`` or ``state_vector``)
    mapping : sequence of int
        The position components.
    pair : {'order', 'timestamp'}
        Pair the states in order (the sequences of the same length), or each track state
        with the truth state of its timestamp (a truth with states at other times too, e.g.
        a track that started late or missed steps).
    """
    if pair == "timestamp":
        by_time = {state.timestamp: state for state in truth}
        missing = [s.timestamp for s in track if s.timestamp not in by_time]
        if missing:
            raise ValueError(f"truth has no state at the track's timestamps {missing[:3]}"
                             f"{' ...' if len(missing) > 3 else ''}")
        truth = [by_time[s.timestamp] for s in track]
    elif pair != "order":
        raise ValueError(f"pair must be 'order' or 'timestamp', got {pair!r}")
    if len(track) != len(truth) or len(track) == 0:
        raise ValueError(f"track and truth must be non-empty and of the same length, "
                         f"got {len(track)} and {len(truth)} (pair='timestamp' matches "
                         f"them by time)")
    index = list(mapping)
    errors = [np.ravel(getattr(s, "mean", s.state_vector))[index]
              - np.ravel(t.state_vector)[index] for s, t in zip(track, truth)]
    return float(np.sqrt(np.mean(np.sum(np.square(errors), axis=1))))
