"""Mirrors of ``fasttrack._jit.akkf``: the adaptive kernel Kalman filter's prediction,
update and proposal draw (contract formulas on dense matrices)."""
import numpy as np

from .gram import gram, resolve
from .numeric import fill_normals


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


def draw_proposal(x, w, lt, sigma, v1t, v2t, key, out):
    """``x w + sqrt(diag(x S x^T)) * normals`` (normals of stream ``key``, row-major)."""
    proposal_dense(x, w, dense_covariance(lt, sigma, v1t, v2t), key, out)
