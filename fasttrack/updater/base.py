"""What the updaters share: the measurement model (the updater's, or a detection's own)
and the checks of hypotheses and predictions."""
from ..models.base import check_model
from ..models.measurement import MeasurementModel
from ..types import Detection, SingleHypothesis

__all__ = ["Updater"]


class Updater:
    """Base class: ``updater.update(hypothesis)`` with ``measurement_model``.

    Parameters
    ----------
    measurement_model : MeasurementModel, optional
        Used when the detection has none of its own.
    """

    def __init__(self, measurement_model=None):
        if measurement_model is not None:
            self._check_model(measurement_model)
        self.measurement_model = measurement_model

    def _check_model(self, model):
        check_model(model, MeasurementModel, "measurement_model")

    def _measurement_model(self, hypothesis):
        """The detection's own measurement model, else the updater's."""
        model = getattr(hypothesis.measurement, "measurement_model", None) \
            or self.measurement_model
        if model is None:
            raise ValueError("no measurement model: give the updater one or set the "
                             "detection's measurement_model")
        check_model(model, MeasurementModel, "measurement model")
        return model

    @staticmethod
    def _check_hypothesis(hypothesis):
        if not isinstance(hypothesis, SingleHypothesis):
            raise TypeError(f"hypothesis must be a SingleHypothesis, "
                            f"got {type(hypothesis).__name__}")
        measurement = hypothesis.measurement
        if measurement is None:
            raise ValueError("hypothesis.measurement is None: nothing to update with")
        if type(measurement) is not Detection and not (hasattr(measurement, "state_vector")
                                                       and hasattr(measurement, "timestamp")):
            raise TypeError(f"hypothesis.measurement must be a Detection (a state_vector and "
                            f"a timestamp), got {type(measurement).__name__}")

    @staticmethod
    def _check_prediction(prediction, kind, name="the prediction"):
        if not isinstance(prediction, kind):
            raise TypeError(f"{name} must be a {kind.__name__}, got {type(prediction).__name__}")

    @staticmethod
    def _check_dimensions(model, prediction):
        if model.ndim_state != prediction.ndim:
            raise ValueError(f"the measurement model expects {model.ndim_state} state "
                             f"dimensions, the prediction has {prediction.ndim}")
