"""Measurement models: z = h(x) + v, v ~ N(0, R), with angle components wrapped to [-pi, pi)
wherever a difference of angles is formed."""
import numpy as np

from .. import _validate
from .._jit import likelihood as _kernels
from .base import check_rows, gaussian_noise, scalar_or_array, state_columns, wrap_angle


def _mapping(mapping, ndim_state, minimum=1):
    try:
        values = tuple(int(m) for m in mapping)
    except TypeError:
        raise TypeError(f"mapping must be a sequence of state indices, "
                        f"got {type(mapping).__name__}") from None
    if len(values) < minimum:
        raise ValueError(f"mapping needs at least {minimum} state indices, got {values}")
    if any(not 0 <= m < ndim_state for m in values):
        raise ValueError(f"mapping indices must lie in [0, {ndim_state}), got {values}")
    return values


def rotation_matrix(rotation_offset):
    """The 3x3 sensor rotation ``Rx(-roll) Ry(pitch) Rz(-yaw)`` of angles (roll, pitch, yaw)."""
    roll, pitch, yaw = rotation_offset

    def rot(axis, theta):
        c, s = np.cos(theta), np.sin(theta)
        matrix = np.eye(3)
        i, j = [k for k in range(3) if k != axis]
        matrix[i, i], matrix[i, j], matrix[j, i], matrix[j, j] = c, -s, s, c
        if axis == 1:
            matrix[i, j], matrix[j, i] = s, -s
        return matrix

    return rot(0, -roll) @ rot(1, pitch) @ rot(2, -yaw)


class MeasurementModel:
    """Base class of the measurement models.

    Attributes: ``ndim_state``, ``ndim_meas``, ``mapping``, ``noise_covar`` (R) and
    ``angle_components`` (the measurement rows that are angles).
    """

    angle_components = ()

    def __init__(self, ndim_state, noise_covar, ndim_meas):
        self.ndim_state = _validate.count(ndim_state, "ndim_state")
        self.ndim_meas = ndim_meas
        self.noise_covar = _validate.covariance(noise_covar, "noise_covar", ndim_meas)
        self._noise = gaussian_noise(self.noise_covar, "noise_covar")
        self._angles = np.array([r in self.angle_components for r in range(ndim_meas)])

    def covar(self, **kwargs):
        """R (m, m)."""
        return self.noise_covar

    def _columns(self, state, name="state"):
        x = state_columns(state, name)
        check_rows(x, self.ndim_state, name)
        return x

    def measurement_column(self, measurement, name="measurement"):
        """The measurement as an (m, 1) float64 C-contiguous array, not checked for NaN (the
        Kalman kernels check it): the detection's own array when it is one."""
        z = getattr(measurement, "state_vector", measurement)
        if type(z) is np.ndarray and z.shape == (self.ndim_meas, 1) \
                and z.dtype == np.float64 and z.flags.c_contiguous:
            return z
        z = _validate.float_array(z, name)
        if z.size != self.ndim_meas or (z.ndim == 2 and z.shape[1] != 1) or z.ndim > 2:
            raise ValueError(f"{name} must have {self.ndim_meas} components for "
                             f"{type(self).__name__}, got shape {z.shape}")
        return np.ascontiguousarray(z.reshape(-1, 1))

    def measurement_vector(self, measurement, name="measurement"):
        """A finite (m,) float64 vector from a Detection or array_like."""
        z = _validate.finite_array(getattr(measurement, "state_vector", measurement), name)
        if z.size != self.ndim_meas or (z.ndim == 2 and z.shape[1] != 1) or z.ndim > 2:
            raise ValueError(f"{name} must have {self.ndim_meas} components for "
                             f"{type(self).__name__}, got shape {z.shape}")
        return np.ascontiguousarray(z.reshape(-1))

    def wrap(self, values):
        """Wrap the angle rows of (m, N) ``values`` to [-pi, pi), in place; returns them."""
        for r in self.angle_components:
            values[r] = wrap_angle(values[r])
        return values

    def function(self, state, noise=False, rng=None):
        """Predicted measurements of ``state``.

        Parameters
        ----------
        state : state object or (d,) / (d, N) array_like
        noise : bool or (m, N) array_like
            False: noise-free; True: add a draw of the measurement noise from ``rng``; an
            array: add it as given. Angle rows are wrapped after the noise is added.
        rng : None, int or numpy.random.Generator

        Returns
        -------
        (m, N) float64 ndarray
        """
        x = self._columns(state)
        out = self._predict(x)
        if noise is True:
            out += self._noise.sample(x.shape[1], rng)
        elif noise is not False and noise is not None:
            out += _validate.finite_array(noise, "noise")
        return self.wrap(out)

    def rvs(self, num_samples=1, rng=None):
        """(m, num_samples) draws of the measurement noise."""
        return self._noise.sample(_validate.count(num_samples, "num_samples"), rng)

    def logpdf(self, measurement, state):
        """Log density of ``measurement`` given each column of ``state`` (a float for one
        column); angle components of the innovation are wrapped."""
        z = self.measurement_vector(measurement)
        x = self._columns(state)
        zeros = np.zeros(x.shape[1])
        out = np.empty(x.shape[1])
        self.log_likelihood(z, x, zeros, out)
        return scalar_or_array(out)

    def pdf(self, measurement, state):
        """Density of ``measurement`` given each column of ``state``."""
        return np.exp(self.logpdf(measurement, state))

    def log_likelihood(self, z, x, log_w, out):
        """``out = log_w + log p(z | x[:, i])`` for a validated (m,) z and (d, N) x; returns
        ``max(out)``. The hot step of the particle updater, in one kernel."""
        raise NotImplementedError


class _KernelModel(MeasurementModel):
    """A built-in model: a kernel kind plus mapping, offset and rotation arrays."""

    kind = None

    @property
    def _kalman_args(self):
        """The model's arguments to the Kalman kernels."""
        args = self.__dict__.get("_kalman_args_cache")
        if args is None:
            args = (self.kind, self._mapping, self._offset, self._rotation, self.noise_covar,
                    self._angles)
            self.__dict__["_kalman_args_cache"] = args
        return args

    def _predict(self, x):
        out = np.empty((self.ndim_meas, x.shape[1]))
        _kernels.measure(self.kind, x, self._mapping, self._offset, self._rotation, out)
        return out

    def log_likelihood(self, z, x, log_w, out):
        whiten, log_norm = self._noise.whitening()
        return _kernels.log_likelihood(self.kind, z, x, self._mapping, self._offset,
                                       self._rotation, self._angles, whiten, log_norm, log_w,
                                       out)


class LinearGaussian(_KernelModel):
    """z = H x + v: the ``mapping`` components of the state, with noise R.

    Parameters
    ----------
    ndim_state : int
    mapping : sequence of int
        The state components measured, in measurement order.
    noise_covar : (m, m) array_like
    """

    kind = _kernels.SELECT

    def __init__(self, ndim_state, mapping, noise_covar):
        mapping = _mapping(mapping, _validate.count(ndim_state, "ndim_state"))
        super().__init__(ndim_state, noise_covar, len(mapping))
        self.mapping = mapping
        self._mapping = np.array(mapping, dtype=np.int64)
        self._offset = np.zeros(2)
        self._rotation = np.eye(2)

    def matrix(self, **kwargs):
        """H (m, d)."""
        h = np.zeros((self.ndim_meas, self.ndim_state))
        h[np.arange(self.ndim_meas), self.mapping] = 1.0
        return h

    def jacobian(self, state=None, **kwargs):
        """H (the model is linear)."""
        return self.matrix()


class _PolarSensor(_KernelModel):
    """A sensor at ``translation_offset`` with orientation ``rotation_offset`` measuring the
    bearing (and range) of the position ``x[mapping[:2]]``."""

    angle_components = (0,)

    def __init__(self, ndim_state, mapping, noise_covar, translation_offset=None,
                 rotation_offset=None):
        mapping = _mapping(mapping, _validate.count(ndim_state, "ndim_state"), minimum=2)
        super().__init__(ndim_state, noise_covar, self.ndim_meas)
        self.mapping = mapping
        self._mapping = np.array(mapping[:2], dtype=np.int64)
        offset = np.zeros(2) if translation_offset is None else _validate.finite_array(
            translation_offset, "translation_offset").ravel()
        if offset.size != 2:
            raise ValueError(f"translation_offset must have 2 components (x, y), "
                             f"got {offset.size}")
        self.translation_offset = offset.reshape(2, 1)
        self._offset = offset
        angles = np.zeros(3) if rotation_offset is None else _validate.finite_array(
            rotation_offset, "rotation_offset").ravel()
        if angles.size != 3:
            raise ValueError(f"rotation_offset must have 3 angles (roll, pitch, yaw), "
                             f"got {angles.size}")
        self.rotation_offset = angles.reshape(3, 1)
        self.rotation_matrix = rotation_matrix(angles)
        self._rotation = np.ascontiguousarray(self.rotation_matrix[:2, :2])


class CartesianToBearingRange(_PolarSensor):
    """z = (bearing, range) of the position ``x[mapping[:2]]`` seen from a sensor at
    ``translation_offset`` rotated by ``rotation_offset``; the bearing (rad) is an angle.

    Parameters
    ----------
    ndim_state : int
    mapping : sequence of int
        State indices of x and y.
    noise_covar : (2, 2) array_like
        R for (bearing in rad, range in state units).
    translation_offset : (2,) array_like, optional
        Sensor position (default the origin).
    rotation_offset : (3,) array_like, optional
        Sensor (roll, pitch, yaw) in rad (default zeros). Roll and pitch project the
        position into the sensor's plane; :meth:`inverse_function` needs them zero.
    """

    kind = _kernels.BEARING_RANGE
    ndim_meas = 2

    def inverse_function(self, detection):
        """The state (d, K) whose position gives each measurement column (other state
        components 0).

        Raises ValueError if the sensor has roll or pitch, whose projection cannot be
        inverted.
        """
        if self.rotation_offset[0, 0] != 0 or self.rotation_offset[1, 0] != 0:
            raise ValueError("inverse_function needs a sensor without roll or pitch "
                             f"(rotation_offset {self.rotation_offset.ravel()})")
        z = _validate.finite_array(getattr(detection, "state_vector", detection), "detection")
        z = z.reshape(2, -1)
        xy = np.vstack([z[1] * np.cos(z[0]), z[1] * np.sin(z[0])])
        xy = np.linalg.inv(self._rotation) @ xy + self._offset[:, None]
        state = np.zeros((self.ndim_state, z.shape[1]))
        state[list(self.mapping[:2])] = xy
        return state


class Cartesian2DToBearing(_PolarSensor):
    """z = bearing (rad, an angle) of the position ``x[mapping[:2]]``; parameters as
    :class:`CartesianToBearingRange` with a (1, 1) ``noise_covar``."""

    kind = _kernels.BEARING
    ndim_meas = 1


class NonlinearGaussianMeasurement(MeasurementModel):
    """A measurement built from a user's Numba function, with additive Gaussian noise.

    Parameters
    ----------
    function : numba.njit function ``h(states) -> measurements``
        ``states`` is a (d, n) float64 array (a block of particles, or one state as a
        column); returns an (m, n) float64 array.
    ndim_state : int
        d.
    noise_covar : (m, m) array_like
        R.
    angle_components : sequence of int, optional
        Measurement rows that are angles (wrapped to [-pi, pi)).
    """

    def __init__(self, function, ndim_state, noise_covar, angle_components=()):
        if not hasattr(function, "py_func"):
            raise TypeError("function must be a numba.njit function h(states)")
        covar = _validate.finite_array(noise_covar, "noise_covar", 2)
        self.angle_components = tuple(int(a) for a in angle_components)
        if any(not 0 <= a < covar.shape[0] for a in self.angle_components):
            raise ValueError(f"angle_components must lie in [0, {covar.shape[0]}), "
                             f"got {self.angle_components}")
        super().__init__(ndim_state, covar, covar.shape[0])
        self.measurement_function = function

    def _predict(self, x):
        out = np.empty((self.ndim_meas, x.shape[1]))
        _kernels.measure_function(self.measurement_function, x, self._angles, out)
        return out

    def log_likelihood(self, z, x, log_w, out):
        whiten, log_norm = self._noise.whitening()
        return _kernels.log_likelihood_function(self.measurement_function, z, x, self._angles,
                                                whiten, log_norm, log_w, out)
