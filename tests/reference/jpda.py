"""Mirrors of ``fasttrack._jit.jpda``: EHM marginals by enumerating every joint event, and
PDAHypothesiser's weights."""
import numpy as np

from .numeric import wrap_angle


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
        if clutter_spatial_density <= 0 and np.isinf(gate_threshold) and valid.any():
            out[t, 0] = 0.0
            out[t, 1:] = np.where(kept, np.exp(-0.5 * (d2 - d2[kept].min())), 0.0)
        elif clutter_spatial_density > 0:
            out[t, 1:] /= clutter_spatial_density
        elif valid.any():
            out[t, 1:] *= volume_factor * np.sqrt(np.linalg.det(covars[t])) / valid.sum()
