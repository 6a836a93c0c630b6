"""Stone Soup's resamplers, with fasttrack's kernels: same classes, same states in and out."""
import copy

import numpy as np
from stonesoup.base import Property
from stonesoup.resampler import particle as ss
from stonesoup.resampler.base import Resampler
from stonesoup.types.array import StateVectors
from stonesoup.types.state import ParticleState

from ..core import resample as _resampling
from ..core import particle as ft_particle
from ._convert import floats, global_rng, plain_particles

ResidualMethod = ss.ResidualMethod


def _indexed(state, index, log_weight):
    """``state[index]`` as Stone Soup builds it (parent indexed too, its own parent dropped),
    with the columns gathered by a parallel kernel, and ``log_weight`` set."""
    if not plain_particles(state) or state.state_vector.dtype != np.float64:
        result = state[index]
        result.log_weight = log_weight
        return result
    parent = None
    if state.parent is not None:
        parent = copy.copy(state.parent)
        parent.parent = None
        parent_weight = None if parent.log_weight is None else parent.log_weight[index]
        parent = _indexed(parent, index, parent_weight)
    return type(state).from_state(state, state_vector=StateVectors(
                                      ft_particle.gather(floats(state.state_vector), index)),
                                  log_weight=log_weight, parent=parent)


class _Scheme:
    """``resample`` for a fasttrack scheme: indices from the compiled kernels, keyed by
    NumPy's global random state; weights normalised first (Stone Soup assumes they are)."""

    _method = _resampling.ResidualMethod.SYSTEMATIC
    _residual = False

    def resample(self, particles, nparts=None):
        """Resample ``particles`` (a ParticleState or list of Particle) to ``nparts``
        (default: as many) equally weighted particles of the same state type."""
        if isinstance(particles, list):
            particles = ParticleState(None, particle_list=particles)
        index = _resampling.draw(particles.log_weight, nparts, self._scheme(), self._residual,
                                 global_rng(), name="particles.log_weight")
        # log(1/N) as Stone Soup stores it (-log N can differ in the last bit)
        return _indexed(particles, index, np.full(index.size, np.log(1 / index.size)))

    def _scheme(self):
        return self._method


class SystematicResampler(_Scheme, ss.SystematicResampler):
    """Stone Soup's ``SystematicResampler``, compiled."""


class StratifiedResampler(_Scheme, ss.StratifiedResampler):
    """Stone Soup's ``StratifiedResampler``, compiled."""

    _method = _resampling.ResidualMethod.STRATIFIED


class MultinomialResampler(_Scheme, ss.MultinomialResampler):
    """Stone Soup's ``MultinomialResampler``, compiled."""

    _method = _resampling.ResidualMethod.MULTINOMIAL


class ResidualResampler(_Scheme, ss.ResidualResampler):
    """Stone Soup's ``ResidualResampler``, compiled; ``residual_method`` may also be the
    method's name ('multinomial', 'systematic', 'stratified'), and any ``nparts`` works."""

    _residual = True

    def _scheme(self):
        return _resampling.ResidualMethod.parse(getattr(self.residual_method, "value",
                                                        self.residual_method))


class ESSResampler(_Scheme, ss.ESSResampler):
    """Stone Soup's ``ESSResampler``: resamples with ``resampler`` when the effective sample
    size is below ``threshold``, else returns ``particles`` itself. A threshold of None means
    N/2 of each call's particles (never stored)."""

    resampler: Resampler = Property(default_factory=SystematicResampler,
                                    doc="Resampler used when the ESS is below the threshold")

    def resample(self, particles, nparts=None):
        if isinstance(particles, list):
            particles = ParticleState(None, particle_list=particles)
        if ft_particle.resampling_decision(particles.log_weight, self.threshold)[1]:
            return self.resampler.resample(particles, nparts)
        return particles
