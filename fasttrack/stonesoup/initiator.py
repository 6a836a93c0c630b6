"""Stone Soup's ``stonesoup.initiator``: the ``SimpleMeasurementInitiator``, which inverts
each linear measurement model once per call instead of once per detection, and the
``MultiMeasurementInitiator``, which uses it as its default initiator."""
import numpy as np
from stonesoup.initiator import simple as ss_initiator
from stonesoup.initiator.base import GaussianInitiator
from stonesoup.models.base import LinearModel, ReversibleModel
from stonesoup.types.hypothesis import SingleHypothesis
from stonesoup.types.state import State
from stonesoup.types.track import Track
from stonesoup.types.update import Update

__all__ = ["MultiMeasurementInitiator", "SimpleMeasurementInitiator"]


class SimpleMeasurementInitiator(ss_initiator.SimpleMeasurementInitiator):
    """Stone Soup's ``SimpleMeasurementInitiator``: a track per detection, its state the
    prior with the measured components taken from the detection (through the model's
    pseudo-inverse, or its inverse function for a reversible model) and their covariance from
    the model's noise; the pseudo-inverse and the covariance of a linear model are computed
    once per call for all the detections that share it."""

    def _model(self, detection):
        if detection.measurement_model is not None:
            return detection.measurement_model
        if self.measurement_model is None:
            raise ValueError("No measurement model specified")
        return self.measurement_model

    def _start(self, model, inverse):
        """The prior's state vector with the measured components zeroed, and the new
        track's covariance (the model's noise mapped through ``inverse``, the prior's
        covariance outside the measured components, the diagonal load)."""
        mapped = model.mapping
        vector = self.prior_state.state_vector.copy()
        vector[mapped, :] = 0
        prior_covar = self.prior_state.covar.copy()
        prior_covar[mapped, :] = 0
        prior_covar[:, mapped] = 0
        covar = inverse @ model.covar() @ inverse.T
        covar = covar + prior_covar + np.diag(np.array([self.diag_load] * covar.shape[0]))
        return vector, covar

    def initiate(self, detections, timestamp, **kwargs):
        tracks = set()
        linear = {}  # id(model) -> (model, inverse, start vector, covariance)
        for detection in detections:
            model = self._model(detection)
            if isinstance(model, LinearModel):
                known = linear.get(id(model))
                if known is None:
                    inverse = np.linalg.pinv(model.matrix())
                    known = linear[id(model)] = (model, inverse) + self._start(model, inverse)
                _, inverse, vector, covar = known
                state_vector = inverse @ detection.state_vector
                covar = covar.copy()
            elif isinstance(model, ReversibleModel):
                try:
                    state_vector = model.inverse_function(detection)
                except NotImplementedError:
                    if self.skip_non_reversible:
                        continue
                    raise
                inverse = np.linalg.pinv(model.jacobian(State(state_vector)))
                vector, covar = self._start(model, inverse)
            elif self.skip_non_reversible:
                continue
            else:
                raise Exception("Invalid measurement model used. Must be instance of linear "
                                "or reversible.")
            tracks.add(Track([Update.from_state(
                self.prior_state, state_vector=vector + state_vector, covar=covar,
                hypothesis=SingleHypothesis(None, detection), timestamp=detection.timestamp)]))
        return tracks


class MultiMeasurementInitiator(ss_initiator.MultiMeasurementInitiator):
    """Stone Soup's ``MultiMeasurementInitiator``; its default ``initiator`` is the drop-in
    :class:`SimpleMeasurementInitiator` (on ``prior_state`` and ``measurement_model``).
    Pass the drop-in associator, updater and deleter to make its holding tracks fast."""

    def __init__(self, *args, **kwargs):
        # Stone Soup's own initialiser would build Stone Soup's SimpleMeasurementInitiator
        GaussianInitiator.__init__(self, *args, **kwargs)
        self.holding_tracks = set()
        if self.initiator is None:
            self.initiator = SimpleMeasurementInitiator(self.prior_state, self.measurement_model)
