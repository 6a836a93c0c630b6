"""Stone Soup's ``stonesoup.deleter``: the ``UpdateTimeStepsDeleter`` and
``CovarianceBasedDeleter``, with their checks over a set of tracks done at once.

- ``UpdateTimeStepsDeleter`` walks each track's states backwards in place, only back to its
  last update (Stone Soup first copies every track into a new reversed sequence).
- ``CovarianceBasedDeleter`` takes the traces of all the tracks' covariances in one array
  operation; ragged or non-numeric covariances, or a subclass's own check, go through Stone
  Soup's code.
"""
import numpy as np
from stonesoup.deleter import error as ss_error
from stonesoup.deleter import time as ss_time
from stonesoup.types.state import StateMutableSequence
from stonesoup.types.update import Update

from ._fallback import fall_back

__all__ = ["CovarianceBasedDeleter", "UpdateTimeStepsDeleter"]


def _remove_last_predictions(tracks):
    """``delete_last_pred``: drop each track's last state (and its metadata) unless it is an
    update."""
    for track in tracks:
        if not isinstance(track[-1], Update):
            del track[-1]
            del track.metadatas[-1]


def _deleted(deleter, tracks):
    if deleter.delete_last_pred:
        _remove_last_predictions(tracks)
    return tracks


class UpdateTimeStepsDeleter(ss_time.UpdateTimeStepsDeleter):
    """Stone Soup's ``UpdateTimeStepsDeleter``: a track is deleted when more than
    ``time_steps_since_update`` distinct timestamps go back from its last state without
    reaching an update with a measurement; the states are read in place, newest first, and
    only back to that update."""

    def check_for_deletion(self, track, **kwargs):
        if type(track).__getitem__ is StateMutableSequence.__getitem__:
            newest_first = reversed(track.states)
        else:  # a sequence type with its own indexing: read it as Stone Soup does
            newest_first = track[::-1]
        limit = self.time_steps_since_update
        seen = set()
        for state in newest_first:
            seen.add(state.timestamp)
            if len(seen) > limit:
                return True
            if isinstance(state, Update) and state.hypothesis:
                return False
        return False

    def delete_tracks(self, tracks, **kwargs):
        check = self.check_for_deletion
        return _deleted(self, {track for track in tracks if check(track, **kwargs)})


class CovarianceBasedDeleter(ss_error.CovarianceBasedDeleter):
    """Stone Soup's ``CovarianceBasedDeleter``: a track is deleted when the trace of its
    last covariance (over ``mapping``, if given) exceeds ``covar_trace_thresh``; the traces
    of all the tracks are summed in one array operation."""

    def delete_tracks(self, tracks, **kwargs):
        if type(self).check_for_deletion is not ss_error.CovarianceBasedDeleter.check_for_deletion:
            fall_back(self, "delete_tracks", "a subclass's own check_for_deletion")
            return super().delete_tracks(tracks, **kwargs)
        tracks = list(tracks)
        if not tracks:
            return set()
        covars = [track.state.covar for track in tracks]
        flags = self._exceeding(covars)
        if flags is None:  # one at a time
            fall_back(self, "delete_tracks", "covariances that do not stack into one array")
            doomed = {track for track in tracks if self.check_for_deletion(track, **kwargs)}
        else:
            doomed = {track for track, flag in zip(tracks, flags.tolist()) if flag}
        return _deleted(self, doomed)

    def _exceeding(self, covars):
        """Whether each covariance's trace (over ``mapping``) exceeds the threshold, or None
        where the covariances do not stack into one numeric array."""
        try:
            stacked = np.array(covars)
        except (ValueError, TypeError):
            return None
        if stacked.ndim != 3 or stacked.shape[1] != stacked.shape[2] \
                or stacked.dtype.kind not in "fiub":
            return None
        diagonals = np.ascontiguousarray(np.diagonal(stacked, axis1=1, axis2=2))
        if self.mapping:
            # the same indexing (and errors) as on one diagonal
            rows = np.reshape(np.arange(diagonals.shape[1])[self.mapping], -1)
            diagonals = np.ascontiguousarray(diagonals[:, rows])
        return diagonals.sum(axis=1) > self.covar_trace_thresh
