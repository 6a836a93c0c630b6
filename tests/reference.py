"""Plain-NumPy mirrors of the kernels in ``fasttrack._jit`` (same names, same arguments,
loops allowed). Tests give both the same inputs, including the same random stream keys,
and compare: integers equal, floats close."""
import numpy as np

# --- numeric -------------------------------------------------------------------------------


def fast_exp(x):
    return np.exp(x)


def fast_log(x):
    return np.log(x)


def uniform(key, counter):
    """SplitMix64 of the Weyl sequence ``key + (counter + 1) * golden``, 53 high bits."""
    counter = np.asarray(counter, dtype=np.uint64)
    with np.errstate(over="ignore"):
        z = np.uint64(key) + (counter + np.uint64(1)) * np.uint64(0x9E3779B97F4A7C15)
        z = (z ^ (z >> np.uint64(30))) * np.uint64(0xBF58476D1CE4E5B9)
        z = (z ^ (z >> np.uint64(27))) * np.uint64(0x94D049BB133111EB)
    z = z ^ (z >> np.uint64(31))
    return (z >> np.uint64(11)).astype(np.float64) * 2.0**-53


def fast_atan2(y, x):
    return np.arctan2(y, x)


def sin_cos_turns(u):
    return np.sin(2 * np.pi * u), np.cos(2 * np.pi * u)


def normal_pairs(key, pairs):
    """The cosine and sine normals of the Box-Muller pairs ``pairs`` of stream ``key``."""
    pairs = np.asarray(pairs, dtype=np.int64)
    radius = np.sqrt(-2.0 * np.log(1.0 - uniform(key, 2 * pairs)))
    turn = 2 * np.pi * uniform(key, 2 * pairs + 1)
    return radius * np.cos(turn), radius * np.sin(turn)


def fill_normals(key, first_pair, out):
    half = out.size // 2
    out[:half], out[half:2 * half] = normal_pairs(key, first_pair + np.arange(half))


def wrap_angle(a):
    """Stone Soup's mod_bearing: ((a + pi) mod 2 pi) - pi."""
    return np.mod(a + np.pi, 2 * np.pi) - np.pi


def cholesky(a, lower):
    try:
        lower[:] = np.linalg.cholesky(a)
    except np.linalg.LinAlgError:
        return False
    return True


def fill(out, value):
    out[...] = value


def copy_into(source, out):
    out.reshape(-1)[:] = source.reshape(-1)


def n_chunks(n):
    return min(max(n // 8192, 1), 4096)


def chunk_bounds(c, k, n):
    return c * n // k, (c + 1) * n // k


def cumulate(w):
    w[:] = np.cumsum(w)


# --- status and user functions -------------------------------------------------------------

OK, PRIOR_NOT_PSD, INNOVATION_NOT_PD, JACOBIAN_UNDEFINED, MEASUREMENT_NOT_FINITE = 0, 1, 2, 3, 4
PREDICTION_NOT_PSD, FUNCTION_SHAPE, FUNCTION_NOT_FINITE = 5, 6, 7
PRIOR_NOT_SYMMETRIC, PREDICTION_NOT_SYMMETRIC = 8, 9


def columns(x, lo, hi):
    return np.ascontiguousarray(x[:, lo:hi])


def store(values, out, lo):
    out[:, lo:lo + values.shape[1]] = values


def output_status(values, rows, cols):
    if values.shape != (rows, cols):
        return FUNCTION_SHAPE
    return OK if np.isfinite(values).all() else FUNCTION_NOT_FINITE


def first_failure(codes):
    bad = [code for code in codes if code != OK]
    return bad[0] if bad else OK


# --- weights -------------------------------------------------------------------------------


def relative_weights(log_w, log_w_max, out):
    out[:] = np.exp(log_w - log_w_max)


def log_sum_exp(log_w, log_w_max):
    return log_w_max + np.log(np.sum(np.exp(log_w - log_w_max)))


def ess(log_w, log_w_max):
    w = np.exp(log_w - log_w_max)
    return w.sum() ** 2 / (w**2).sum()


def weighted_mean(x, log_w, log_w_max, mean):
    w = np.exp(log_w - log_w_max)
    mean[:] = x @ w / w.sum()


def weighted_mean_covar(x, log_w, log_w_max, mean, covar):
    w = np.exp(log_w - log_w_max)
    mean[:] = np.average(x, axis=1, weights=w)
    covar[:] = np.atleast_2d(np.cov(x, ddof=0, aweights=w))


def normalise_in_place(log_w, log_w_max):
    w = np.exp(log_w - log_w_max)
    log_w[:] = (log_w - log_w_max) - np.log(w.sum())
    return w.sum() ** 2 / (w**2).sum()


# --- propagate -----------------------------------------------------------------------------

PROPAGATE_BLOCK = 1024


def _process_noise(noise_root, key, n):
    """S z for n particles, with the kernels' layout of the normals: block b fills
    ``even * BLOCK`` normals (even = d rounded up to even) from pair ``b * BLOCK * even / 2``,
    and component c of its particle i is entry ``c * BLOCK + i``."""
    d = noise_root.shape[0]
    even = d + d % 2
    blocks = -(-n // PROPAGATE_BLOCK)
    z = np.empty((d, blocks * PROPAGATE_BLOCK))
    for b in range(blocks):
        block = np.empty(even * PROPAGATE_BLOCK)
        fill_normals(key, b * PROPAGATE_BLOCK * even // 2, block)
        z[:, b * PROPAGATE_BLOCK:(b + 1) * PROPAGATE_BLOCK] = block[:d * PROPAGATE_BLOCK].reshape(
            d, PROPAGATE_BLOCK)
    return noise_root @ z[:, :n]


def propagate_linear(x, matrix, noise_root, key, out):
    out[:] = matrix @ x
    if np.any(noise_root != 0):
        out += _process_noise(noise_root, key, x.shape[1])


def propagate_function(function, time_interval, x, noise_root, key, out):
    values = function(np.ascontiguousarray(x), time_interval)
    status = output_status(values, x.shape[0], x.shape[1])
    if status == OK:
        out[:] = values
        if np.any(noise_root != 0):
            out += _process_noise(noise_root, key, x.shape[1])
    return status


# --- likelihood ----------------------------------------------------------------------------

SELECT, BEARING_RANGE, BEARING = 0, 1, 2


def measure(kind, x, mapping, offset, rotation, out):
    if kind == SELECT:
        out[:] = x[mapping]
        return
    p = rotation @ (x[mapping[:2]] - offset[:, None])
    out[0] = wrap_angle(np.arctan2(p[1], p[0]))
    if kind == BEARING_RANGE:
        out[1] = np.hypot(p[0], p[1])


def _log_likelihoods(z, predicted, angles, whiten, log_norm, log_w, out):
    innovation = z[:, None] - predicted
    innovation[angles] = wrap_angle(innovation[angles])
    out[:] = log_w + log_norm - 0.5 * np.sum((whiten @ innovation) ** 2, axis=0)
    return np.nan if np.isnan(out).any() else out.max()


def log_likelihood(kind, z, x, mapping, offset, rotation, angles, whiten, log_norm, log_w, out):
    predicted = np.empty((z.size, x.shape[1]))
    measure(kind, x, mapping, offset, rotation, predicted)
    return _log_likelihoods(z, predicted, angles, whiten, log_norm, log_w, out)


def measure_function(function, x, angles, out):
    values = function(np.ascontiguousarray(x))
    status = output_status(values, out.shape[0], x.shape[1])
    if status == OK:
        out[:] = values
        out[angles] = wrap_angle(out[angles])
    return status


def log_likelihood_function(function, z, x, angles, whiten, log_norm, log_w, out):
    values = function(np.ascontiguousarray(x))
    status = output_status(values, z.size, x.shape[1])
    if status != OK:
        return np.nan, status
    return _log_likelihoods(z, values, angles, whiten, log_norm, log_w, out), status


# --- resample ------------------------------------------------------------------------------


def last_nonempty(cdf):
    nonempty = np.flatnonzero(np.diff(cdf) != 0)
    return int(nonempty[-1] + 1) if nonempty.size else 0


def _stratum(bound, scale, n):
    return np.minimum((bound * scale).astype(np.int64), n - 1)


def _starts_frame(cdf, n, starts):
    """Starts of particles no draw reaches, as the kernels set them."""
    last = last_nonempty(cdf)
    starts[0] = 0
    starts[last + 1:] = n
    return last, n / cdf[-1]


def systematic_starts(cdf, n, key, starts):
    last, scale = _starts_frame(cdf, n, starts)
    u = uniform(key, 0)
    starts[1:last + 1] = np.clip(np.ceil(cdf[:last] * scale - u), 0, n).astype(np.int64)


def stratified_starts(cdf, n, key, starts):
    last, scale = _starts_frame(cdf, n, starts)
    y = cdf[:last] * scale
    s = _stratum(cdf[:last], scale, n)
    starts[1:last + 1] = s + (s + uniform(key, s) < y)


def sorted_uniforms(key, n, out):
    spacing = -np.log(1.0 - uniform(key, np.arange(n + 1)))
    total = np.cumsum(spacing)
    out[:n] = np.minimum(total[:n] * (n / total[n]), n)
    out[n] = total[n]


def stratum_occupancy(points, n, occupancy):
    strata = np.minimum(points[:n].astype(np.int64), n - 1)
    occupancy[0] = 0
    occupancy[1:] = np.cumsum(np.bincount(strata, minlength=n))


def multinomial_starts(cdf, n, key, occupancy, starts):
    """The k-th point is ``s_k + u(key, n + 1 + k)``; starts count the points below each
    boundary by a search in the sorted points."""
    last, scale = _starts_frame(cdf, n, starts)
    point_strata = np.repeat(np.arange(n), np.diff(occupancy))
    points = np.sort(point_strata + uniform(key, n + 1 + np.arange(n)))
    starts[1:last + 1] = np.searchsorted(points, cdf[:last] * scale, side="left")


def scheme_points(scheme, key, n, occupancy, out):
    j = np.arange(n)
    if scheme == 0:
        out[:n] = (j + uniform(key, 0)) / n
    elif scheme == 1:
        out[:n] = (j + uniform(key, j)) / n
    else:
        out[:n] = (np.repeat(j, np.diff(occupancy[:n + 1])) + uniform(key, n + 1 + j)) / n


def residual_floors(cdf, log_w, log_w_max, n, floors, residuals):
    expected = np.exp(log_w - log_w_max) * (n / cdf[-1])
    floors[:] = np.floor(expected * (1.0 + 1e-12)).astype(np.int64)
    residuals[:] = np.maximum(expected - floors, 0.0)


def add_floors(starts, floor_sums):
    starts[1:] += floor_sums[:-1]


def expand(starts, idx, x, out):
    idx[:] = np.searchsorted(starts, np.arange(idx.size), side="right") - 1
    out[:] = x[:, idx]


def take_columns(x, idx, out):
    out[:] = x[:, idx]


# --- the resampling pipeline on these mirrors ----------------------------------------------


def draw(log_w, n, method, residual, key):
    """Ancestor indices of ``fasttrack.resampling.draw`` for the stream ``key``."""
    cdf = np.empty_like(log_w)
    log_w_max = log_w.max()
    relative_weights(log_w, log_w_max, cdf)
    cumulate(cdf)
    if residual:
        floors = np.empty(cdf.size, dtype=np.int64)
        residuals = np.empty_like(cdf)
        residual_floors(cdf, log_w, log_w_max, n, floors, residuals)
        cumulate(floors)
        n_rest = n - floors[-1]
        starts = np.zeros(cdf.size, dtype=np.int64)
        if n_rest > 0:
            cumulate(residuals)
            starts = scheme_starts(method, residuals, n_rest, key)
        add_floors(starts, floors)
    else:
        starts = scheme_starts(method, cdf, n, key)
    idx = np.empty(n, dtype=np.int64)
    expand(starts, idx, np.empty((0, cdf.size)), np.empty((0, n)))
    return idx


def scheme_starts(method, cdf, n, key):
    starts = np.empty(cdf.size, dtype=np.int64)
    if method == "systematic":
        systematic_starts(cdf, n, key, starts)
    elif method == "stratified":
        stratified_starts(cdf, n, key, starts)
    else:
        points = np.empty(n + 1)
        sorted_uniforms(key, n, points)
        occupancy = np.empty(n + 1, dtype=np.int64)
        stratum_occupancy(points, n, occupancy)
        multinomial_starts(cdf, n, key, occupancy, starts)
    return starts


# --- jacobian ------------------------------------------------------------------------------

ANALYTIC, FORWARD, CENTRAL = 0, 1, 2


def _mod_bearing(a):
    return (a + np.pi) % (2.0 * np.pi) - np.pi


def _steps(x, central):
    if central:
        return np.cbrt(np.finfo(float).eps) * np.maximum(np.abs(x), 1.0)
    steps = 1e8 * np.spacing(x)
    steps[steps < 1e-8] = 1e-8
    return steps


def _difference_jacobian(evaluate, x, angles, central):
    """Finite-difference Jacobian of ``evaluate((d, n)) -> (m, n)`` at x (d,)."""
    d = x.size
    steps = _steps(x, central)
    plus = x[:, None] + np.diag(steps)
    if central:
        minus = x[:, None] - np.diag(steps)
        delta = evaluate(plus) - evaluate(minus)
        delta[angles] = wrap_angle(delta[angles])
        return delta / (2 * steps)
    values = evaluate(np.column_stack([plus, x]))
    delta = values[:, :d] - values[:, d:]
    delta[angles] = _mod_bearing(delta[angles])
    return delta / steps


def _polar(kind, points, mapping, offset, rotation):
    """Stone Soup's arithmetic: bearing wrapped by mod_bearing, range by sqrt(x**2 + y**2)."""
    p = rotation @ (points[list(mapping[:2])] - offset[:, None])
    rows = [_mod_bearing(np.arctan2(p[1], p[0]))]
    if kind == BEARING_RANGE:
        rows.append(np.sqrt(p[0] ** 2 + p[1] ** 2))
    return np.array(rows)


def measurement_jacobian(kind, x, mapping, offset, rotation, angles, method, out):
    out[:] = 0.0
    if kind == SELECT:
        out[np.arange(mapping.size), mapping] = 1.0
        return
    if method == ANALYTIC:
        p = rotation @ (x[list(mapping[:2])] - offset)
        rho2 = p @ p
        rows = [np.array([-p[1], p[0]]) / rho2]
        if kind == BEARING_RANGE:
            rows.append(p / np.sqrt(rho2))
        out[:, list(mapping[:2])] = np.array(rows) @ rotation
        return
    def evaluate(points):
        if method != CENTRAL:
            return _polar(kind, points, mapping, offset, rotation)
        values = np.empty((out.shape[0], points.shape[1]))
        measure(kind, points, mapping, offset, rotation, values)
        return values
    out[:] = _difference_jacobian(evaluate, x, angles, method == CENTRAL)


class _BadOutput(Exception):
    """A user function's output failed :func:`output_status`."""


def _checked_jacobian(evaluate, rows, x, angles, central, out):
    """:func:`_difference_jacobian` of a user function, or the status of a bad output."""
    def checked(points):
        values = evaluate(np.ascontiguousarray(points))
        status = output_status(values, rows, points.shape[1])
        if status != OK:
            raise _BadOutput(status)
        return values
    try:
        out[:] = _difference_jacobian(checked, x, angles, central)
    except _BadOutput as bad:
        return bad.args[0]
    return OK


def measurement_jacobian_function(function, x, angles, central, out):
    return _checked_jacobian(function, out.shape[0], x, angles, central, out)


def transition_jacobian_function(function, time_interval, x, central, out):
    return _checked_jacobian(lambda points: function(points, time_interval), x.size, x,
                             np.zeros(x.size, dtype=bool), central, out)


# --- kalman --------------------------------------------------------------------------------

FIXED, CV = 0, 1


def _transition(kind, rates, fixed_matrix, fixed_covar, dt, d):
    if kind == FIXED:
        return fixed_matrix, fixed_covar
    blocks_f = [np.array([[1.0, dt], [0.0, 1.0]]) for _ in rates]
    t = abs(dt)
    blocks_q = [q * np.array([[t ** 3 / 3, t ** 2 / 2], [t ** 2 / 2, t]]) for q in rates]
    from scipy.linalg import block_diag
    return block_diag(*blocks_f), block_diag(*blocks_q)


def _positive_definite(a):
    try:
        np.linalg.cholesky(a)
        return True
    except np.linalg.LinAlgError:
        return False


def _positive_semi_definite(a, tolerance=1e-10):
    values = np.linalg.eigvalsh(a)
    return values.min() >= -tolerance * max(values.max(), 0.0)


def _covariance_status(a, asymmetric, indefinite):
    if np.abs(a - a.T).max() > 1e-9 * np.abs(a).max():
        return asymmetric
    return OK if _positive_semi_definite(a) else indefinite


def predict_one(kind, rates, fixed_matrix, fixed_covar, dt, x, covariance, x_out,
                covariance_out):
    f, q = _transition(kind, rates, fixed_matrix, fixed_covar, dt, x.shape[0])
    x_out[:] = f @ x
    covariance_out[:] = f @ covariance @ f.T + q
    return _covariance_status(covariance, PRIOR_NOT_SYMMETRIC, PRIOR_NOT_PSD)


def predict_function(function, dt, covar, central, x, covariance, x_out, covariance_out):
    f = np.empty((x.shape[0], x.shape[0]))
    status = transition_jacobian_function(function, dt, x[:, 0], central, f)
    if status != OK:
        return status
    values = function(np.ascontiguousarray(x), dt)
    status = output_status(values, x.shape[0], 1)
    if status != OK:
        return status
    x_out[:] = values
    covariance_out[:] = f @ covariance @ f.T + covar
    return _covariance_status(covariance, PRIOR_NOT_SYMMETRIC, PRIOR_NOT_PSD)


def _kalman_update(x, covariance, z, z_hat, h, noise, angles, joseph, x_out, covariance_out,
                   innovation_covar, cross):
    cross[:] = covariance @ h.T
    innovation_covar[:] = h @ cross + noise
    if not np.isfinite(z).all():
        return MEASUREMENT_NOT_FINITE
    if not _positive_definite(innovation_covar):
        return INNOVATION_NOT_PD
    gain = cross @ np.linalg.inv(innovation_covar)
    innovation = z - z_hat
    innovation[angles] = wrap_angle(innovation[angles])
    x_out[:] = x + gain @ innovation
    if joseph:
        a = np.eye(x.shape[0]) - gain @ h
        covariance_out[:] = a @ covariance @ a.T + gain @ noise @ gain.T
    else:
        covariance_out[:] = covariance - gain @ innovation_covar @ gain.T
    return OK


def update_one(kind, mapping, offset, rotation, noise, angles, method, joseph, x, covariance,
               z, x_out, covariance_out, z_hat, innovation_covar, cross):
    m, d = noise.shape[0], x.shape[0]
    status = _covariance_status(covariance, PREDICTION_NOT_SYMMETRIC, PREDICTION_NOT_PSD)
    if status != OK:
        return status
    measure(kind, x, mapping, offset, rotation, z_hat)
    h = np.empty((m, d))
    measurement_jacobian(kind, x[:, 0], mapping, offset, rotation, angles, method, h)
    if not np.isfinite(h).all():
        return JACOBIAN_UNDEFINED
    return _kalman_update(x, covariance, z, z_hat, h, noise, angles, joseph, x_out,
                          covariance_out, innovation_covar, cross)


def update_function(function, noise, angles, central, joseph, x, covariance, z, x_out,
                    covariance_out, z_hat, innovation_covar, cross):
    values = function(np.ascontiguousarray(x))
    status = output_status(values, noise.shape[0], 1)
    if status != OK:
        return status
    h = np.empty((noise.shape[0], x.shape[0]))
    status = measurement_jacobian_function(function, x[:, 0], angles, central, h)
    if status != OK:
        return status
    status = _covariance_status(covariance, PREDICTION_NOT_SYMMETRIC, PREDICTION_NOT_PSD)
    if status != OK:
        return status
    z_hat[:] = values
    z_hat[angles] = wrap_angle(z_hat[angles])
    return _kalman_update(x, covariance, z, z_hat, h, noise, angles, joseph, x_out,
                          covariance_out, innovation_covar, cross)


def _filter_step(t_spec, dt, m_spec, method, joseph, x, covariance, z):
    d, m = x.size, z.size
    x_pred, covariance_pred = np.empty((d, 1)), np.empty((d, d))
    status = predict_one(*t_spec, dt, x[:, None], covariance, x_pred, covariance_pred)
    x_out, covariance_out = np.empty((d, 1)), np.empty((d, d))
    code = update_one(*m_spec, method, joseph, x_pred, covariance_pred, z[:, None], x_out,
                      covariance_out, np.empty((m, 1)), np.empty((m, m)), np.empty((d, m)))
    return status or code, x_out[:, 0], covariance_out


def batch_step(t_kind, rates, fixed_matrix, fixed_covar, dts, m_kind, mapping, offset,
               rotation, noise, angles, method, joseph, means, covariances, measurements,
               means_out, covariances_out, status):
    t_spec = (t_kind, rates, fixed_matrix, fixed_covar)
    m_spec = (m_kind, mapping, offset, rotation, noise, angles)
    for k in range(means.shape[0]):
        status[k], means_out[k], covariances_out[k] = _filter_step(
            t_spec, dts[k], m_spec, method, joseph, means[k], covariances[k], measurements[k])


def batch_run(t_kind, rates, fixed_matrix, fixed_covar, dts, m_kind, mapping, offset, rotation,
              noise, angles, method, joseph, mean0, covariance0, measurements, means_out,
              covariances_out, status):
    t_spec = (t_kind, rates, fixed_matrix, fixed_covar)
    m_spec = (m_kind, mapping, offset, rotation, noise, angles)
    steps = measurements.shape[0]
    for k in range(mean0.shape[0]):
        x, covariance = mean0[k], covariance0[k]
        status[k] = (steps, OK)
        for t in range(steps):
            code, x, covariance = _filter_step(t_spec, dts[t, k], m_spec, method, joseph, x,
                                               covariance, measurements[t, k])
            means_out[t, k], covariances_out[t, k] = x, covariance
            if code != OK and status[k][1] == OK:
                status[k] = (t, code)


# Kernels and the adaptive kernel Kalman filter (contract formulas, dense matrices).
POLYNOMIAL, GAUSSIAN, MATRIX = 0, 1, 2


def gram(kind, params, angles, x1, x2, out):
    if kind == POLYNOMIAL:
        out[:] = (x1.T @ x2 / params[2] + params[1]) ** int(params[0])
        return
    variance, norm = params[:2]
    diff = x1[:, :, None] - x2[:, None, :]
    diff[angles] = 2 * np.sin(diff[angles] / 2)
    out[:] = norm * np.exp(-np.sum(diff ** 2, axis=0) / (2 * variance))


def median_variance(angles, x):
    n = x.shape[1]
    if n < 2:
        return 1.0
    if n * (n - 1) // 2 <= 256:
        i, j = np.triu_indices(n, 1)
    else:
        k = np.arange(256)
        u, v = k * 0.6180339887498949, k * 0.41421356237309503
        i = ((u - np.floor(u)) * n).astype(np.int64)
        j = (i + 1 + ((v - np.floor(v)) * (n - 1)).astype(np.int64)) % n
    diff = x[:, i] - x[:, j]
    diff[angles] = 2 * np.sin(diff[angles] / 2)
    squared = np.sum(diff ** 2, axis=0)
    for value in (np.median(squared), np.mean(squared)):
        if value > 0:
            return value
    return 1.0


def resolve(kind, params, angles, x1, x2):
    if kind != GAUSSIAN or params[0] > 0:
        return params
    variance = params[2] ** 2 * median_variance(angles, np.hstack((x1, x2)))
    return np.array([variance, 1.0, params[2]])


def factor(kind, params, angles, points):
    """Diagonally pivoted Cholesky on the dense matrix, stopped at n eps max(diag)."""
    if kind == MATRIX:
        k = points.copy()
    else:
        k = np.empty((points.shape[1], points.shape[1]))
        gram(kind, params, angles, points, points, k)
    n = k.shape[0]
    tol = n * np.finfo(float).eps * max(np.diag(k).max(), 0.0)
    rows = []
    residual = np.diag(k).copy()
    while len(rows) < n:
        p = int(np.argmax(residual))
        if residual[p] <= tol:
            break
        previous = np.array(rows).reshape(len(rows), n)
        row = (k[p] - previous[:, p] @ previous) / np.sqrt(residual[p])
        residual -= row ** 2
        residual[p] = 0.0
        rows.append(row)
    return np.array(rows).reshape(len(rows), n)


def dense_covariance(lt, sigma, v1t, v2t):
    """S = Lt^T Lt + sigma Z Z^T, Z = I - V1t^T V2t."""
    z = np.eye(lt.shape[1]) - v1t.T @ v2t
    return lt.T @ lt + sigma * z @ z.T


def sandwich(a, lt, sigma, v1t, v2t):
    return a @ dense_covariance(lt, sigma, v1t, v2t) @ a.T


def predict_embedding(kind, params, angles, proposal, x, w, lt, sigma, v1t, v2t, lam):
    """Contract 5.3 on dense matrices. Returns the weights and the dense kernel covariance
    (the kernel returns it factored)."""
    return predict_dense(kind, params, angles, proposal, x, w,
                         dense_covariance(lt, sigma, v1t, v2t), lam)


def predict_dense(kind, params, angles, proposal, x, w, s, lam):
    """``(w-, S-)`` from a dense S, with A = (K + lam I)^-1 by inversion."""
    m = w.size
    params = resolve(kind, params, angles, proposal, x)
    k = np.empty((m, m))
    kx = np.empty((m, m))
    gram(kind, params, angles, proposal, proposal, k)
    gram(kind, params, angles, proposal, x, kx)
    a = np.linalg.inv(k + lam * np.eye(m))
    gamma = a @ kx
    r = a @ k - np.eye(m)
    return gamma @ w, gamma @ s @ gamma.T + r @ r.T / m


def update_embedding(kind, params, angles, y, z, w, lt, sigma, v1t, v2t, lam, x, key,
                     proposal_out):
    """Contract 5.4 on dense matrices; draws the proposal. Returns the weights and the dense
    kernel covariance."""
    w_post, s_post = update_dense(kind, params, angles, y, z, w,
                                  dense_covariance(lt, sigma, v1t, v2t), lam)
    proposal_dense(x, w_post, s_post, key, proposal_out)
    return w_post, s_post


def update_dense(kind, params, angles, y, z, w, s, lam):
    """``(w+, S+)`` from a dense S, with Q = S (G S + lam I)^-1 by a solve."""
    m = w.size
    params = resolve(kind, params, angles, y, z)
    g_mat = np.empty((m, m))
    g_vec = np.empty((m, 1))
    gram(kind, params, angles, y, y, g_mat)
    gram(kind, params, angles, y, z, g_vec)
    q = np.linalg.solve((g_mat @ s + lam * np.eye(m)).T, s.T).T
    return w + q @ (g_vec[:, 0] - g_mat @ w), s - q @ g_mat @ s


def proposal_dense(x, w, s, key, out):
    """The proposal draw from a dense S."""
    d, m = x.shape
    normals = np.empty(d * m + (d * m) % 2)
    fill_normals(key, 0, normals)
    scale = np.sqrt(np.diag(x @ s @ x.T))
    out[:] = (x @ w)[:, None] + scale[:, None] * normals[:d * m].reshape(d, m)


def largest_magnitude(w):
    return np.nan if np.isnan(w).any() else float(np.abs(w).max(initial=0.0))


def draw_proposal(x, w, lt, sigma, v1t, v2t, key, out):
    """``x w + sqrt(diag(x S x^T)) * normals`` (normals of stream ``key``, row-major)."""
    proposal_dense(x, w, dense_covariance(lt, sigma, v1t, v2t), key, out)


# --- assign (linear sum assignment, GOSPA, OSPA) --------------------------------------------


def lsap(cost, row_to_col):
    """scipy.optimize.linear_sum_assignment; infeasible: every row -1 and False."""
    from scipy.optimize import linear_sum_assignment
    row_to_col[:] = -1
    try:
        rows, cols = linear_sum_assignment(cost)
    except ValueError:
        return False
    row_to_col[rows] = cols
    return True


def lsap_batch(costs, offsets, shapes, row_offsets, row_to_col, feasible):
    for q, (nr, nc) in enumerate(shapes):
        block = costs[offsets[q]:offsets[q + 1]].reshape(nr, nc)
        feasible[q] = lsap(block, row_to_col[row_offsets[q]:row_offsets[q + 1]])


def _capped(rows, cols, c):
    """min(|rows[i] - cols[j]|, c) for every pair."""
    d = np.sqrt(((rows[:, None, :] - cols[None, :, :]) ** 2).sum(axis=-1))
    return np.where(d < c, d, c)


def gospa_steps(truths, truth_offsets, estimates, estimate_offsets, c, p, alpha, assignment,
                out):
    """GOSPA from its definition, step by step: scipy's pairs on min(d, c)^p (truth rows),
    then c^p/alpha per unassigned point; with alpha = 2 a pair at the cut-off is split
    into a missed truth and a false estimate."""
    from scipy.optimize import linear_sum_assignment
    cut = c ** p
    dummy = cut / alpha
    for k in range(truth_offsets.size - 1):
        x = truths[truth_offsets[k]:truth_offsets[k + 1]]
        y = estimates[estimate_offsets[k]:estimate_offsets[k + 1]]
        n, m = len(x), len(y)
        pairs = np.full(n, -1)
        loc = missed = false = 0.0
        if n and m:
            cost = _capped(x, y, c) ** p
            rows, cols = linear_sum_assignment(cost)
            pairs[rows] = cols
            at_cut = (cost[rows, cols] == cut) if alpha == 2 else np.zeros(len(rows), bool)
            loc = cost[rows, cols][~at_cut].sum()
            pairs[rows[at_cut]] = -1
            missed = dummy * (n - len(rows) + at_cut.sum())
            false = dummy * (m - len(rows) + at_cut.sum())
            total = cost[rows, cols].sum() + dummy * (n + m - 2 * len(rows))
        else:
            missed, false = dummy * n, dummy * m
            total = missed + false
        assignment[truth_offsets[k]:truth_offsets[k + 1]] = pairs
        out[k] = total ** (1 / p), loc, missed, false


def switching_loss(truth_ids, truth_offsets, estimate_offsets, assigned_ids, n_ids, out):
    """Stone Soup's _SwitchingLoss.add_associations on dicts, step by step."""
    record = {}
    for k in range(truth_offsets.size - 1):
        out[k] = 0.0
        if estimate_offsets[k + 1] == estimate_offsets[k]:
            continue  # Stone Soup's mapping is empty without estimates
        for t in range(truth_offsets[k], truth_offsets[k + 1]):
            truth = int(truth_ids[t])
            estimate = None if assigned_ids[t] == -1 else int(assigned_ids[t])
            if truth not in record:
                if estimate is not None:
                    record[truth] = estimate
            elif record[truth] != estimate:
                out[k] += 0.5 + 0.5 * (estimate is not None and record[truth] is not None)
                record[truth] = estimate


def _bottleneck(cost):
    """min over complete assignments of the largest entry: the least threshold at which
    scipy still finds an assignment."""
    from scipy.optimize import linear_sum_assignment
    for value in np.unique(cost):
        try:
            linear_sum_assignment(np.where(cost <= value, 0.0, np.inf))
        except ValueError:
            continue
        return value


def ospa_steps(truths, truth_offsets, estimates, estimate_offsets, c, p, stonesoup, out):
    """OSPA from its definition (or, with ``stonesoup``, Stone Soup 1.9.1's computation:
    the square matrix of min(d, c) padded with c, scipy's pairs on it, then the powers)."""
    from scipy.optimize import linear_sum_assignment
    for k in range(truth_offsets.size - 1):
        x = truths[truth_offsets[k]:truth_offsets[k + 1]]
        y = estimates[estimate_offsets[k]:estimate_offsets[k + 1]]
        n, m = len(x), len(y)
        big = max(n, m)
        if big == 0:
            out[k] = 0.0
        elif p == np.inf:
            if n != m:
                out[k] = c
            elif stonesoup:
                cost = _capped(y, x, c)
                out[k] = cost[linear_sum_assignment(cost)].max()
            else:
                out[k] = _bottleneck(_capped(x, y, c))
        elif stonesoup:
            cost = np.full((big, big), float(c))
            cost[:m, :n] = _capped(y, x, c)
            out[k] = ((1 / big) * np.sum(cost[linear_sum_assignment(cost)] ** p)) ** (1 / p)
        else:
            cost = _capped(x, y, c) ** p
            total = cost[linear_sum_assignment(cost)].sum() + c ** p * (big - min(n, m))
            out[k] = (total / big) ** (1 / p)


# --- jpda ----------------------------------------------------------------------------------


def _joint_events(weights):
    """Every joint event of a (T, M + 1) cluster (one column per track, no detection column
    twice, positive weights only) and its weight: brute-force enumeration."""
    import itertools
    options = [np.flatnonzero(row > 0) for row in weights]
    for event in itertools.product(*options):
        taken = [j for j in event if j > 0]
        if len(taken) == len(set(taken)):
            yield event, np.prod([weights[t, j] for t, j in enumerate(event)])


def ehm_marginals(weights, max_nodes, out):
    """Marginals by enumerating every joint event (``max_nodes`` is ignored)."""
    out[...] = 0.0
    for t, row in enumerate(weights):
        if not (row > 0).any():
            return 3, t
    total = 0.0
    for event, weight in _joint_events(weights):
        total += weight
        for t, j in enumerate(event):
            out[t, j] += weight
    if weights.shape[0] == 0:
        return 0, 0
    if not total > 0:
        return 3, -1
    out /= total
    return 0, 0


def ehm_marginals_batch(weights, offsets, shapes, max_nodes, out, info):
    for c, (n_tracks, n_dets) in enumerate(shapes):
        lo, hi = offsets[c], offsets[c + 1]
        info[c] = ehm_marginals(weights[lo:hi].reshape(n_tracks, n_dets + 1), max_nodes,
                                out[lo:hi].reshape(n_tracks, n_dets + 1))


def pda_weight_matrix(means, covars, detections, angles, gate, prob_detect, prob_gate,
                      gate_threshold, clutter_spatial_density, volume_factor, include_all,
                      out, status):
    """PDAHypothesiser's weights with NumPy (inverse covariance, scipy's Gaussian pdf)."""
    from scipy.stats import multivariate_normal
    out[:, 0] = 1.0 - prob_detect * prob_gate
    out[:, 1:] = 0.0
    status[:] = 0
    for t in range(means.shape[0]):
        if np.linalg.eigvalsh(covars[t]).min() <= 0:
            status[t] = 2
            out[t] = 0.0
            continue
        nu = detections - means[t]
        nu[:, angles] = wrap_angle(nu[:, angles])
        d2 = np.einsum("di,ij,dj->d", nu, np.linalg.inv(covars[t]), nu)
        valid = gate[t] & (d2 <= gate_threshold)
        kept = valid | (gate[t] & include_all)
        pdf = multivariate_normal(np.zeros(means.shape[1]), covars[t]).pdf(nu)
        out[t, 1:] = np.where(kept, prob_detect * np.atleast_1d(pdf), 0.0)
        if clutter_spatial_density > 0:
            out[t, 1:] /= clutter_spatial_density
        elif valid.any():
            out[t, 1:] *= volume_factor * np.sqrt(np.linalg.det(covars[t])) / valid.sum()


# --- kalman batches of tracks (prediction with measurement, update) -------------------------

def linear_predict(matrix, covar, mapping, noise, means, covariances, means_out,
                   covariances_out, z_hats, innovation_covars, status):
    for k in range(means.shape[0]):
        status[k] = _covariance_status(covariances[k], PRIOR_NOT_SYMMETRIC, PRIOR_NOT_PSD)
        means_out[k] = matrix @ means[k]
        covariances_out[k] = matrix @ covariances[k] @ matrix.T + covar
        z_hats[k] = means_out[k][mapping]
        innovation_covars[k] = covariances_out[k][np.ix_(mapping, mapping)] + noise


def linear_update(mapping, noise, angles, joseph, means, covariances, measurements, means_out,
                  covariances_out, status):
    d, m = means.shape[1], measurements.shape[1]
    h = np.zeros((m, d))
    h[np.arange(m), mapping] = 1.0
    for k in range(means.shape[0]):
        x_out = np.empty((d, 1))
        status[k] = _kalman_update(means[k][:, None], covariances[k], measurements[k][:, None],
                                   means[k][mapping][:, None], h, noise, angles, joseph, x_out,
                                   covariances_out[k], np.empty((m, m)), np.empty((d, m)))
        means_out[k] = x_out[:, 0]


def batch_predict(t_kind, rates, fixed_matrix, fixed_covar, dts, m_kind, mapping, offset,
                  rotation, noise, method, means, covariances, means_out, covariances_out,
                  z_hats, innovation_covars, status):
    d, m = means.shape[1], z_hats.shape[1]
    angles = np.zeros(m, dtype=bool)
    for k in range(means.shape[0]):
        x, p = np.empty((d, 1)), np.empty((d, d))
        status[k] = predict_one(t_kind, rates, fixed_matrix, fixed_covar, dts[k],
                                means[k][:, None], covariances[k], x, p)
        z_hat, h = np.empty((m, 1)), np.empty((m, d))
        measure(m_kind, x, mapping, offset, rotation, z_hat)
        measurement_jacobian(m_kind, x[:, 0], mapping, offset, rotation, angles, method, h)
        means_out[k], covariances_out[k] = x[:, 0], p
        z_hats[k], innovation_covars[k] = z_hat[:, 0], h @ p @ h.T + noise


# --- gating, clusters, nearest-neighbour assignment (dense) -----------------------------------

def cell_keys(detections, axes, origin, cell, shape, keys):
    cells = np.floor((detections[:, axes] - origin[:len(axes)]) / cell).astype(np.int64)
    keys[:] = 0
    if len(axes) == 1:
        keys[:] = cells[:, 0]
    elif len(axes) == 2:
        keys[:] = cells[:, 0] * shape[1] + cells[:, 1]


def _dense_gate(z_hats, covariances, detections, angles, threshold):
    """Squared distances (K, M), inf outside the gates, and the log-likelihoods."""
    v = detections[None, :, :] - z_hats[:, None, :]
    v[..., angles] = wrap_angle(v[..., angles])
    d2 = np.einsum("kji,kil,kjl->kj", v, np.linalg.inv(covariances), v)
    m = z_hats.shape[1]
    log_norm = 0.5 * (m * np.log(2 * np.pi) + np.linalg.slogdet(covariances)[1])
    return np.where(d2 < threshold, d2, np.inf), -0.5 * d2 - log_norm[:, None]


def gate(z_hats, covariances, detections, order, sorted_keys, axes, angles, origin, cell,
         shape, threshold, write, starts, candidates, distances2, log_likelihoods, status):
    d2, ll = _dense_gate(z_hats, covariances, detections, angles, threshold)
    if not write:
        starts[0] = 0
        starts[1:] = np.cumsum(np.isfinite(d2).sum(axis=1))
        status[:] = 0
        return
    rows, cols = np.nonzero(np.isfinite(d2))
    candidates[:], distances2[:], log_likelihoods[:] = cols, d2[rows, cols], ll[rows, cols]


def clusters(starts, candidates, n_detections, labels):
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components
    k = starts.size - 1
    rows = np.repeat(np.arange(k), np.diff(starts))
    graph = coo_matrix((np.ones(rows.size), (rows, k + candidates)),
                       shape=(k + n_detections,) * 2)
    _, raw = connected_components(graph, directed=False)
    first = {}
    for label in raw:  # renumber in order of the first member
        first.setdefault(label, len(first))
    labels[:] = [first[label] for label in raw]
    return len(first)


def gnn_problems(labels, n_clusters, k_tracks, n_detections, shapes, offsets, row_offsets,
                 track_rows, detection_columns):
    tracks, detections = labels[:k_tracks], labels[k_tracks:]
    for c in range(n_clusters):
        track_rows[tracks == c] = np.arange((tracks == c).sum())
        detection_columns[detections == c] = np.arange((detections == c).sum())
        shapes[c] = (tracks == c).sum(), (detections == c).sum() + (tracks == c).sum()
    offsets[0] = row_offsets[0] = 0
    offsets[1:] = np.cumsum(shapes[:, 0] * shapes[:, 1])
    row_offsets[1:] = np.cumsum(shapes[:, 0])
    return offsets[-1]


def gnn_fill(labels, starts, candidates, costs, missed, shapes, offsets, track_rows,
             detection_columns, flat):
    flat[:] = np.inf
    for k in range(starts.size - 1):
        c = labels[k]
        block = flat[offsets[c]:offsets[c + 1]].reshape(shapes[c])
        block[track_rows[k], detection_columns[candidates[starts[k]:starts[k + 1]]]] = \
            costs[starts[k]:starts[k + 1]]
        block[track_rows[k], shapes[c, 1] - shapes[c, 0] + track_rows[k]] = missed[k]


def gnn_assignments(labels, shapes, row_offsets, track_rows, detection_columns, n_detections,
                    row_to_col, assigned):
    k_tracks = track_rows.size
    for k in range(k_tracks):
        c = labels[k]
        col = row_to_col[row_offsets[c] + track_rows[k]]
        members = np.flatnonzero(labels[k_tracks:] == c)
        assigned[k] = members[col] if 0 <= col < members.size else -1


def greedy_assignments(starts, candidates, costs, missed, n_detections, assigned):
    k_tracks = starts.size - 1
    owners = np.repeat(np.arange(k_tracks), np.diff(starts))
    options = sorted([(costs[q], owners[q], q) for q in range(candidates.size)]
                     + [(missed[k], k, candidates.size + k) for k in range(k_tracks)],
                     key=lambda option: (option[0], option[2]))
    assigned[:] = -1
    decided, taken = set(), set()
    for _, k, q in options:
        if k in decided:
            continue
        if q >= candidates.size:
            decided.add(k)
        elif candidates[q] not in taken:
            decided.add(k)
            taken.add(candidates[q])
            assigned[k] = candidates[q]


def rts(x, covar, x_pred, covar_pred, recompute, matrix, noise, step, x_out, covar_out):
    n_tracks, n_times, d = x.shape
    for k in range(n_tracks):
        x_out[k, -1] = x[k, -1]
        covar_out[k, -1] = covar[k, -1]
        for t in range(n_times - 2, -1, -1):
            f, q = matrix[step[t]], noise[step[t]]
            if recompute[t + 1] == 1:
                xp = f @ x[k, t]
                pp = f @ covar[k, t] @ f.T + q
            elif recompute[t + 1] == 2:
                xp, pp = x_out[k, t + 1], covar_out[k, t + 1]
            else:
                xp, pp = x_pred[k, t + 1], covar_pred[k, t + 1]
            if np.any(np.linalg.eigvalsh(pp) <= 0):
                return 1 + k * n_times + t + 1
            gain = covar[k, t] @ f.T @ np.linalg.inv(pp)
            x_out[k, t] = x[k, t] + gain @ (x_out[k, t + 1] - xp)
            c = covar[k, t] + gain @ (covar_out[k, t + 1] - pp) @ gain.T
            covar_out[k, t] = (c + c.T) / 2
    return 0


# --- unscented Kalman (fasttrack._jit.unscented) ---------------------------------------------

def _cholesky_eps(a):
    """NumPy's Cholesky, else Stone Soup's ``cholesky_eps`` rule (pivots <= eps -> sqrt(eps))."""
    try:
        return np.linalg.cholesky(a)
    except np.linalg.LinAlgError:
        eps = np.spacing(np.max(np.diag(a)))
        lower = np.zeros(a.shape)
        for i in range(a.shape[0]):
            for j in range(i):
                lower[i, j] = (a[i, j] - lower[i, :] @ lower[j, :]) / lower[j, j]
            v = a[i, i] - lower[i, :] @ lower[i, :]
            lower[i, i] = np.sqrt(v) if v > eps else np.sqrt(eps)
        return lower


def sigma_points(x, covariance, alpha, beta, kappa, lower, points, mean_weights,
                 covar_weights):
    d = x.shape[0]
    lower[:] = _cholesky_eps(covariance)
    lamda = alpha ** 2 * (d + kappa) - d
    c = d + lamda
    points[:] = np.hstack([x, x + lower * np.sqrt(c), x - lower * np.sqrt(c)])
    mean_weights[:] = 0.5 / c
    covar_weights[:] = 0.5 / c
    mean_weights[0] = lamda / c
    covar_weights[0] = lamda / c + 1 - alpha ** 2 + beta


def unscented_moments(points, transformed, mean_weights, covar_weights, angles, noise, mean,
                      covar, cross):
    for r in range(transformed.shape[0]):
        row = transformed[r]
        if angles[r]:
            mean[r, 0] = wrap_angle(np.arctan2(np.sum(np.sin(row) * mean_weights),
                                               np.sum(np.cos(row) * mean_weights)))
        else:
            mean[r, 0] = np.average(row, weights=mean_weights)
    diff = transformed - mean
    diff[angles] = wrap_angle(diff[angles])
    covar[:] = diff @ np.diag(covar_weights) @ diff.T + noise
    cross[:] = (points - points[:, :1]) @ np.diag(covar_weights) @ diff.T


def _sigma(x, covariance, alpha, beta, kappa):
    d = x.shape[0]
    lower, points = np.empty((d, d)), np.empty((d, 2 * d + 1))
    wm, wc = np.empty(2 * d + 1), np.empty(2 * d + 1)
    sigma_points(x, covariance, alpha, beta, kappa, lower, points, wm, wc)
    return lower, points, wm, wc


def unscented_predict(kind, rates, fixed_matrix, fixed_covar, dt, alpha, beta, kappa, x,
                      covariance, x_out, covariance_out):
    status = _covariance_status(covariance, PRIOR_NOT_SYMMETRIC, PRIOR_NOT_PSD)
    if status != OK:
        return status
    d = x.shape[0]
    f, q = _transition(kind, rates, fixed_matrix, fixed_covar, dt, d)
    _, points, wm, wc = _sigma(x, covariance, alpha, beta, kappa)
    unscented_moments(points, f @ points, wm, wc, np.zeros(d, bool), q, x_out,
                      covariance_out, np.empty((d, d)))
    return OK



def unscented_predict_function(function, dt, covar, alpha, beta, kappa, x, covariance,
                               x_out, covariance_out, cross):
    status = _covariance_status(covariance, PRIOR_NOT_SYMMETRIC, PRIOR_NOT_PSD)
    if status != OK:
        return status
    d = x.shape[0]
    _, points, wm, wc = _sigma(x, covariance, alpha, beta, kappa)
    moved = function(np.ascontiguousarray(points), dt)
    status = output_status(moved, d, points.shape[1])
    if status == OK:
        full = np.empty((d, d))
        unscented_moments(points, moved, wm, wc, np.zeros(d, bool), covar, x_out,
                          covariance_out, full)
        cross[:] = full[:cross.shape[0]]
    return status


def unscented_update(kind, mapping, offset, rotation, noise, angles, alpha, beta, kappa,
                     joseph, x, covariance, z, x_out, covariance_out, z_hat,
                     innovation_covar, cross):
    status = _covariance_status(covariance, PREDICTION_NOT_SYMMETRIC, PREDICTION_NOT_PSD)
    if status != OK:
        return status
    _, points, wm, wc = _sigma(x, covariance, alpha, beta, kappa)
    transformed = np.empty((z.shape[0], points.shape[1]))
    measure(kind, points, mapping, offset, rotation, transformed)
    return _unscented_correct(points, transformed, wm, wc, noise, angles, joseph, x,
                              covariance, z, x_out, covariance_out, z_hat, innovation_covar,
                              cross)


def _unscented_correct(points, transformed, wm, wc, noise, angles, joseph, x, covariance, z,
                       x_out, covariance_out, z_hat, innovation_covar, cross):
    unscented_moments(points, transformed, wm, wc, angles, noise, z_hat, innovation_covar,
                      cross)
    if not _positive_definite(innovation_covar):
        return INNOVATION_NOT_PD
    if not np.all(np.isfinite(z)):
        return MEASUREMENT_NOT_FINITE
    gain = cross @ np.linalg.inv(innovation_covar)
    v = z - z_hat
    v[angles] = wrap_angle(v[angles])
    x_out[:] = x + gain @ v
    if joseph:
        h = np.linalg.solve(covariance, cross).T
        square = np.eye(x.shape[0]) - gain @ h
        covariance_out[:] = square @ covariance @ square.T + gain @ noise @ gain.T
    else:
        covariance_out[:] = covariance - gain @ innovation_covar @ gain.T
    return OK


def unscented_update_function(function, noise, angles, alpha, beta, kappa, joseph, x,
                              covariance, z, x_out, covariance_out, z_hat, innovation_covar,
                              cross):
    status = _covariance_status(covariance, PREDICTION_NOT_SYMMETRIC, PREDICTION_NOT_PSD)
    if status != OK:
        return status
    _, points, wm, wc = _sigma(x, covariance, alpha, beta, kappa)
    transformed = function(np.ascontiguousarray(points))
    status = output_status(transformed, z.shape[0], points.shape[1])
    if status != OK:
        return status
    return _unscented_correct(points, transformed, wm, wc, noise, angles, joseph, x,
                              covariance, z, x_out, covariance_out, z_hat, innovation_covar,
                              cross)


PREDICT, MEASURE, UPDATE = 1, 2, 4


def batch_unscented(t_kind, rates, fixed_matrix, fixed_covar, dts, m_kind, mapping, offset,
                    rotation, noise, angles, alpha, beta, kappa, joseph, stages, means,
                    covars, measurements, means_out, covars_out, z_hats, innovation_covars,
                    status):
    d, m = means.shape[1], noise.shape[0]
    for k in range(means.shape[0]):
        x, p = means[k].reshape(d, 1).copy(), covars[k].copy()
        status[k] = OK
        if stages & PREDICT:
            status[k] = unscented_predict(t_kind, rates, fixed_matrix, fixed_covar, dts[k],
                                          alpha, beta, kappa, means[k].reshape(d, 1),
                                          covars[k], x, p)
        outs = (np.empty((d, 1)), np.empty((d, d)), np.empty((m, 1)), np.empty((m, m)),
                np.empty((d, m)))
        if status[k] == OK and stages & (MEASURE | UPDATE):
            z = measurements[k].reshape(m, 1) if stages & UPDATE else np.zeros((m, 1))
            code = unscented_update(m_kind, mapping, offset, rotation, noise, angles, alpha,
                                    beta, kappa, joseph, x, p, z, *outs)
            if stages & MEASURE:
                z_hats[k], innovation_covars[k] = outs[2][:, 0], outs[3]
            if stages & UPDATE:
                status[k] = code
                x, p = outs[0], outs[1]
        means_out[k], covars_out[k] = x[:, 0], p

def _ffbs_categorical(logw, u):
    """The first index whose cumulative weight ``exp(logw - max)`` exceeds ``u`` times the
    total, or the last of positive weight."""
    w = np.exp(logw - logw.max())
    cumulative = np.cumsum(w)
    i = np.searchsorted(cumulative, u * cumulative[-1], side="right")
    return i if i < logw.size else np.flatnonzero(w > 0)[-1]



def ffbs(states, log_weights, mean_next, precision_root, rng, max_proposals,
         min_acceptance, out_index):
    n_times, n_paths = out_index.shape
    for m in range(n_paths):
        out_index[-1, m] = _ffbs_categorical(log_weights[-1], rng.random())
    for t in range(n_times - 2, -1, -1):
        accepted = proposed = 0
        for m in range(n_paths):
            diff = states[t + 1][:, [out_index[t + 1, m]]] - mean_next[t]
            quad = ((np.tril(precision_root[t]) @ diff) ** 2).sum(axis=0)
            i = None
            for _ in range(max_proposals if accepted + 1 >= proposed * min_acceptance else 0):
                proposed += 1
                proposal = _ffbs_categorical(log_weights[t], rng.random())
                if rng.random() < np.exp(-0.5 * quad[proposal]):
                    accepted, i = accepted + 1, proposal
                    break
            if i is None:
                i = _ffbs_categorical(log_weights[t] - 0.5 * quad, rng.random())
            out_index[t, m] = i
    return 0
