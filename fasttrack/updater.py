"""Updaters: ``updater.update(hypothesis)``."""
import numpy as np

from .models.measurement import MeasurementModel
from .resampler import Resampler
from .types import ParticleState, ParticleStateUpdate, SingleHypothesis
from ._jit import weights as _weights


def _measurement_model(hypothesis, default):
    """The detection's own measurement model, else the updater's."""
    model = getattr(hypothesis.measurement, "measurement_model", None) or default
    if model is None:
        raise ValueError("no measurement model: give the updater one or set the "
                         "detection's measurement_model")
    if not isinstance(model, MeasurementModel):
        raise TypeError(f"measurement model must be a MeasurementModel, "
                        f"got {type(model).__name__}")
    return model


class ParticleUpdater:
    """Weights particles by the likelihood of a measurement, then optionally resamples.

    Parameters
    ----------
    measurement_model : MeasurementModel, optional
        Used when the detection has none of its own.
    resampler : Resampler, optional
        Applied after the weights are updated (an :class:`~fasttrack.ESSResampler` resamples
        only when it decides to).
    """

    def __init__(self, measurement_model=None, resampler=None):
        if measurement_model is not None and not isinstance(measurement_model, MeasurementModel):
            raise TypeError(f"measurement_model must be a MeasurementModel, "
                            f"got {type(measurement_model).__name__}")
        if resampler is not None and not isinstance(resampler, Resampler):
            raise TypeError(f"resampler must be a Resampler, got {type(resampler).__name__}")
        self.measurement_model = measurement_model
        self.resampler = resampler

    def update(self, hypothesis):
        """The posterior of ``hypothesis.prediction`` given ``hypothesis.measurement``.

        ``log_weight += log p(z | particle)``, normalised with logsumexp, then the resampler.

        Returns
        -------
        ParticleStateUpdate
            Sharing the prediction's ``state_vector`` (unless resampled), with ``hypothesis``,
            ``parent`` = the prediction's parent (its prior), and the prediction's timestamp.
        """
        if not isinstance(hypothesis, SingleHypothesis):
            raise TypeError(f"hypothesis must be a SingleHypothesis, "
                            f"got {type(hypothesis).__name__}")
        prediction = hypothesis.prediction
        if not isinstance(prediction, ParticleState):
            raise TypeError(f"hypothesis.prediction must be a ParticleState, "
                            f"got {type(prediction).__name__}")
        if hypothesis.measurement is None:
            raise ValueError("hypothesis.measurement is None: nothing to update with")
        model = _measurement_model(hypothesis, self.measurement_model)
        if model.ndim_state != prediction.ndim:
            raise ValueError(f"the measurement model expects {model.ndim_state} state "
                             f"dimensions, the prediction has {prediction.ndim}")
        z = model.measurement_vector(hypothesis.measurement, "hypothesis.measurement")
        log_w = np.empty(len(prediction))
        top = model.log_likelihood(z, prediction.state_vector, prediction.log_weight, log_w)
        if np.isnan(top):
            raise ValueError(f"{type(model).__name__} gave NaN log-likelihoods for this "
                             f"measurement")
        if top == -np.inf:
            raise ValueError("every particle has zero likelihood for this measurement: "
                             "no weight survives")
        _weights.normalise_in_place(log_w, top)
        update = ParticleStateUpdate._trusted(
            prediction.state_vector, log_w, timestamp=prediction.timestamp,
            parent=prediction.parent, hypothesis=hypothesis, fixed_covar=prediction.fixed_covar)
        if self.resampler is not None:
            update = self.resampler.resample(update)
        return update
