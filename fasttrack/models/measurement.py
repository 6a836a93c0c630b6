"""Measurement models: z = h(x) + v, v ~ N(0, R), with angle components wrapped to [-pi, pi)
wherever a difference of angles is formed.

Parameters may be assigned after construction (a moving sensor changes its
``translation_offset`` every step): each assignment is validated and honoured by every
method and filter from the next call. Array parameters are stored read-only, so they
cannot be changed in place behind the model's back; the dimensions (``ndim_state``,
``ndim_meas``) and a user model's function are fixed.
"""
import numpy as np

from .. import _validate
from ..core import particle as _particle
from .base import (UserFunction, check_rows, gaussian_noise, read_only, scalar_or_array,
                   state_columns, wrap_angle)
from .spec import BEARING, BEARING_RANGE, FUNCTION, SELECT, MeasurementSpec

#: The largest angle a measurement may hold, radians (wrapping it to [-pi, pi) keeps about
#: 7 digits; :data:`fasttrack._validate.LARGEST_ANGLE`).
LARGEST_ANGLE = _validate.LARGEST_ANGLE

__all__ = [
    "MeasurementModel", "LinearGaussian", "CartesianToBearingRange", "Cartesian2DToBearing",
    "NonlinearGaussianMeasurement",
]


def rotation_matrix(rotation_offset):
    """The 3x3 sensor rotation ``Rx(-roll) Ry(pitch) Rz(-yaw)`` of angles (roll, pitch, yaw)."""
    roll, pitch, yaw = np.ravel(rotation_offset)

    def rot(axis, theta):
        c, s = np.cos(theta), np.sin(theta)
        matrix = np.eye(3)
        i, j = [k for k in range(3) if k != axis]
        matrix[i, i], matrix[i, j], matrix[j, i], matrix[j, j] = c, -s, s, c
        if axis == 1:
            matrix[i, j], matrix[j, i] = s, -s
        return matrix

    return rot(0, -roll) @ rot(1, pitch) @ rot(2, -yaw)


def _components(value, name, size, what):
    """A finite (size,) float64 copy of a (size,) or (size, 1) array_like; ``what``
    describes the entries in the error."""
    array = _validate.finite_array(value, name)
    if array.size != size or array.ndim > 2 or (array.ndim == 2 and array.shape[1] != 1):
        raise ValueError(f"{name} must have {what}, got shape {array.shape}")
    return array.ravel().copy()


class MeasurementModel:
    """Base class of the measurement models.

    Attributes: ``ndim_state``, ``ndim_meas``, ``mapping``, ``noise_covar`` (R) and
    ``angle_components`` (the measurement rows that are angles).

    Parameters
    ----------
    ndim_state : int
        Number of state dimensions d, >= 1.
    noise_covar : (m, m) array_like
        R, symmetric positive semi-definite.
    ndim_meas : int
        Number of measurement dimensions m (the size of ``noise_covar``).
    """

    angle_components = ()
    #: The checked user function (:class:`~fasttrack.models.base.UserFunction`) of a model
    #: built from one, else None.
    _function = None

    def __init__(self, ndim_state, noise_covar, ndim_meas):
        self._ndim_state = _validate.count(ndim_state, "ndim_state")
        self._ndim_meas = ndim_meas
        self._angles = np.array([r in self.angle_components for r in range(ndim_meas)],
                                dtype=np.bool_)
        self.noise_covar = noise_covar

    ndim_state = property(lambda self: self._ndim_state,
                          doc="Number of state dimensions d (fixed).")
    ndim_meas = property(lambda self: self._ndim_meas,
                         doc="Number of measurement dimensions m (fixed).")

    @property
    def noise_covar(self):
        """R (m, m), symmetric positive semi-definite (positive definite for densities and
        Kalman updates); read-only array, assign a new one to change it."""
        return self._public_noise_covar

    @noise_covar.setter
    def noise_covar(self, value):
        covar = _validate.psd_covariance(value, "noise_covar", self.ndim_meas).copy()
        self._noise_covar = covar
        self._public_noise_covar = read_only(covar)
        self._noise = gaussian_noise(covar, "noise_covar")
        self._refresh()

    def _refresh(self):
        """Forget the spec after a parameter changed."""
        self.__dict__.pop("_spec", None)

    @property
    def spec(self):
        """The :class:`~fasttrack.models.spec.MeasurementSpec` the array layer reads (rebuilt
        after a parameter changes)."""
        spec = self.__dict__.get("_spec")
        if spec is None:
            spec = self._spec = self._build_spec()
        return spec

    def _build_spec(self):
        raise NotImplementedError

    def _predict(self, x):
        return _particle.measure(self.spec, x)

    def covar(self, **kwargs):
        """R (m, m).

        Parameters
        ----------
        **kwargs : dict
            Ignored (accepted for Stone Soup's call signature).
        """
        return self.noise_covar

    def _columns(self, state, name="state"):
        x = state_columns(state, name)
        check_rows(x, self.ndim_state, name)
        return x

    def measurement_column(self, measurement, name="measurement"):
        """The measurement as an (m, 1) float64 C-contiguous array, not checked for NaN (the
        Kalman kernels check it): the detection's own array when it is one.

        Parameters
        ----------
        measurement : Detection or (m,) / (m, 1) array_like
        name : str
            Name of the measurement in error messages.

        Returns
        -------
        (m, 1) float64 ndarray
        """
        z = getattr(measurement, "state_vector", measurement)
        if not (type(z) is np.ndarray and z.shape == (self._ndim_meas, 1)
                and z.dtype == np.float64 and z.flags.c_contiguous):
            z = _validate.float_array(z, name)
            if z.ndim not in (1, 2) or z.size != self.ndim_meas \
                    or (z.ndim == 2 and z.shape[1] != 1):
                raise ValueError(f"{name} must have {self.ndim_meas} components, as a "
                                 f"({self.ndim_meas},) or ({self.ndim_meas}, 1) array, for "
                                 f"{type(self).__name__}, got shape {z.shape}")
            z = np.ascontiguousarray(z.reshape(-1, 1))
        for r in self.angle_components:
            if abs(z[r, 0]) > LARGEST_ANGLE:
                self._check_angles(z[:, 0], name)
        return z

    def measurement_vector(self, measurement, name="measurement"):
        """A finite (m,) float64 vector from a Detection or array_like.

        Parameters
        ----------
        measurement : Detection or (m,) / (m, 1) array_like
        name : str
            Name of the measurement in error messages.

        Returns
        -------
        (m,) float64 ndarray
        """
        z = _validate.finite_array(getattr(measurement, "state_vector", measurement), name)
        if z.ndim not in (1, 2) or z.size != self.ndim_meas or (z.ndim == 2 and z.shape[1] != 1):
            raise ValueError(f"{name} must have {self.ndim_meas} components, as a "
                             f"({self.ndim_meas},) or ({self.ndim_meas}, 1) array, for "
                             f"{type(self).__name__}, got shape {z.shape}")
        z = np.ascontiguousarray(z.reshape(-1))
        if self.angle_components:
            self._check_angles(z, name)
        return z

    def check_angle_columns(self, z, name):
        """Refuse measurements whose angles are beyond :data:`LARGEST_ANGLE` rad (wrapped
        in float64, they would keep fewer than 7 digits).

        Parameters
        ----------
        z : (..., m) float64 ndarray
            Measurements, one a row.
        name : str
            Their name in the error message.

        Raises
        ------
        ValueError
            If an angle component of a row is beyond :data:`LARGEST_ANGLE`.
        """
        _validate.angle_columns(z, self._angles, name)

    def _check_angles(self, z, name):
        """A ValueError naming ``name`` if an angle of the (m,) measurement ``z`` is beyond
        :data:`LARGEST_ANGLE` (wrapped in float64, it would lose its digits)."""
        for r in self.angle_components:
            if abs(z[r]) > LARGEST_ANGLE:
                raise ValueError(f"{name}[{r}] is an angle of {z[r]:.3g} rad: angles must lie "
                                 f"within +-{LARGEST_ANGLE:.0e} rad (wrapped to [-pi, pi) in "
                                 f"float64, a larger one keeps fewer than 7 digits)")

    def wrap(self, values):
        """Wrap the angle rows of (m, N) ``values`` to [-pi, pi), in place; returns them.

        Parameters
        ----------
        values : (m, N) float64 ndarray
            Measurements (or differences of measurements), one per column; modified.

        Returns
        -------
        (m, N) float64 ndarray
            ``values`` itself.
        """
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
            noise = _validate.finite_array(noise, "noise")
            if noise.shape not in ((self.ndim_meas, x.shape[1]), (self.ndim_meas, 1),
                                   (self.ndim_meas,)):
                raise ValueError(f"noise must have shape {(self.ndim_meas, x.shape[1])}, "
                                 f"got {noise.shape}")
            out += noise.reshape(self.ndim_meas, -1)
        return self.wrap(out)

    def rvs(self, num_samples=1, rng=None):
        """(m, num_samples) draws of the measurement noise v ~ N(0, R).

        Parameters
        ----------
        num_samples : int
            Number of draws, >= 1.
        rng : None, int or numpy.random.Generator
            Source of the draws (None: the package default generator).

        Returns
        -------
        (m, num_samples) float64 ndarray
        """
        return self._noise.sample(_validate.count(num_samples, "num_samples"), rng)

    def logpdf(self, measurement, state):
        """Log density of ``measurement`` given each column of ``state`` (a float for one
        column); angle components of the innovation are wrapped.

        Parameters
        ----------
        measurement : Detection or (m,) / (m, 1) array_like
        state : state object or (d,) / (d, N) array_like
            The states conditioned on, one per column.

        Returns
        -------
        float or (N,) float64 ndarray
        """
        z = self.measurement_vector(measurement)
        x = self._columns(state)
        zeros = np.zeros(x.shape[1])
        out = np.empty(x.shape[1])
        self.log_likelihood(z, x, zeros, out)
        return scalar_or_array(out)

    def pdf(self, measurement, state):
        """Density of ``measurement`` given each column of ``state``.

        Parameters
        ----------
        measurement : Detection or (m,) / (m, 1) array_like
        state : state object or (d,) / (d, N) array_like
            The states conditioned on, one per column.

        Returns
        -------
        float or (N,) float64 ndarray
        """
        return np.exp(self.logpdf(measurement, state))

    def log_likelihood(self, z, x, log_w, out):
        """``out = log_w + log p(z | x[:, i])`` for a validated (m,) z and (d, N) x; returns
        ``max(out)``. The hot step of the particle updater, in one kernel.

        Parameters
        ----------
        z : (m,) float64 ndarray
            The measurement, as :meth:`measurement_vector` returns it.
        x : (d, N) float64 ndarray
            States, one per column, finite (as a state's ``state_vector``).
        log_w : (N,) float64 ndarray
            Log weights added to the log likelihoods.
        out : (N,) float64 ndarray
            Written with the result.

        Returns
        -------
        float
            The largest entry of ``out``.
        """
        return _particle.log_likelihood(self.spec, z, x, log_w, out)


class _KernelModel(MeasurementModel):
    """A built-in model: a kernel kind plus mapping, offset and rotation arrays."""

    kind = None

    def _build_spec(self):
        return MeasurementSpec(self.kind, self._mapping, self._offset, self._rotation,
                               self._noise_covar, self._angles, self._noise, None,
                               self._ndim_state, self._ndim_meas)


class LinearGaussian(_KernelModel):
    """z = H x + v: the ``mapping`` components of the state, with noise R.

    Parameters
    ----------
    ndim_state : int
    mapping : sequence of int
        The state components measured, in measurement order (may be reassigned with the
        same number of components).
    noise_covar : (m, m) array_like
    """

    kind = SELECT

    def __init__(self, ndim_state, mapping, noise_covar):
        ndim_state = _validate.count(ndim_state, "ndim_state")
        mapping = _validate.indices(mapping, "mapping", ndim_state, minimum=1)
        self._offset = np.zeros(2)
        self._rotation = np.eye(2)
        super().__init__(ndim_state, noise_covar, len(mapping))
        self.mapping = mapping

    @property
    def mapping(self):
        """The measured state components (a tuple of ints)."""
        return self._mapping_tuple

    @mapping.setter
    def mapping(self, value):
        mapping = _validate.indices(value, "mapping", self.ndim_state, minimum=1)
        if len(mapping) != self.ndim_meas:
            raise ValueError(f"mapping must keep {self.ndim_meas} components (the size of "
                             f"noise_covar), got {mapping}")
        self._mapping_tuple = mapping
        self._mapping = np.array(mapping, dtype=np.int64)
        self._refresh()

    def matrix(self, **kwargs):
        """H (m, d).

        Parameters
        ----------
        **kwargs : dict
            Ignored (accepted for Stone Soup's call signature).
        """
        h = np.zeros((self.ndim_meas, self.ndim_state))
        h[np.arange(self.ndim_meas), self.mapping] = 1.0
        return h

    def jacobian(self, state=None, **kwargs):
        """H (m, d) (the model is linear).

        Parameters
        ----------
        state : state object or array_like, optional
            Ignored: the Jacobian is the same at every state.
        **kwargs : dict
            Ignored (accepted for Stone Soup's call signature).
        """
        return self.matrix()


class _PolarSensor(_KernelModel):
    """A sensor at ``translation_offset`` with orientation ``rotation_offset`` measuring the
    bearing (and range) of the position ``x[mapping]``."""

    angle_components = (0,)

    def __init__(self, ndim_state, mapping, noise_covar, translation_offset=None,
                 rotation_offset=None):
        ndim_state = _validate.count(ndim_state, "ndim_state")
        super().__init__(ndim_state, noise_covar, self._NDIM_MEAS)
        self.mapping = mapping
        self.translation_offset = np.zeros(2) if translation_offset is None \
            else translation_offset
        self.rotation_offset = np.zeros(3) if rotation_offset is None else rotation_offset

    @property
    def mapping(self):
        """The state indices (x, y) of the position (a tuple of 2 ints)."""
        return self._mapping_tuple

    @mapping.setter
    def mapping(self, value):
        mapping = _validate.indices(value, "mapping", self.ndim_state)
        if len(mapping) != 2:
            raise ValueError(f"mapping must give the 2 state indices (x, y) of the position, "
                             f"got {mapping}")
        self._mapping_tuple = mapping
        self._mapping = np.array(mapping, dtype=np.int64)
        self._refresh()

    @property
    def translation_offset(self):
        """Sensor position (2, 1) (read-only array; assign a new one to move the sensor)."""
        return self._translation

    @translation_offset.setter
    def translation_offset(self, value):
        self._offset = _components(value, "translation_offset", 2, "2 components (x, y)")
        self._translation = read_only(self._offset.reshape(2, 1))
        self._refresh()

    @property
    def rotation_offset(self):
        """Sensor orientation (roll, pitch, yaw) in rad (3, 1) (read-only array)."""
        return self._rotation_angles

    @rotation_offset.setter
    def rotation_offset(self, value):
        angles = _components(value, "rotation_offset", 3, "3 angles (roll, pitch, yaw)")
        self._rotation_angles = read_only(angles.reshape(3, 1))
        matrix = rotation_matrix(angles)
        self._rotation_matrix = read_only(matrix)
        self._rotation = np.ascontiguousarray(matrix[:2, :2])
        self._refresh()

    @property
    def rotation_matrix(self):
        """The (3, 3) rotation of ``rotation_offset`` (derived, read-only)."""
        return self._rotation_matrix


class CartesianToBearingRange(_PolarSensor):
    """z = (bearing, range) of the position ``x[mapping]`` seen from a sensor at
    ``translation_offset`` rotated by ``rotation_offset``; the bearing (rad) is an angle.

    Parameters
    ----------
    ndim_state : int
    mapping : sequence of 2 int
        State indices of x and y.
    noise_covar : (2, 2) array_like
        R for (bearing in rad, range in state units).
    translation_offset : (2,) array_like, optional
        Sensor position (default the origin).
    rotation_offset : (3,) array_like, optional
        Sensor (roll, pitch, yaw) in rad (default zeros). Roll and pitch project the
        position into the sensor's plane; :meth:`inverse_function` needs them zero.
    """

    kind = BEARING_RANGE
    _NDIM_MEAS = 2

    def inverse_function(self, detection):
        """The state (d, K) whose position gives each measurement column (other state
        components 0).

        Parameters
        ----------
        detection : Detection or (2,) / (2, K) array_like
            Measurements (bearing in rad, range), one per column.

        Returns
        -------
        (d, K) float64 ndarray

        Raises
        ------
        ValueError
            If the sensor has roll or pitch, whose projection cannot be inverted.
        """
        if self.rotation_offset[0, 0] != 0 or self.rotation_offset[1, 0] != 0:
            raise ValueError("inverse_function needs a sensor without roll or pitch "
                             f"(rotation_offset {self.rotation_offset.ravel()})")
        z = _validate.finite_array(getattr(detection, "state_vector", detection), "detection")
        if z.size == 0 or z.size % 2 or z.ndim > 2 or (z.ndim == 2 and z.shape[0] != 2):
            raise ValueError(f"detection must have shape (2,) or (2, K), got {z.shape}")
        z = z.reshape(2, -1)
        xy = np.vstack([z[1] * np.cos(z[0]), z[1] * np.sin(z[0])])
        xy = np.linalg.inv(self._rotation) @ xy + self._offset[:, None]
        state = np.zeros((self.ndim_state, z.shape[1]))
        state[list(self.mapping)] = xy
        return state


class Cartesian2DToBearing(_PolarSensor):
    """z = bearing (rad, an angle) of the position ``x[mapping]`` seen from a sensor at
    ``translation_offset`` rotated by ``rotation_offset``; parameters as
    :class:`CartesianToBearingRange` with a (1, 1) ``noise_covar``.

    Parameters
    ----------
    ndim_state : int
    mapping : sequence of 2 int
        State indices of x and y.
    noise_covar : (1, 1) array_like
        R of the bearing (rad).
    translation_offset : (2,) array_like, optional
        Sensor position (default the origin).
    rotation_offset : (3,) array_like, optional
        Sensor (roll, pitch, yaw) in rad (default zeros), as
        :class:`CartesianToBearingRange`.
    """

    kind = BEARING
    _NDIM_MEAS = 1


class NonlinearGaussianMeasurement(MeasurementModel):
    """A measurement built from a user's Numba function, with additive Gaussian noise.

    Parameters
    ----------
    function : numba.njit function ``h(states) -> measurements``
        ``states`` is a C-contiguous (d, n) float64 array, one state per column (a block
        of particles, or one state); it returns an (m, n) float64 array. It is compiled
        and tried on a probe at construction, and its output is checked on every call
        (shape, finite values): see :class:`~fasttrack.models.base.UserFunction`.
    ndim_state : int
        d.
    noise_covar : (m, m) array_like
        R.
    angle_components : sequence of int, optional
        Measurement rows that are angles (wrapped to [-pi, pi)).
    """

    def __init__(self, function, ndim_state, noise_covar, angle_components=()):
        ndim_state = _validate.count(ndim_state, "ndim_state")
        covar = _validate.finite_array(noise_covar, "noise_covar", 2)
        self._angle_components = _validate.indices(angle_components, "angle_components",
                                                   covar.shape[0])
        super().__init__(ndim_state, covar, covar.shape[0])
        self._function = UserFunction(function, "measurement function", ndim_state,
                                      covar.shape[0], interval=False)

    angle_components = property(lambda self: self._angle_components,
                                doc="Measurement rows that are angles (fixed).")
    measurement_function = property(lambda self: self._function.function,
                                    doc="The user's function h (fixed).")

    def _build_spec(self):
        none = np.empty(0)
        return MeasurementSpec(FUNCTION, none.astype(np.int64), none, none.reshape(0, 0),
                               self._noise_covar, self._angles, self._noise, self._function,
                               self._ndim_state, self._ndim_meas)
