"""Mirrors of ``fasttrack._jit.gating``: gating, clusters and nearest-neighbour assignment,
on dense matrices."""
import numpy as np

from .numeric import wrap_angle


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
        starts[1:] = np.isfinite(d2).sum(axis=1)
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
