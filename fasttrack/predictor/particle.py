"""The particle filter's predictor."""
from .. import random as _random
from ..core import particle as _particle
from ..types import ParticleState, ParticleStatePrediction, weak
from .base import Predictor

__all__ = ["ParticlePredictor"]


class ParticlePredictor(Predictor):
    """Moves every particle through the transition model, with process noise.

    Parameters
    ----------
    transition_model : TransitionModel
    rng : None, int or numpy.random.Generator
        Source of the process noise (None: the package default generator).
    """

    def __init__(self, transition_model, rng=None):
        super().__init__(transition_model)
        self.rng = _random.check_rng(rng)

    def predict(self, prior, timestamp):
        """Propagate ``prior`` to ``timestamp``.

        Parameters
        ----------
        prior : ParticleState
        timestamp : datetime.datetime or float seconds
            Of the same kind as the prior's timestamp.

        Returns
        -------
        ParticleStatePrediction
            New (d, N) particles; the prior's ``log_weight`` array (shared, unchanged);
            ``parent`` and ``prior`` both the prior (weak links: see
            :mod:`fasttrack.types`); ``transition_model``; ``timestamp``.
        """
        self._check_prior(prior, ParticleState, self.transition_model.ndim_state)
        dt = self._interval(prior, timestamp)
        particles = _particle.predict(self.transition_model, prior.state_vector, dt, self.rng)
        link = weak(prior)
        return ParticleStatePrediction._trusted(
            particles, prior.log_weight, timestamp=timestamp, parent=link, _prior=link,
            transition_model=self.transition_model, fixed_covar=prior.fixed_covar)
