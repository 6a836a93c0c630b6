"""Linear algebra on blocks of B small matrices, laid out (n, n, B) with the block index last
so that the innermost loops run over the B matrices and vectorise; each function takes the
block's count ``nb`` first (see :mod:`kalman`)."""
import numpy as np

from .dispatch import jit
from .tunables import PSD_TOLERANCE
from .status import OK, PREDICTION_OVERFLOW


@jit()
def _cholesky(nb, a, lower, status, code):
    """Lower Cholesky factors of the symmetric (n, n, B) ``a``; where one is not positive
    definite, ``status`` becomes ``code`` (if still OK) and its factor is the identity."""
    n = a.shape[0]
    for j in range(n):
        for b in range(nb):
            s = a[j, j, b]
            for k in range(j):
                s -= lower[j, k, b] * lower[j, k, b]
            good = s > 0.0
            if not good and status[b] == OK:
                status[b] = code
            lower[j, j, b] = np.sqrt(s) if good else 1.0
        for i in range(n):
            for b in range(nb):
                if i < j:
                    lower[i, j, b] = 0.0
                elif i > j:
                    t = a[i, j, b]
                    for k in range(j):
                        t -= lower[i, k, b] * lower[j, k, b]
                    lower[i, j, b] = t / lower[j, j, b]


@jit()
def _check_covariance(nb, a, status, asymmetric, indefinite):
    """``status[b]`` (if still OK) becomes ``asymmetric`` where the (n, n, B) ``a`` is not
    symmetric (to 1e-9 of its largest entry) and ``indefinite`` where it is not positive
    semi-definite: a Cholesky factorisation in which a pivot within ``tol = PSD_TOLERANCE *
    max(diag)`` of zero counts as zero (its column must then vanish, to
    ``sqrt(tol max(diag))``) and a pivot below ``-tol`` means a negative eigenvalue. The
    loops run innermost over the B filters, branch-free, so that they vectorise."""
    n = a.shape[0]
    top = np.zeros(nb)
    largest = np.zeros(nb)
    for i in range(n):
        for j in range(n):
            for b in range(nb):
                largest[b] = max(largest[b], abs(a[i, j, b]))
                top[b] = max(top[b], a[i, j, b] if i == j else 0.0)
    symmetric = np.ones(nb, dtype=np.bool_)
    for i in range(n):
        for j in range(i):
            for b in range(nb):
                symmetric[b] &= abs(a[i, j, b] - a[j, i, b]) <= 1e-9 * largest[b]
    good = np.ones(nb, dtype=np.bool_)
    lower = np.zeros((n, n, nb))
    for j in range(n):
        for b in range(nb):
            s = a[j, j, b]
            for k in range(j):
                s -= lower[j, k, b] * lower[j, k, b]
            tol = PSD_TOLERANCE * top[b]
            good[b] &= s >= -tol
            lower[j, j, b] = np.sqrt(s) if s > tol else 0.0
        for i in range(j + 1, n):
            for b in range(nb):
                t = a[i, j, b]
                for k in range(j):
                    t -= lower[i, k, b] * lower[j, k, b]
                pivot = lower[j, j, b]
                lower[i, j, b] = t / pivot if pivot > 0.0 else 0.0
                good[b] &= pivot > 0.0 or abs(t) <= np.sqrt(PSD_TOLERANCE) * top[b]
    for b in range(nb):
        if status[b] == OK:
            if not symmetric[b]:
                status[b] = asymmetric
            elif not good[b]:
                status[b] = indefinite


@jit()
def _covariance_code(a, lower, asymmetric, indefinite):
    """OK, ``asymmetric`` or ``indefinite`` for one (n, n) ``a`` by the rule of
    :func:`_check_covariance` (NaN fails it); ``lower`` (n, n) is scratch, so that a
    loop over many matrices allocates nothing."""
    return _covariance_code_of(a.shape[0], a, lower, asymmetric, indefinite)


@jit(inline=True)
def _covariance_code_of(n, a, lower, asymmetric, indefinite):
    """:func:`_covariance_code` for (n, n) ``a``, inline: a build whose n is a constant
    unrolls it."""
    top = 0.0
    largest = 0.0
    for i in range(n):
        top = max(top, a[i, i])
        for j in range(n):
            largest = max(largest, abs(a[i, j]))
    for i in range(n):
        for j in range(i):
            if not abs(a[i, j] - a[j, i]) <= 1e-9 * largest:
                return asymmetric
    tol = PSD_TOLERANCE * top
    for j in range(n):
        s = a[j, j]
        for k in range(j):
            s -= lower[j, k] * lower[j, k]
        if not s >= -tol:
            return indefinite
        lower[j, j] = np.sqrt(s) if s > tol else 0.0
        for i in range(j + 1, n):
            t = a[i, j]
            for k in range(j):
                t -= lower[i, k] * lower[j, k]
            if lower[j, j] > 0.0:
                lower[i, j] = t / lower[j, j]
            elif abs(t) <= np.sqrt(PSD_TOLERANCE) * top:
                lower[i, j] = 0.0
            else:
                return indefinite
    return OK


@jit()
def _sandwich(nb, left, middle, work, out):
    """``out += left middle left^T`` per filter (lower triangle computed, mirrored)."""
    rows, inner = left.shape[0], left.shape[1]
    for r in range(rows):
        for c in range(inner):
            for b in range(nb):
                s = 0.0
                for k in range(inner):
                    s += left[r, k, b] * middle[k, c, b]
                work[r, c, b] = s
    for r in range(rows):
        for c in range(r + 1):
            for b in range(nb):
                s = out[r, c, b]
                for k in range(inner):
                    s += work[r, k, b] * left[c, k, b]
                out[r, c, b] = s
                out[c, r, b] = s


@jit()
def _solve(nb, lower, rhs, half, out):
    """``half = L^-1 rhs`` and ``out = L^-T half`` (the solution of ``L L^T out = rhs``) per
    filter, for lower Cholesky factors L (n, n, B) and ``rhs``, ``half``, ``out``
    (n, k, B)."""
    n, k = rhs.shape[0], rhs.shape[1]
    for c in range(k):
        for r in range(n):
            for b in range(nb):
                s = rhs[r, c, b]
                for j in range(r):
                    s -= lower[r, j, b] * half[j, c, b]
                half[r, c, b] = s / lower[r, r, b]
        for r in range(n - 1, -1, -1):
            for b in range(nb):
                s = half[r, c, b]
                for j in range(r + 1, n):
                    s -= lower[j, r, b] * out[j, c, b]
                out[r, c, b] = s / lower[r, r, b]


@jit()
def _check_overflow(nb, x_out, covariance_out, status):
    """``status[b]`` (if still OK) becomes PREDICTION_OVERFLOW where the predicted mean or
    covariance of filter b is not finite (``v * 0`` is NaN exactly then)."""
    d = x_out.shape[0]
    for b in range(nb):
        total = 0.0
        for r in range(d):
            total += x_out[r, b] * 0.0
            for c in range(d):
                total += covariance_out[r, c, b] * 0.0
        if status[b] == OK and total != 0.0:
            status[b] = PREDICTION_OVERFLOW
