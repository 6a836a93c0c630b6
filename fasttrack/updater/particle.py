"""The particle filter's updater."""
from ..core import particle as _particle
from ..resampler import Resampler
from ..types import ParticleState, ParticleStateUpdate, weak
from .base import Updater

__all__ = ["ParticleUpdater"]


class ParticleUpdater(Updater):
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
        super().__init__(measurement_model)
        if resampler is not None and not isinstance(resampler, Resampler):
            raise TypeError(f"resampler must be a Resampler, got {type(resampler).__name__}")
        self.resampler = resampler

    def update(self, hypothesis):
        """The posterior of ``hypothesis.prediction`` given ``hypothesis.measurement``:
        :meth:`weigh`, then the resampler.

        Parameters
        ----------
        hypothesis : SingleHypothesis
            The ``prediction`` (a :class:`~fasttrack.ParticleState`) and the
            ``measurement`` (a :class:`~fasttrack.Detection`, not None).

        Returns
        -------
        ParticleStateUpdate
            Sharing the prediction's ``state_vector`` (unless resampled), with ``hypothesis``,
            ``parent`` = the prediction's parent (its prior, a weak link), and the
            prediction's timestamp.
        """
        update = self.weigh(hypothesis)
        if self.resampler is None:
            return update
        resampled = self.resampler.resample(update)
        resampled.ess, resampled.resampled = update.ess, resampled is not update
        return resampled

    def weigh(self, hypothesis):
        """The posterior before resampling: ``log_weight += log p(z | particle)``,
        normalised with logsumexp.

        Parameters
        ----------
        hypothesis : SingleHypothesis
            The ``prediction`` (a :class:`~fasttrack.ParticleState`) and the
            ``measurement`` (a :class:`~fasttrack.Detection`, not None).

        Returns
        -------
        ParticleStateUpdate
            As :meth:`update` returns it without a resampler.
        """
        self._check_hypothesis(hypothesis)
        prediction = hypothesis.prediction
        self._check_prediction(prediction, ParticleState, "hypothesis.prediction")
        model = self._measurement_model(hypothesis)
        self._check_dimensions(model, prediction)
        z = model.measurement_vector(hypothesis.measurement, "hypothesis.measurement")
        log_w, ess = _particle.weigh(model, z, prediction.state_vector, prediction.log_weight)
        hypothesis._used()
        return ParticleStateUpdate._trusted(
            prediction.state_vector, log_w, timestamp=prediction.timestamp,
            parent=weak(prediction.parent), hypothesis=hypothesis,
            fixed_covar=prediction.fixed_covar, ess=ess)
