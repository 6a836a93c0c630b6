"""Particle resamplers with Stone Soup's names and call pattern:
``resampler.resample(particles, nparts=None)``."""
import numbers

from . import _buffers, _validate
from ._validate import Setting
from . import random as _random
from .core import particle as _particle
from .core.resample import ResidualMethod, draw
from .types import as_particle_state


class Resampler:
    """Base class of the resamplers: ``resample(particles, nparts=None)``."""

    def resample(self, particles, nparts=None):
        """Resample ``particles`` (implemented by each subclass).

        Parameters
        ----------
        particles : ParticleState or list of Particle
        nparts : int, optional
            Number of particles out, >= 1 (default: as many as in).

        Returns
        -------
        ParticleState
        """
        raise NotImplementedError


class _SchemeResampler(Resampler):
    """Draws ancestors with ``method`` (and ``residual``) and builds the resampled state.

    Parameters
    ----------
    rng : None, int or numpy.random.Generator
        Source of randomness (None: the package default generator, see
        :func:`fasttrack.seed`).
    """

    method = ResidualMethod.SYSTEMATIC
    residual = False

    def __init__(self, rng=None):
        self.rng = _random.check_rng(rng)

    def resample(self, particles, nparts=None):
        """Resample to ``nparts`` equally weighted particles.

        Parameters
        ----------
        particles : ParticleState or list of Particle
        nparts : int, optional
            Number of particles out, >= 1 (default: as many as in).

        Returns
        -------
        ParticleState
            Same type as the input, other attributes shared with it; ``state_vector`` holds
            the drawn columns (ancestor indices ascending), ``log_weight`` is ``-log(nparts)``
            (one read-only array, shared by the states resampled to this size: assign a new
            array to change it), and ``parent`` is the input's parent indexed by the same
            ancestors (its own parent dropped), or None.
        """
        state = as_particle_state(particles)
        parent = state.parent
        if parent is not None and len(parent) != len(state):
            raise ValueError(f"particles.parent has {len(parent)} particles, "
                             f"particles has {len(state)}")
        idx, columns = draw(state.log_weight, nparts, self.method, self.residual, self.rng,
                            columns=state.state_vector, name="particles.log_weight",
                            compact=True)
        return state._replace(state_vector=columns,
                              log_weight=_buffers.uniform_log_weights(idx.size),
                              parent=None if parent is None else parent._indexed(idx))


class SystematicResampler(_SchemeResampler):
    """Systematic resampling: points ``(j + u) / n`` for a single uniform u; each particle
    gets ``floor(n w_i)`` or ``ceil(n w_i)`` copies.

    Parameters
    ----------
    rng : None, int or numpy.random.Generator
        Source of randomness (None: the package default generator, see
        :func:`fasttrack.seed`).
    """

    method = ResidualMethod.SYSTEMATIC


class StratifiedResampler(_SchemeResampler):
    """Stratified resampling: one uniform point in each stratum ``[j/n, (j+1)/n)``.

    Parameters
    ----------
    rng : None, int or numpy.random.Generator
        Source of randomness (None: the package default generator, see
        :func:`fasttrack.seed`).
    """

    method = ResidualMethod.STRATIFIED


class MultinomialResampler(_SchemeResampler):
    """Multinomial resampling: ``nparts`` independent draws from the weights.

    Parameters
    ----------
    rng : None, int or numpy.random.Generator
        Source of randomness (None: the package default generator, see
        :func:`fasttrack.seed`).
    """

    method = ResidualMethod.MULTINOMIAL


class ResidualResampler(_SchemeResampler):
    """Residual resampling: ``floor(n w_i)`` copies of each particle, the remaining draws
    from the residual weights ``n w_i - floor(n w_i)``.

    Works for any weights, including when every ``n w_i < 1``, and for any ``nparts``.

    Parameters
    ----------
    residual_method : str or fasttrack.resampling.ResidualMethod
        Scheme of the second stage: 'multinomial', 'systematic' or 'stratified', or the
        member.
    rng : None, int or numpy.random.Generator
        Source of randomness (None: the package default generator, see
        :func:`fasttrack.seed`).
    """

    residual = True

    def __init__(self, residual_method=ResidualMethod.MULTINOMIAL, rng=None):
        super().__init__(rng)
        self.residual_method = residual_method

    #: The scheme (checked when assigned, here or later).
    residual_method = Setting(ResidualMethod.parse)

    @property
    def method(self):
        return self.residual_method


class ESSResampler(Resampler):
    """Resample only when Kish's effective sample size ``(sum w)**2 / sum(w**2)`` is below
    a threshold.

    Parameters
    ----------
    threshold : float, optional
        Resample when ESS < threshold (> 0). Default: half the number of particles of each
        call (computed per call, so it follows N).
    resampler : Resampler, optional
        The resampler used when it resamples (default: a :class:`SystematicResampler`).
    """

    def __init__(self, threshold=None, resampler=None):
        self.threshold = threshold
        self.resampler = SystematicResampler() if resampler is None else resampler

    # Settings, checked when assigned (here or later).
    threshold = Setting("_checked_threshold")
    resampler = Setting("_checked_resampler")

    @staticmethod
    def _checked_threshold(threshold, name):
        if threshold is None:
            return None
        if not isinstance(threshold, numbers.Real) or isinstance(threshold, bool):
            raise TypeError(f"{name} must be a number or None, got {type(threshold).__name__}")
        threshold = _validate.real(threshold, name)
        if not threshold > 0:
            raise ValueError(f"{name} must be finite and > 0 (an ESS is >= 1), got {threshold}")
        return threshold

    @staticmethod
    def _checked_resampler(resampler, name):
        if isinstance(resampler, type) or not callable(getattr(resampler, "resample", None)):
            raise TypeError(f"{name} must be a resampler (an object with a resample method, "
                            f"e.g. SystematicResampler()), got {resampler!r}")
        return resampler

    def resample(self, particles, nparts=None):
        """``resampler.resample(particles, nparts)`` if the ESS is below the threshold,
        otherwise the input state itself (the same object; a list of Particle is returned as
        the ParticleState built from it) and ``nparts`` is ignored.

        Parameters
        ----------
        particles : ParticleState or list of Particle
        nparts : int, optional
            Number of particles out when it resamples, >= 1 (default: as many as in).

        Returns
        -------
        ParticleState
        """
        state = as_particle_state(particles)
        if _particle.resampling_decision(state.log_weight, self.threshold)[1]:
            return self.resampler.resample(state, nparts)
        return state
