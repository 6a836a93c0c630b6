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

Every inverse above is applied as the *ridge map* ``(F F^T + lambda I)^-1 F`` of a factor F
(:func:`_ridge_map`): by Cholesky when it is well conditioned, else from an orthogonal
factorisation of ``[F, sqrt(lambda) I]`` that never forms the regularised matrix, so kernel
values of any magnitude (a polynomial kernel far from the origin reaches 1e21 against
lambda = 1e-3) cost accuracy in proportion to the square root of its condition number and
never fail to factorise.
"""
import numpy as np

from .dispatch import jit
from .gram import MATRIX, factor
from .numeric import fill_normals
from .tunables import CHOLESKY_CONDITION as _CHOLESKY_CONDITION


@jit()
def _reflect(rows, v):
    """Each row r of ``rows`` (k, v.size) becomes ``r (I - 2 v v^T / v.v)`` (a Householder
    reflection from the right); nothing for v = 0."""
    vv = 0.0
    for j in range(v.size):
        vv += v[j] * v[j]
    if vv == 0.0:
        return
    for k in range(rows.shape[0]):
        row = rows[k]
        dot = 0.0
        for j in range(v.size):
            dot += row[j] * v[j]
        scale = 2.0 * dot / vv
        for j in range(v.size):
            row[j] -= scale * v[j]


@jit()
def _ridge_map(f, lam):
    """``(F F^T + lam I)^-1 F`` for F (p, n) and lam > 0.

    The eigenvalues of ``F F^T + lam I`` lie in ``[lam, trace]``, so ``trace / lam`` bounds
    its condition number: a well-conditioned problem (kernel values near 1, the usual
    case) takes a Cholesky factorisation, an ill-conditioned one (a polynomial kernel far
    from the origin: 1e21 against lam = 1e-3) the LQ route of :func:`_lq_ridge_map`.
    Neither can fail.
    """
    p, n = f.shape
    trace = p * lam
    for i in range(p):
        row = f[i]
        for j in range(n):
            trace += row[j] * row[j]
    if trace > _CHOLESKY_CONDITION * lam:
        return _lq_ridge_map(f, lam)
    a = _mul_t(f, f)
    c = np.zeros((p, p))  # lower Cholesky factor of a + lam I
    for i in range(p):
        ci = c[i]
        for j in range(i + 1):
            cj = c[j]
            total = a[i, j]
            for k in range(j):
                total -= ci[k] * cj[k]
            if j < i:
                ci[j] = total / cj[j]
            else:
                ci[i] = np.sqrt(max(total, 0.0) + lam)
    out = f.copy()  # (c c^T) out = f, by forward and back substitution
    for i in range(p):
        row = out[i]
        for j in range(i):
            coef = c[i, j]
            other = out[j]
            for col in range(n):
                row[col] -= coef * other[col]
        inv = 1.0 / c[i, i]
        for col in range(n):
            row[col] *= inv
    _back_substitute(c, out)
    return out


@jit()
def _lq_ridge_map(f, lam):
    """:func:`_ridge_map` without forming ``F F^T``.

    The LQ factorisation (Householder reflections on the rows) of ``B = [F, sqrt(lam) I]``
    (p, n + p) gives ``B = L Q`` with ``L L^T = F F^T + lam I``, so the map is
    ``L^-T Q[:, :n]``. Its conditioning is the square root of that of ``F F^T + lam I``, and
    it cannot fail: with lam > 0 every diagonal entry of L is at least ``sqrt(lam)`` in
    exact arithmetic (kernel values of 1e21 against lam = 1e-3 are fine, where a Cholesky
    factorisation of ``F F^T + lam I`` breaks down).
    """
    p, n = f.shape
    width = n + p
    b = np.zeros((p, width))
    for i in range(p):
        row = b[i]
        source = f[i]
        for j in range(n):
            row[j] = source[j]
        row[n + i] = np.sqrt(lam)
    reflectors = np.zeros((p, width))
    for i in range(p):  # reflector i maps b[i, i:] onto the axis, then acts on rows i:
        tail = b[i, i:]
        norm = 0.0
        for j in range(tail.size):
            norm += tail[j] * tail[j]
        v = reflectors[i, i:]
        for j in range(tail.size):
            v[j] = tail[j]
        v[0] += np.sqrt(norm) if tail[0] >= 0.0 else -np.sqrt(norm)
        _reflect(b[i:, i:], v)
    q = np.zeros((p, width))  # the first p rows of H_{p-1} ... H_0
    for i in range(p):
        q[i, i] = 1.0
    for i in range(p - 1, -1, -1):
        _reflect(q[:, i:], reflectors[i, i:])
    out = np.empty((p, n))  # L^T out = q[:, :n], L the lower triangle of b
    for i in range(p):
        for j in range(n):
            out[i, j] = q[i, j]
    _back_substitute(b, out)
    return out


@jit()
def _back_substitute(lower, out):
    """Solve ``L^T X = out`` in place for the (p, n) ``out``, L the lower triangle of the
    leading (p, p) block of ``lower``: rows from the last up, by row updates."""
    p, n = out.shape
    for i in range(p - 1, -1, -1):
        row = out[i]
        for j in range(i + 1, p):
            coef = lower[j, i]
            other = out[j]
            for col in range(n):
                row[col] -= coef * other[col]
        inv = 1.0 / lower[i, i]
        for col in range(n):
            row[col] *= inv


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
def _factor_matrix(a):
    """The low-rank factor of a positive semi-definite matrix (:func:`gram.factor`; its
    empty parameter arrays made here: a global array would be a read-only constant, and a
    second compilation of the factorisation)."""
    return factor(MATRIX, np.empty(0), np.zeros(0, dtype=np.bool_), a)


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
        The kernel (see :mod:`gram`; params resolved for the proposal and prior together).
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
    if r <= m:  # W = (Phi_new Phi_new^T + lam I)^-1 in feature space
        v2t_pred = _ridge_map(phi_new, lam)
        w_pred = _vector_mul(_mul_vector(phi, w), v2t_pred)
        root = _factor_matrix(sandwich(phi, lt, sigma, v1t, v2t))
        return w_pred, _mul(root, v2t_pred), phi_new, v2t_pred
    # more features than particles: A = (K + lam I)^-1 in particle space, where
    # Gamma = A Phi_new^T Phi and Z = I - A K
    solve = _ridge_map(np.ascontiguousarray(phi_new.T), lam)  # A Phi_new^T
    gamma = _mul(solve, phi)
    a_k = _mul(solve, phi_new)
    root = _factor_matrix(sandwich(gamma, lt, sigma, v1t, v2t))
    return _mul_vector(gamma, w), root, np.eye(m), a_k


@jit()
def update_embedding(kind, params, angles, y, z, w, lt, sigma, v1t, v2t, lam, x, key,
                     proposal_out):
    """Updated weights and kernel covariance factors, and the next proposal.

    Parameters
    ----------
    kind, params, angles
        The measurement kernel (see :mod:`gram`; params resolved for y and z together).
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
    # gain_t = (F F^T + lam I)^-1 F [Lt; sqrt(sigma) Z^T] with F = [t1, sqrt(sigma) u]
    k = t1.shape[1]
    root_sigma = np.sqrt(sigma)
    solve = _ridge_map(np.hstack((t1, root_sigma * u)), lam)
    gain_t = _mul(np.ascontiguousarray(solve[:, :k]), lt) + root_sigma * _deviation(
        np.ascontiguousarray(solve[:, k:]), v2t, v1t)
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
    fill_normals(key, np.int64(0), normals)
    for i in range(d):
        scale = np.sqrt(covar[i, i])
        row = normals[i * m:(i + 1) * m]
        for j in range(m):
            out[i, j] = mean[i] + scale * row[j]
