"""Joint probabilistic data association (JPDA) kernels: the per-track hypothesis weights of
a PDA hypothesiser, and exact marginal association probabilities per cluster by efficient
hypothesis management (EHM; Maskell, Briers and Wright, "Fast mutual exclusion", 2004).

A cluster is a (T, M + 1) weight matrix: row t holds track t's hypothesis weights, column 0
its missed detection, column j >= 1 detection j - 1; a zero weight is an impossible (not
gated) hypothesis. A joint event gives every track one hypothesis, no detection to two
tracks; its weight is the product of its tracks' weights, and the marginal probability of
(t, j) is the total weight of the events giving j to t over the total of all events.

EHM runs the tracks in an order (a greedy one that keeps the *frontier* small: the
detections that a track already run and a track still to run can both take). The nodes of
level t are the distinct subsets of level t's frontier that tracks 0..t-1 have used: every
partial event reaching one node has the same futures, so equal nodes merge. A backward pass
sums the weights of the futures of each node, a forward pass the weights of its pasts, and
the marginal of (t, j) is the sum over level t's nodes of past x weight x future. The cost is
the number of (node, hypothesis) pairs, at most ``2**F`` nodes per level for a frontier of F
detections, against the product of the hypothesis counts for enumeration.

Limits: a node is a bitset of its level's frontier in an int64, so a frontier holds at
most :data:`MAX_FRONTIER` = 63 detections (a cluster may have any number of detections:
only those shared across the current cut count); and a cluster may have at most
``max_nodes`` nodes in all (memory: about 8 bytes per node and 8 per (node, hypothesis)
pair, plus the forward and backward weights). Forward and backward weights are rescaled per
level (by its largest), which leaves the marginals unchanged and keeps long products of
small weights from underflowing.

Kernels return status codes instead of raising: :data:`EHM_OK`, :data:`EHM_FRONTIER`
(detail: the frontier size needed), :data:`EHM_NODES` (detail: the nodes made so far),
:data:`EHM_INFEASIBLE` (detail: the track whose row is all zero, or -1 when every joint
event conflicts).
"""
import numpy as np

from .dispatch import jit
from .numeric import wrap_angle
from .status import INNOVATION_NOT_PD, OK
from .tunables import MAX_FRONTIER


EHM_OK = np.int64(0)
#: A frontier wider than MAX_FRONTIER detections.
EHM_FRONTIER = np.int64(1)
#: More nodes than ``max_nodes``.
EHM_NODES = np.int64(2)
#: No joint event has a positive weight.
EHM_INFEASIBLE = np.int64(3)

_HASH = np.int64(0x5851F42D4C957F2D)


@jit()
def _grown(a, need):
    """``a`` if it holds ``need`` entries, else a copy with room for at least ``need``."""
    if a.size >= need:
        return a
    b = np.empty(max(need, 2 * a.size), dtype=a.dtype)
    for i in range(a.size):
        b[i] = a[i]
    return b


@jit()
def _slot(key, mask):
    """Start slot of ``key`` in an open-addressing table of ``mask + 1`` slots."""
    h = (key ^ (key >> 29)) * _HASH
    return (h ^ (h >> 32)) & mask


@jit()
def _track_order(hyp_ptr, hyp_col, remaining, order):
    """A greedy track order that keeps the frontier small: at each step the track whose
    turn changes the frontier size least (then the one sharing most detections with it,
    then the lowest index). ``remaining[d]``: tracks that may take detection d (consumed)."""
    n_tracks = order.size
    active = np.zeros(remaining.size, dtype=np.bool_)
    placed = np.zeros(n_tracks, dtype=np.bool_)
    for step in range(n_tracks):
        best, best_delta, best_overlap = -1, np.int64(1) << 62, np.int64(-1)
        for c in range(n_tracks):
            if placed[c]:
                continue
            delta, overlap = np.int64(0), np.int64(0)
            for h in range(hyp_ptr[c], hyp_ptr[c + 1]):
                d = hyp_col[h] - 1
                if d < 0:
                    continue
                if active[d]:
                    overlap += 1
                    if remaining[d] == 1:
                        delta -= 1
                elif remaining[d] > 1:
                    delta += 1
            if delta < best_delta or (delta == best_delta and overlap > best_overlap):
                best, best_delta, best_overlap = c, delta, overlap
        placed[best] = True
        order[step] = best
        for h in range(hyp_ptr[best], hyp_ptr[best + 1]):
            d = hyp_col[h] - 1
            if d >= 0:
                remaining[d] -= 1
                active[d] = remaining[d] > 0


@jit()
def _ehm(w, n_tracks, n_dets, max_nodes, out):
    """EHM marginals of one cluster: ``w`` and ``out`` are its (T, M + 1) matrices flat
    (row-major). Returns (status, detail)."""
    cols = n_dets + 1
    for i in range(out.size):
        out[i] = 0.0
    if n_tracks == 0:
        return EHM_OK, np.int64(0)
    # The hypotheses of each track: its columns of positive weight.
    hyp_ptr = np.zeros(n_tracks + 1, dtype=np.int64)
    for t in range(n_tracks):
        k = 0
        for j in range(cols):
            if w[t * cols + j] > 0.0:
                k += 1
        if k == 0:
            return EHM_INFEASIBLE, np.int64(t)
        hyp_ptr[t + 1] = hyp_ptr[t] + k
    hyp_col = np.empty(hyp_ptr[n_tracks], dtype=np.int64)
    hyp_w = np.empty(hyp_ptr[n_tracks], dtype=np.float64)
    remaining = np.zeros(n_dets, dtype=np.int64)
    max_h = 0
    for t in range(n_tracks):
        h = hyp_ptr[t]
        max_h = max(max_h, hyp_ptr[t + 1] - h)
        for j in range(cols):
            if w[t * cols + j] > 0.0:
                hyp_col[h] = j
                hyp_w[h] = w[t * cols + j]
                if j > 0:
                    remaining[j - 1] += 1
                h += 1
    order = np.empty(n_tracks, dtype=np.int64)
    _track_order(hyp_ptr, hyp_col, remaining.copy(), order)

    # Forward construction of the net, level by level.
    bit = np.full(n_dets, -1, dtype=np.int64)  # frontier position of each detection
    front = np.empty(MAX_FRONTIER, dtype=np.int64)
    new_front = np.empty(MAX_FRONTIER, dtype=np.int64)
    remap = np.empty(MAX_FRONTIER, dtype=np.int64)
    old_bit = np.empty(max_h, dtype=np.int64)
    new_bit = np.empty(max_h, dtype=np.int64)
    n_front = 0
    keys = np.empty(64, dtype=np.int64)
    children = np.empty(256, dtype=np.int64)
    level_start = np.empty(n_tracks + 2, dtype=np.int64)
    edge_start = np.empty(n_tracks + 1, dtype=np.int64)
    keys[0] = 0
    level_start[0], level_start[1] = 0, 1
    n_edges = 0
    for t in range(n_tracks):
        tr = order[t]
        h0, nh = hyp_ptr[tr], hyp_ptr[tr + 1] - hyp_ptr[tr]
        for k in range(nh):
            d = hyp_col[h0 + k] - 1
            if d >= 0:
                remaining[d] -= 1
        # The next frontier: the survivors of this one, then this track's new detections.
        nf = 0
        for p in range(n_front):
            d = front[p]
            if remaining[d] > 0:
                remap[p] = nf
                new_front[nf] = d
                nf += 1
            else:
                remap[p] = -1
        width = nf
        for k in range(nh):
            d = hyp_col[h0 + k] - 1
            if d >= 0 and bit[d] < 0 and remaining[d] > 0:
                if width < MAX_FRONTIER:
                    new_front[width] = d
                width += 1
        if width > MAX_FRONTIER:
            return EHM_FRONTIER, np.int64(width)
        for k in range(nh):
            d = hyp_col[h0 + k] - 1
            old_bit[k] = bit[d] if d >= 0 else -1
        for p in range(n_front):
            bit[front[p]] = -1
        for q in range(width):
            bit[new_front[q]] = q
            front[q] = new_front[q]
        for k in range(nh):
            d = hyp_col[h0 + k] - 1
            new_bit[k] = bit[d] if d >= 0 else -1
        # Children of each node of this level, merged by key through a hash table.
        lo, hi = level_start[t], level_start[t + 1]
        n_level = hi - lo
        edge_start[t] = n_edges
        children = _grown(children, n_edges + n_level * nh)
        bound = n_level * nh
        if width < 62:
            bound = min(bound, np.int64(1) << width)
        cap = np.int64(4)
        while cap < 2 * bound:
            cap *= 2
        mask = cap - 1
        table = np.full(cap, -1, dtype=np.int64)
        n_next = 0
        for i in range(n_level):
            key = keys[lo + i]
            base = np.int64(0)
            for p in range(n_front):
                if (key >> p) & 1 and remap[p] >= 0:
                    base |= np.int64(1) << remap[p]
            for k in range(nh):
                ob = old_bit[k]
                if ob >= 0 and (key >> ob) & 1:
                    children[n_edges] = -1
                    n_edges += 1
                    continue
                nb = new_bit[k]
                child_key = base | (np.int64(1) << nb) if nb >= 0 else base
                s = _slot(child_key, mask)
                while True:
                    found = table[s]
                    if found < 0:
                        keys = _grown(keys, hi + n_next + 1)
                        keys[hi + n_next] = child_key
                        table[s] = n_next
                        found = n_next
                        n_next += 1
                        break
                    if keys[hi + found] == child_key:
                        break
                    s = (s + 1) & mask
                children[n_edges] = found
                n_edges += 1
        level_start[t + 2] = hi + n_next
        if n_next == 0:
            return EHM_INFEASIBLE, np.int64(-1)
        if hi + n_next > max_nodes:
            return EHM_NODES, hi + n_next
        n_front = width
    edge_start[n_tracks] = n_edges
    n_nodes = level_start[n_tracks + 1]

    # Backward weights: the total weight of each node's futures (rescaled per level).
    back = np.empty(n_nodes, dtype=np.float64)
    back[n_nodes - 1] = 1.0
    for t in range(n_tracks - 1, -1, -1):
        tr = order[t]
        h0, nh = hyp_ptr[tr], hyp_ptr[tr + 1] - hyp_ptr[tr]
        lo, hi, nxt = level_start[t], level_start[t + 1], level_start[t + 1]
        top = 0.0
        for i in range(hi - lo):
            e = edge_start[t] + i * nh
            s = 0.0
            for k in range(nh):
                c = children[e + k]
                if c >= 0:
                    s += hyp_w[h0 + k] * back[nxt + c]
            back[lo + i] = s
            top = max(top, s)
        if top == 0.0:
            return EHM_INFEASIBLE, np.int64(-1)
        for i in range(hi - lo):
            back[lo + i] /= top

    # Forward weights (the total weight of each node's pasts) and the marginals.
    fwd = np.zeros(n_nodes, dtype=np.float64)
    fwd[0] = 1.0
    acc = np.empty(max_h, dtype=np.float64)
    for t in range(n_tracks):
        tr = order[t]
        h0, nh = hyp_ptr[tr], hyp_ptr[tr + 1] - hyp_ptr[tr]
        lo, hi = level_start[t], level_start[t + 1]
        nxt, nxt_hi = hi, level_start[t + 2]
        for k in range(nh):
            acc[k] = 0.0
        for i in range(hi - lo):
            f = fwd[lo + i]
            e = edge_start[t] + i * nh
            for k in range(nh):
                c = children[e + k]
                if c >= 0:
                    v = f * hyp_w[h0 + k]
                    fwd[nxt + c] += v
                    acc[k] += v * back[nxt + c]
        total = 0.0
        for k in range(nh):
            total += acc[k]
        if not total > 0.0:
            return EHM_INFEASIBLE, np.int64(-1)
        for k in range(nh):
            out[tr * cols + hyp_col[h0 + k]] = acc[k] / total
        top = 0.0
        for i in range(nxt, nxt_hi):
            top = max(top, fwd[i])
        if top > 0.0:
            for i in range(nxt, nxt_hi):
                fwd[i] /= top
    return EHM_OK, np.int64(0)


@jit()
def ehm_marginals(weights, max_nodes, out):
    """Exact JPDA marginal association probabilities of one cluster, by EHM.

    Parameters
    ----------
    weights : (T, M + 1) float64, C-contiguous
        Hypothesis weights, >= 0 (column 0 missed detection, column j detection j - 1;
        0 = impossible); every row has a positive entry.
    max_nodes : int
        Most nodes the net may have.
    out : (T, M + 1) float64, C-contiguous
        Written: the marginal probabilities (each row sums to 1; 0 where the weight is 0).

    Returns
    -------
    status, detail : int
        See the module docstring.
    """
    return _ehm(weights.reshape(-1), weights.shape[0], weights.shape[1] - 1, max_nodes,
                out.reshape(-1))


@jit()
def ehm_marginals_batch(weights, offsets, shapes, max_nodes, out, info):
    """:func:`ehm_marginals` of many clusters stored flat (a slice of the clusters, of
    ``offsets``, ``shapes`` and ``info``, computes those clusters alone).

    Parameters
    ----------
    weights : (W,) float64
        The (T_c, M_c + 1) weight matrices of the clusters, row-major, concatenated.
    offsets : (C + 1,) int64
        Cluster c's entries are ``weights[offsets[c]:offsets[c + 1]]``.
    shapes : (C, 2) int64
        ``(T_c, M_c)`` of each cluster.
    max_nodes : int
        Most nodes per cluster.
    out : (W,) float64
        Written: the marginals, laid out as ``weights``.
    info : (C, 2) int64
        Written: (status, detail) of each cluster.
    """
    for c in range(shapes.shape[0]):
        lo, hi = offsets[c], offsets[c + 1]
        status, detail = _ehm(weights[lo:hi], shapes[c, 0], shapes[c, 1], max_nodes,
                              out[lo:hi])
        info[c, 0] = status
        info[c, 1] = detail


@jit()
def _unbounded_gate(row, kept, n_kept, d2):
    """A track's row in the limit of an unbounded gate (``prob_gate`` 1) with no clutter
    density, whose estimate n / V tends to 0, up to a factor: the missed detection 0, the
    kept detections (``kept[:n_kept]``) in proportion to ``exp(-d2 / 2)``, relative to
    the nearest (so that none underflows)."""
    nearest = np.inf
    for k in range(n_kept):
        nearest = min(nearest, d2[kept[k]])
    row[0] = 0.0
    for k in range(n_kept):
        d = kept[k]
        row[d + 1] = np.exp(-0.5 * (d2[d] - nearest))


@jit()
def pda_weight_matrix(means, covars, detections, angles, gate, prob_detect, prob_gate,
                      gate_threshold, clutter_spatial_density, volume_factor, include_all,
                      out, status):
    """PDA hypothesis weights of T tracks against M detections (Stone Soup's
    PDAHypothesiser, unnormalised).

    Missed detection ``1 - prob_detect * prob_gate``; detection j, if its squared
    Mahalanobis distance is within ``gate_threshold`` (or ``include_all``) and ``gate``
    allows it: ``prob_detect * N(z_j; mean, S) / clutter_spatial_density``, or, for a density
    <= 0 (none given), ``prob_detect * N(z_j; mean, S) * V / n`` with the gate volume
    ``V = volume_factor * sqrt(det S)`` and n the detections inside the gate; with an
    infinite ``gate_threshold`` and no density, the limit of the row up to a factor (the
    missed detection 0, detection j in proportion to ``exp(-d2_j / 2)``) where n > 0.

    Parameters
    ----------
    means : (T, m) float64
        Predicted measurements.
    covars : (T, m, m) float64
        Innovation covariances S (symmetric; the lower triangle is read).
    detections : (M, m) float64
    angles : (m,) bool
        Components whose innovation is wrapped to [-pi, pi).
    gate : (T, M) bool
        Pairs that may associate (False: weight 0, and not counted inside the gate).
    prob_detect, prob_gate, gate_threshold, clutter_spatial_density, volume_factor : float
    include_all : bool
        Keep detections outside the gate.
    out : (T, M + 1) float64
        Written: the weights.
    status : (T,) int64
        Written: OK, or INNOVATION_NOT_PD where S is not positive definite (its row is 0).
    """
    n_tracks, m = means.shape
    n_dets = detections.shape[0]
    log_norm = m * np.log(2.0 * np.pi)
    columns = np.empty((m, n_dets), dtype=np.float64)  # detections component-major
    for d in range(n_dets):
        for i in range(m):
            columns[i, d] = detections[d, i]
    for t in range(n_tracks):
        row = out[t]
        lower = np.zeros((m, m), dtype=np.float64)
        row[0] = 1.0 - prob_detect * prob_gate
        status[t] = OK
        for j in range(m):
            s = covars[t, j, j]
            for k in range(j):
                s -= lower[j, k] * lower[j, k]
            if not s > 0.0:
                status[t] = INNOVATION_NOT_PD
                break
            lower[j, j] = np.sqrt(s)
            for i in range(j + 1, m):
                v = covars[t, i, j]
                for k in range(j):
                    v -= lower[i, k] * lower[j, k]
                lower[i, j] = v / lower[j, j]
        if status[t] != OK:
            for j in range(n_dets + 1):
                row[j] = 0.0
            continue
        log_det = 0.0
        for j in range(m):
            log_det += np.log(lower[j, j])
        log_det *= 2.0
        # Whitened innovations L^-1 (z - z_hat), all detections at once (vectorised).
        white = np.empty((m, n_dets), dtype=np.float64)
        d2 = np.zeros(n_dets, dtype=np.float64)
        for i in range(m):
            wi = white[i]
            zi = columns[i]
            mean = means[t, i]
            for d in range(wi.size):
                wi[d] = zi[d] - mean
            if angles[i]:
                for d in range(wi.size):
                    wi[d] = wrap_angle(wi[d])
            for k in range(i):
                lik = lower[i, k]
                wk = white[k]
                for d in range(wi.size):
                    wi[d] -= lik * wk[d]
            inv = 1.0 / lower[i, i]
            for d in range(wi.size):
                wi[d] *= inv
                d2[d] += wi[d] * wi[d]
        # Pairs kept, compacted first: a branch around the exp lets LLVM evaluate it for
        # every pair (most are outside the gate).
        kept = np.empty(n_dets, dtype=np.int64)
        inside = 0
        n_kept = 0
        for d in range(kept.size):
            row[d + 1] = 0.0
            allowed = gate[t, d]
            valid = allowed and d2[d] <= gate_threshold
            inside += valid
            kept[n_kept] = d
            n_kept += valid or (allowed and include_all)
        if clutter_spatial_density <= 0.0 and gate_threshold == np.inf and inside > 0:
            _unbounded_gate(row, kept, n_kept, d2)
            continue
        for k in range(n_kept):
            d = kept[k]
            row[d + 1] = prob_detect * np.exp(-0.5 * (log_det + d2[d] + log_norm))
        if clutter_spatial_density > 0.0:
            for d in range(n_dets):
                row[d + 1] /= clutter_spatial_density
        elif inside > 0:
            scale = volume_factor * np.exp(0.5 * log_det) / inside
            for d in range(n_dets):
                row[d + 1] *= scale
