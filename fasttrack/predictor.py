"""Predictors: ``predictor.predict(prior, timestamp)``."""
from . import random as _random
from .models.transition import TransitionModel
from .types import ParticleState, ParticleStatePrediction, check_timestamp, time_interval


def _interval(prior, timestamp):
    """Seconds from the prior's timestamp to ``timestamp``, with clear errors."""
    check_timestamp(timestamp)
    if timestamp is None:
        raise ValueError("predict needs a timestamp")
    if prior.timestamp is None:
        raise ValueError("the prior has no timestamp, so the prediction interval is unknown")
    return time_interval(timestamp, prior.timestamp)


class ParticlePredictor:
    """Moves every particle through the transition model, with process noise.

    Parameters
    ----------
    transition_model : TransitionModel
    rng : None, int or numpy.random.Generator
        Source of the process noise (None: the package default generator).
    """

    def __init__(self, transition_model, rng=None):
        if not isinstance(transition_model, TransitionModel):
            raise TypeError(f"transition_model must be a TransitionModel, "
                            f"got {type(transition_model).__name__}")
        self.transition_model = transition_model
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
            ``parent`` and ``prior`` both the prior; ``transition_model``; ``timestamp``.
        """
        if not isinstance(prior, ParticleState):
            raise TypeError(f"prior must be a ParticleState, got {type(prior).__name__}")
        if prior.ndim != self.transition_model.ndim_state:
            raise ValueError(f"prior has {prior.ndim} state dimensions, the transition model "
                             f"{self.transition_model.ndim_state}")
        dt = _interval(prior, timestamp)
        particles = self.transition_model._propagate(prior.state_vector, dt,
                                                     _random.stream_key(self.rng))
        return ParticleStatePrediction._trusted(
            particles, prior.log_weight, timestamp=timestamp, parent=prior, prior=prior,
            transition_model=self.transition_model, fixed_covar=prior.fixed_covar)
