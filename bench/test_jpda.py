"""JPDA with EHM, 100 targets on a jittered 6 m grid + 100 clutter points (the
``ss_jpda(100, ..., ehm=True, clutter_per_target=1.0)`` workload of
/work/shared/stonesoup_mtt_baseline.py): fasttrack (Kalman prediction of every track with
NumPy, :func:`pda_weights`, clusters as connected components of the gating pattern,
:func:`jpda_marginals` over all clusters) against Stone Soup 1.9.1's ``JPDAwithEHM``
(prediction, PDAHypothesiser, clustering, EHM), in the same run. Target: fasttrack <= 10 ms.
"""
import datetime

import numpy as np
import pytest
from scipy.sparse import csr_matrix
from scipy.sparse.csgraph import connected_components

from fasttrack.core.jpda import jpda_marginals, pda_weights

N = 100
PROB_DETECT, PROB_GATE = 0.9, 0.99
T0 = datetime.datetime(2025, 1, 1)
DT = datetime.timedelta(seconds=1)
P0 = np.diag([1.0, 0.1, 1.0, 0.1])


def scenario(n, spacing=6.0, seed=0):
    """Targets on a jittered grid: initial states (n, 4) as (x, vx, y, vy) and one position
    detection each, one second later (as the baseline script)."""
    rng = np.random.default_rng(seed)
    side = int(np.ceil(np.sqrt(n)))
    gx, gy = np.meshgrid(np.arange(side), np.arange(side))
    pos = np.c_[gx.ravel(), gy.ravel()][:n] * spacing + rng.normal(0, 1, (n, 2))
    vel = rng.normal(0, 1, (n, 2))
    return np.c_[pos[:, 0], vel[:, 0], pos[:, 1], vel[:, 1]], pos + vel + rng.normal(0, 1, (n, 2))


def workload(n=N, clutter_per_target=1.0):
    x0, z = scenario(n)
    lo, hi = z.min(0) - 10, z.max(0) + 10
    n_clutter = int(round(clutter_per_target * n))
    clutter = np.random.default_rng(1).uniform(lo, hi, (n_clutter, 2))
    density = max(n_clutter, 1) / float(np.prod(hi - lo))
    return x0, z, clutter, density


def models():
    from fasttrack import CombinedLinearGaussianTransitionModel, ConstantVelocity
    transition = CombinedLinearGaussianTransitionModel([ConstantVelocity(0.05)] * 2)
    f, q = transition.matrix(time_interval=1.0), transition.covar(time_interval=1.0)
    h = np.array([[1.0, 0, 0, 0], [0, 0, 1.0, 0]])
    return f, q, h, np.eye(2)


def clusters(weights):
    """Connected components of the bipartite track-detection gating pattern: a list of
    (track indices, weight columns) with the missed-detection column first."""
    n_tracks, n_cols = weights.shape
    rows, cols = np.nonzero(weights[:, 1:] > 0)
    graph = csr_matrix((np.ones(rows.size), (rows, cols + n_tracks)),
                       shape=(n_tracks + n_cols - 1,) * 2)
    _, labels = connected_components(graph, directed=True, connection="weak")
    track_labels, det_labels = labels[:n_tracks], labels[n_tracks:]
    used = np.zeros(n_cols - 1, dtype=bool)
    used[cols] = True
    tracks = np.argsort(track_labels, kind="stable")
    dets = np.flatnonzero(used)
    dets = dets[np.argsort(det_labels[dets], kind="stable")]
    found = np.unique(track_labels)
    t_bounds = np.searchsorted(track_labels[tracks], np.r_[found, found[-1] + 1])
    d_bounds = np.searchsorted(det_labels[dets], np.r_[found, found[-1] + 1])
    return [(tracks[t_bounds[k]:t_bounds[k + 1]],
             np.r_[0, dets[d_bounds[k]:d_bounds[k + 1]] + 1]) for k in range(found.size)]


def fasttrack_jpda(x0, covars, points, density, f, q, h, r):
    """Predict, weigh, cluster and associate: the (T, M + 1) marginals of every track."""
    means = x0 @ (h @ f).T
    s = h @ (f @ covars @ f.T + q) @ h.T + r
    weights = pda_weights(means, s, points, PROB_DETECT, PROB_GATE, density)
    groups = clusters(weights)
    marginals = jpda_marginals([weights[np.ix_(t, c)] for t, c in groups])
    out = np.zeros_like(weights)
    for (t, c), m in zip(groups, marginals):
        out[np.ix_(t, c)] = m
    return out


@pytest.fixture(scope="module")
def arrays():
    x0, z, clutter, density = workload()
    return x0, np.broadcast_to(P0, (N, 4, 4)).copy(), np.vstack([z, clutter]), density


def test_fasttrack(benchmark, arrays):
    benchmark.group = f"jpda-ehm N={N}"
    x0, covars, points, density = arrays
    out = benchmark.pedantic(fasttrack_jpda, args=(x0, covars, points, density, *models()),
                             rounds=50, iterations=1, warmup_rounds=2)
    np.testing.assert_allclose(out.sum(axis=1), 1.0, atol=1e-12)


def test_fasttrack_weights(benchmark, arrays):
    """:func:`pda_weights` alone (100 tracks x 200 detections)."""
    benchmark.group = f"jpda-weights N={N}"
    x0, covars, points, density = arrays
    f, q, h, r = models()
    means = x0 @ (h @ f).T
    s = h @ (f @ covars @ f.T + q) @ h.T + r
    benchmark.pedantic(pda_weights, args=(means, s, points, PROB_DETECT, PROB_GATE, density),
                       rounds=50, iterations=1, warmup_rounds=2)


def test_fasttrack_marginals(benchmark, arrays):
    """:func:`jpda_marginals` alone, on the clusters of the workload."""
    benchmark.group = f"jpda-marginals N={N}"
    x0, covars, points, density = arrays
    f, q, h, r = models()
    means = x0 @ (h @ f).T
    s = h @ (f @ covars @ f.T + q) @ h.T + r
    weights = pda_weights(means, s, points, PROB_DETECT, PROB_GATE, density)
    blocks = [weights[np.ix_(t, c)] for t, c in clusters(weights)]
    benchmark.extra_info["clusters"] = len(blocks)
    benchmark.extra_info["largest"] = max(b.shape for b in blocks)
    benchmark.pedantic(jpda_marginals, args=(blocks,), rounds=50, iterations=1,
                       warmup_rounds=2)


def test_stonesoup(benchmark, arrays):
    pytest.importorskip("stonesoup")
    from stonesoup.dataassociator.probability import JPDAwithEHM
    from stonesoup.hypothesiser.probability import PDAHypothesiser
    from stonesoup.models.measurement.linear import LinearGaussian
    from stonesoup.models.transition.linear import (CombinedLinearGaussianTransitionModel,
                                                    ConstantVelocity)
    from stonesoup.predictor.kalman import KalmanPredictor
    from stonesoup.types.detection import Clutter, Detection
    from stonesoup.types.state import GaussianState
    from stonesoup.types.track import Track
    from stonesoup.updater.kalman import KalmanUpdater
    benchmark.group = f"jpda-ehm N={N}"
    x0, covars, points, density = arrays
    transition = CombinedLinearGaussianTransitionModel([ConstantVelocity(0.05)] * 2)
    sensor = LinearGaussian(ndim_state=4, mapping=(0, 2), noise_covar=np.eye(2))
    associator = JPDAwithEHM(PDAHypothesiser(
        KalmanPredictor(transition), KalmanUpdater(sensor), clutter_spatial_density=density,
        prob_detect=PROB_DETECT, prob_gate=PROB_GATE))
    kinds = [Detection] * N + [Clutter] * (len(points) - N)
    made = {}

    def setup():  # fresh tracks each round: Stone Soup memoises predictions
        tracks = [Track([GaussianState(x.reshape(4, 1), P0, timestamp=T0)]) for x in x0]
        dets = [kind(p.reshape(2, 1), timestamp=T0 + DT, measurement_model=sensor)
                for kind, p in zip(kinds, points)]
        made.update(tracks=tracks, dets=dets)
        return (set(tracks), set(dets), T0 + DT), {}

    result = benchmark.pedantic(associator.associate, setup=setup, rounds=7, iterations=1)
    column = {id(d): j + 1 for j, d in enumerate(made["dets"])}
    theirs = np.zeros((N, len(points) + 1))
    for i, track in enumerate(made["tracks"]):
        for hypothesis in result[track]:
            theirs[i, column[id(hypothesis.measurement)] if hypothesis else 0] = float(
                hypothesis.probability)
    ours = fasttrack_jpda(x0, covars, points, density, *models())
    np.testing.assert_allclose(ours, theirs, rtol=0, atol=1e-9)
