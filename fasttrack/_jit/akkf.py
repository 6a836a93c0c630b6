"""The adaptive kernel Kalman filter in factored form.

The M x M kernel covariance is never formed. It is kept as

    S = Lt^T Lt + sigma Z Z^T,    Z = I - V1t^T V2t,

with ``Lt`` (k, M), ``V1t`` and ``V2t`` (r, M) and ``sigma >= 0``: positive semi-definite by
construction, and every quadratic form ``a S a^T`` is a sum of squares, so proposal variances
cannot go negative. The kernel Gram matrices enter through low-rank factors
(:func:`gram.factor`): ``K(proposal, proposal) = Phi_new^T Phi_new``, ``K(proposal, prior) =
Phi_new^T Phi`` and ``K(Y, Y) = Psi^T Psi``, ``K(Y, z) = Psi^T psi_z``.

With ``A = (K + lambda I)^-1`` and, while r <= M, ``V2t = (A Phi_new^T)^T = W Phi_new``
(``W = (Phi_new Phi_new^T + lambda I)^-1``, r x r), the prediction
``Gamma = A K(proposal, prior)``, ``w- = Gamma w``,
``S- = Gamma S Gamma^T + (A K - I)(A K - I)^T / M`` becomes

    w- = V2t^T (Phi w),   S- = V2t^T P V2t + (1/M) (I - Phi_new^T V2t)(...)^T,

``P = Phi S Phi^T`` (r, r), whose own factor keeps the rank at r. With more features than
particles (r > M) the same is done in particle space: Gamma and ``A K`` from M x M solves,
``V1t = I``, ``V2t = A K``. The update
``Q = S- (G S- + lambda I)^-1`` is, by the push-through identity, ``S- Psi^T E Psi`` with
``E = (Psi S- Psi^T + lambda I)^-1`` (q, q), so that with the gain ``K = S- Psi^T E``

    w+ = w- + K (psi_z - Psi w-),   S+ = (I - K Psi) S- (I - K Psi)^T + lambda K K^T,

the Joseph form, equal to ``S- - Q G S-`` and a sum of two positive semi-definite terms.
"""
import numpy as np

from . import jit
from .gram import MATRIX, factor
from .numeric import fill_normals

_NO_PARAMS = np.empty(0)
_NO_ANGLES = np.zeros(0, dtype=np.bool_)


@jit()
def _cholesky_solve(c, b):
    """Solve ``(c c^T) x = b`` in place for a lower-triangular c (n, n) and b (n, m)."""
    n = c.shape[0]
    for i in range(n):
        bi = b[i]
        for j in range(i):
            coef = c[i, j]
            bj = b[j]
            for col in range(bi.size):
                bi[col] -= coef * bj[col]
        inv = 1.0 / c[i, i]
        for col in range(bi.size):
            bi[col] *= inv
    for i in range(n - 1, -1, -1):
        bi = b[i]
        for j in range(i + 1, n):
            coef = c[j, i]
            bj = b[j]
            for col in range(bi.size):
                bi[col] -= coef * bj[col]
        inv = 1.0 / c[i, i]
        for col in range(bi.size):
            bi[col] *= inv
    return b


@jit()
def _regularised_cholesky(a, lam):
    """Lower Cholesky factor of ``a + lam I`` for a symmetric a (its lower triangle is
    read)."""
    n = a.shape[0]
    c = np.zeros((n, n))
    for i in range(n):
        ci = c[i]
        for j in range(i + 1):
            cj = c[j]
            total = a[i, j]
            for k in range(j):
                total -= ci[k] * cj[k]
            if j < i:
                ci[j] = total / cj[j]
            elif total + lam > 0.0:
                ci[i] = np.sqrt(total + lam)
            else:
                raise ValueError("a regularised kernel matrix is not positive definite")
    return c


@jit()
def _mul(a, b):
    """``a @ b`` for row-major a (n, K) and b (K, p), by row updates that vectorise.

    The filter's products are small or thin, and this keeps them single-threaded: a BLAS
    thread pool here would compete with NumPy's own for the cores.
    """
    out = np.zeros((a.shape[0], b.shape[1]))
    for i in range(a.shape[0]):
        row = out[i]
        for k in range(a.shape[1]):
            coef = a[i, k]
            bk = b[k]
            for j in range(row.size):
                row[j] += coef * bk[j]
    return out


@jit()
def _mul_t(a, b):
    """``a @ b.T``."""
    return _mul(a, np.ascontiguousarray(b.T))


@jit()
def _mul_vector(a, v):
    """``a @ v`` for a (n, K) and v (K,)."""
    out = np.zeros(a.shape[0])
    for i in range(a.shape[0]):
        ai = a[i]
        total = 0.0
        for k in range(v.size):
            total += ai[k] * v[k]
        out[i] = total
    return out


@jit()
def _vector_mul(v, b):
    """``v @ b`` for v (K,) and b (K, p)."""
    return _mul(v.reshape(1, -1), b)[0]


@jit()
def _deviation(a, v1t, v2t):
    """``a Z = a - (a V1t^T) V2t`` for a (n, M)."""
    return a - _mul(_mul_t(a, v1t), v2t)


@jit()
def _gram(a, b, sigma):
    """``a a^T + sigma b b^T``."""
    return _mul_t(a, a) + sigma * _mul_t(b, b)


@jit()
def sandwich(a, lt, sigma, v1t, v2t):
    """``a S a^T`` for a (n, M): a sum of two Gram matrices."""
    return _gram(_mul_t(a, lt), _deviation(a, v1t, v2t), sigma)


@jit()
def predict_embedding(kind, params, angles, proposal, x, w, lt, sigma, v1t, v2t, lam):
    """Predicted weights and kernel covariance factors.

    Parameters
    ----------
    kind, params, angles
        The kernel (see :mod:`gram`).
    proposal, x : (d, M)
        Proposal particles and the prior's particles.
    w : (M,)
        Prior weights.
    lt, sigma, v1t, v2t
        Prior kernel covariance factors.
    lam : float
        Regularisation lambda_predictor > 0.

    Returns
    -------
    w_pred (M,), lt_pred (g, M), v1t_pred and v2t_pred (min(r, M), M); the predicted
    ``sigma`` is 1/M.
    """
    m = w.size
    joint = factor(kind, params, angles, np.hstack((proposal, x)))
    phi_new = np.ascontiguousarray(joint[:, :m])
    phi = np.ascontiguousarray(joint[:, m:])
    r = phi_new.shape[0]
    phi_new_t = np.ascontiguousarray(phi_new.T)
    if r <= m:  # W = (Phi_new Phi_new^T + lam I)^-1 in feature space
        c = _regularised_cholesky(_mul(phi_new, phi_new_t), lam)
        v2t_pred = _cholesky_solve(c, phi_new.copy())
        w_pred = _vector_mul(_mul_vector(phi, w), v2t_pred)
        root = factor(MATRIX, _NO_PARAMS, _NO_ANGLES, sandwich(phi, lt, sigma, v1t, v2t))
        return w_pred, _mul(root, v2t_pred), phi_new, v2t_pred
    # more features than particles: A = (K + lam I)^-1 in particle space, where
    # Gamma = A Phi_new^T Phi and Z = I - A K
    k_new = _mul(phi_new_t, phi_new)
    c = _regularised_cholesky(k_new, lam)
    gamma = _cholesky_solve(c, _mul(phi_new_t, phi))
    a_k = _cholesky_solve(c, k_new)
    root = factor(MATRIX, _NO_PARAMS, _NO_ANGLES, sandwich(gamma, lt, sigma, v1t, v2t))
    return _mul_vector(gamma, w), root, np.eye(m), a_k


@jit()
def update_embedding(kind, params, angles, y, z, w, lt, sigma, v1t, v2t, lam, x, key,
                     proposal_out):
    """Updated weights and kernel covariance factors, and the next proposal.

    Parameters
    ----------
    kind, params, angles
        The measurement kernel (see :mod:`gram`).
    y : (m, M)
        Predicted measurements of the particles.
    z : (m, 1)
        The measurement.
    w, lt, sigma, v1t, v2t
        Predicted weights and kernel covariance factors.
    lam : float
        Regularisation lambda_updater > 0.
    x : (d, M)
        The predicted particles.
    key : int
        Random stream of the proposal draw (:func:`draw_proposal`).
    proposal_out : (d, M)
        Receives the proposal particles.

    Returns
    -------
    w_post (M,), lt_post (k + q, M), v1t_post and v2t_post (r + q, M); ``sigma`` is
    unchanged.
    """
    m = w.size
    joint = factor(kind, params, angles, np.hstack((y, z)))
    psi = np.ascontiguousarray(joint[:, :m])
    t1 = _mul_t(psi, lt)
    u = _deviation(psi, v1t, v2t)
    c = _regularised_cholesky(_gram(t1, u, sigma), lam)
    gain_t = _cholesky_solve(c, _mul(t1, lt) + sigma * _deviation(u, v2t, v1t))
    w_post = w + _vector_mul(joint[:, m] - _mul_vector(psi, w), gain_t)
    lt_post = np.vstack((lt - _mul(np.ascontiguousarray(t1.T), gain_t),
                         np.sqrt(lam) * gain_t))
    v1t_post = np.vstack((v1t, gain_t))
    v2t_post = np.vstack((v2t, u))
    draw_proposal(x, w_post, lt_post, sigma, v1t_post, v2t_post, key, proposal_out)
    return w_post, lt_post, v1t_post, v2t_post


@jit()
def draw_proposal(x, w, lt, sigma, v1t, v2t, key, out):
    """Draw ``out`` (d, M): column j is ``mu + sqrt(diag(Sigma)) * n_j``, ``mu = x w``,
    ``Sigma = x S x^T``, n_j standard normals of stream ``key``."""
    d, m = x.shape
    mean = _mul_vector(x, w)
    covar = sandwich(x, lt, sigma, v1t, v2t)
    normals = np.empty(d * m + (d * m) % 2)
    fill_normals(key, 0, normals)
    for i in range(d):
        scale = np.sqrt(covar[i, i])
        row = normals[i * m:(i + 1) * m]
        for j in range(m):
            out[i, j] = mean[i] + scale * row[j]
