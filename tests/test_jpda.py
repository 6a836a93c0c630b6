"""JPDA: PDA hypothesis weights and exact marginals by EHM, against brute-force enumeration
(tests/reference/jpda.py) and Stone Soup's PDAHypothesiser, JPDA and JPDAwithEHM."""
import datetime
import json
import os
import subprocess
import sys

import numpy as np
import pytest
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

import reference.jpda
from fasttrack._jit import jpda as kernels
from fasttrack.core.jpda import MAX_NODES, jpda_marginals, pda_weights


def brute(weights):
    """Marginals by enumeration (the mirror), or None when no joint event is feasible."""
    out = np.empty_like(weights)
    status, _ = reference.jpda.ehm_marginals(weights, MAX_NODES, out)
    return out if status == 0 else None


def random_cluster(rng, n_tracks, n_dets, density=0.5):
    w = rng.random((n_tracks, n_dets + 1)) * (rng.random((n_tracks, n_dets + 1)) < density)
    w[:, 0] = rng.random(n_tracks) + 0.01
    return w


def components(weights):
    """Clusters of a full (T, M + 1) weight matrix: connected components of the nonzero
    pattern of its detection columns. Returns [(tracks, detections), ...]."""
    from scipy.sparse import csr_matrix
    from scipy.sparse.csgraph import connected_components
    pattern = csr_matrix(weights[:, 1:] > 0)
    n_tracks = pattern.shape[0]
    _, labels = connected_components(pattern @ pattern.T, directed=False)
    clusters = []
    for c in np.unique(labels):
        tracks = np.flatnonzero(labels == c)
        dets = np.flatnonzero(pattern[tracks].sum(axis=0).A1 > 0)
        clusters.append((tracks, dets))
    assert sum(t.size for t, _ in clusters) == n_tracks
    return clusters


def clustered_marginals(weights):
    """:func:`jpda_marginals` of every cluster of a full matrix, put back in place."""
    clusters = components(weights)
    blocks = [weights[np.ix_(t, np.r_[0, d + 1])] for t, d in clusters]
    out = np.zeros_like(weights)
    for (t, d), m in zip(clusters, jpda_marginals(blocks)):
        out[np.ix_(t, np.r_[0, d + 1])] = m
    return out


# --- EHM against enumeration ---------------------------------------------------------------


@st.composite
def cluster_weights(draw):
    n_tracks = draw(st.integers(1, 6))
    n_dets = draw(st.integers(0, 6))
    values = draw(arrays(np.float64, (n_tracks, n_dets + 1),
                         elements=st.floats(1e-6, 1e6, allow_nan=False)))
    density = draw(st.sampled_from([0.2, 0.4, 0.6, 1.0]))
    keep = draw(arrays(np.float64, (n_tracks, n_dets + 1),
                       elements=st.floats(0, 1, allow_nan=False))) < density
    if draw(st.booleans()):
        keep[:, 0] = True
    return np.where(keep, values, 0.0)


@settings(max_examples=250, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(cluster_weights())
def test_ehm_equals_brute_force(weights):
    assume(np.prod(np.maximum((weights > 0).sum(axis=1), 1)) <= 30_000)
    expected = brute(weights)
    if expected is None:
        with pytest.raises(ValueError, match="weights"):
            jpda_marginals(weights)
        return
    got = jpda_marginals(weights)
    np.testing.assert_allclose(got, expected, rtol=0, atol=1e-12)
    np.testing.assert_allclose(got.sum(axis=1), 1.0, rtol=0, atol=1e-12)
    assert (got[weights == 0] == 0).all()


def test_kernel_matches_its_mirror():
    rng = np.random.default_rng(3)
    for _ in range(50):
        w = random_cluster(rng, rng.integers(1, 6), rng.integers(0, 6))
        got, expected = np.empty_like(w), np.empty_like(w)
        assert kernels.ehm_marginals(w, MAX_NODES, got) == (0, 0)
        assert reference.jpda.ehm_marginals(w, MAX_NODES, expected) == (0, 0)
        np.testing.assert_allclose(got, expected, rtol=0, atol=1e-12)


def test_single_track_is_pda():
    w = np.array([[0.3, 2.0, 0.0, 5.0, 0.7]])
    np.testing.assert_allclose(jpda_marginals(w), w / w.sum(), rtol=1e-15)
    np.testing.assert_array_equal(jpda_marginals(np.array([[0.2]])), [[1.0]])


def test_batched_equals_per_cluster():
    rng = np.random.default_rng(5)
    clusters = [random_cluster(rng, rng.integers(1, 7), rng.integers(0, 7)) for _ in range(40)]
    clusters.append(np.empty((0, 4)))
    batched = jpda_marginals(clusters)
    assert isinstance(batched, list) and len(batched) == len(clusters)
    for w, m in zip(clusters, batched):
        assert m.shape == w.shape
        np.testing.assert_array_equal(m, jpda_marginals(w))
        if w.shape[0]:
            np.testing.assert_allclose(m, brute(w), rtol=0, atol=1e-12)
    assert jpda_marginals([]) == []


def test_a_list_of_rows_is_one_cluster():
    w = [[0.5, 1.0, 0.0], [0.5, 1.0, 1.0]]
    np.testing.assert_allclose(jpda_marginals(w), brute(np.array(w)), atol=1e-15)


def test_independent_tracks_factorise_and_order_does_not_matter():
    rng = np.random.default_rng(11)
    a, b = random_cluster(rng, 4, 5, 0.7), random_cluster(rng, 3, 4, 0.7)
    joint = np.zeros((7, 10))
    joint[:4, :6] = a
    joint[4:, 0] = b[:, 0]
    joint[4:, 6:] = b[:, 1:]
    m = jpda_marginals(joint)
    np.testing.assert_allclose(m[:4, :6], jpda_marginals(a), atol=1e-14)
    np.testing.assert_allclose(m[4:, 6:], jpda_marginals(b)[:, 1:], atol=1e-14)
    tracks, dets = rng.permutation(7), rng.permutation(9)
    cols = np.r_[0, dets + 1]
    np.testing.assert_allclose(jpda_marginals(joint[np.ix_(tracks, cols)]),
                               m[np.ix_(tracks, cols)], atol=1e-14)
    np.testing.assert_allclose(clustered_marginals(joint), m, atol=1e-14)


def test_long_chain_is_exact_and_does_not_underflow():
    """500 tracks in a chain (track t may take detections t and t + 1): a frontier of one
    detection. Rows scaled by 1e-250 (products far below the smallest double) give the same
    marginals; a 12-track piece agrees with enumeration."""
    rng = np.random.default_rng(2)
    n = 500
    w = np.zeros((n, n + 2))
    w[:, 0] = rng.random(n) + 0.1
    w[np.arange(n), np.arange(n) + 1] = rng.random(n) + 0.1
    w[np.arange(n), np.arange(n) + 2] = rng.random(n) + 0.1
    m = jpda_marginals(w)
    np.testing.assert_allclose(m.sum(axis=1), 1.0, atol=1e-12)
    np.testing.assert_allclose(jpda_marginals(w * 1e-250), m, rtol=1e-12, atol=1e-300)
    piece = w[:12, :14]
    np.testing.assert_allclose(jpda_marginals(piece), brute(piece), atol=1e-12)


def test_dense_cluster_agrees_with_enumeration():
    rng = np.random.default_rng(9)
    w = rng.random((6, 7)) + 0.01  # every track gates every detection: 7**6 events
    np.testing.assert_allclose(jpda_marginals(w), brute(w), rtol=0, atol=1e-12)


def test_inputs_are_not_modified():
    rng = np.random.default_rng(1)
    w = random_cluster(rng, 5, 5)
    before = w.copy()
    jpda_marginals(w)
    jpda_marginals([w, w])
    np.testing.assert_array_equal(w, before)


_THREAD_SCRIPT = r"""
import json, sys
import numpy as np
from fasttrack.core import jpda
from fasttrack.core.jpda import jpda_marginals, pda_weights
if sys.argv[1:] == ["parallel"]:
    jpda.SERIAL_BELOW_HEAVY = jpda.SERIAL_BELOW_PAIRS = 0  # chunks on threads, however small
rng = np.random.default_rng(4)
clusters = []
for _ in range(64):
    t, m = rng.integers(1, 8, size=2)
    w = rng.random((t, m + 1)) * (rng.random((t, m + 1)) < 0.5)
    w[:, 0] += 0.01
    clusters.append(w)
out = [v.hex() for c in jpda_marginals(clusters) for v in c.ravel()]
means, dets = rng.normal(0, 3, (40, 2)), rng.normal(0, 3, (60, 2))
covars = np.broadcast_to(np.array([[2.0, 0.3], [0.3, 1.5]]), (40, 2, 2))
out += [v.hex() for v in pda_weights(means, covars, dets, 0.9, 0.99, 0.02).ravel()]
json.dump(out, sys.stdout)
"""


def test_batched_results_do_not_depend_on_the_thread_count():
    def run(threads, *args):
        env = dict(os.environ, NUMBA_NUM_THREADS=str(threads))
        done = subprocess.run([sys.executable, "-c", _THREAD_SCRIPT, *args], env=env,
                              capture_output=True, text=True, check=True, timeout=900)
        return json.loads(done.stdout)
    serial = run(2)
    assert run(1, "parallel") == run(2, "parallel") == serial


# --- limits and bad input ------------------------------------------------------------------


def test_a_cluster_with_a_wide_frontier_is_refused_naming_its_size():
    w = np.ones((2, 71))
    with pytest.raises(ValueError, match=r"weights \(2 tracks x 70 detections\).*frontier "
                                         r"of 70 shared detections, more than 63"):
        jpda_marginals(w)
    with pytest.raises(ValueError, match=r"weights\[1\] \(2 tracks x 70 detections\)"):
        jpda_marginals([np.ones((1, 3)), w])


def test_a_cluster_above_max_nodes_is_refused():
    w = np.ones((6, 7))
    with pytest.raises(ValueError, match=r"6 tracks x 6 detections.*max_nodes=10 nodes"):
        jpda_marginals(w, max_nodes=10)
    np.testing.assert_allclose(jpda_marginals(w, max_nodes=200), brute(w), atol=1e-12)


def test_infeasible_clusters_are_refused():
    with pytest.raises(ValueError, match="no joint association of positive weight"):
        jpda_marginals(np.array([[0.0, 1.0], [0.0, 1.0]]))
    with pytest.raises(ValueError, match=r"weights\[0\] row 1 is all zero"):
        jpda_marginals([np.array([[1.0, 1.0], [0.0, 0.0]])])


@pytest.mark.parametrize("weights, error, match", [
    (np.array([[1.0, np.nan]]), ValueError, "weights contains NaN"),
    (np.array([[1.0, np.inf]]), ValueError, "weights contains infinite"),
    (np.array([[1.0, -0.5]]), ValueError, "weights contains negative"),
    (np.ones(3), ValueError, "weights must be 2-D"),
    (np.ones((2, 0)), ValueError, "missed-detection column"),
    (np.array([["a", "b"]]), TypeError, "weights must be a numeric array"),
    ([np.ones((1, 2)), np.array([[1.0, -1.0]])], ValueError, r"weights\[1\] contains negative"),
])
def test_bad_weights(weights, error, match):
    with pytest.raises(error, match=match):
        jpda_marginals(weights)


def test_weights_near_the_float_limit_give_the_marginals_of_scaled_weights():
    """Every joint event takes one weight a row: rows of 1e308 give the marginals of rows
    of 1 (the products would overflow), one cluster or several."""
    rng = np.random.default_rng(3)
    w = rng.uniform(0.1, 1.0, (3, 4))
    for clusters in ([w], [w, w[:2]]):
        want = jpda_marginals([c.copy() for c in clusters])
        got = jpda_marginals([c * 1e308 for c in clusters])
        for a, b in zip(got, want):
            np.testing.assert_allclose(a, b, rtol=1e-12)
    np.testing.assert_allclose(jpda_marginals(w * 1e308), jpda_marginals(w), rtol=1e-12)
    np.testing.assert_allclose(jpda_marginals(np.full((3, 4), 1e308)),
                               jpda_marginals(np.ones((3, 4))), rtol=1e-12)


@pytest.mark.parametrize("max_nodes, error", [(1.5, TypeError), (0, ValueError),
                                              (True, TypeError)])
def test_bad_max_nodes(max_nodes, error):
    with pytest.raises(error, match="max_nodes"):
        jpda_marginals(np.ones((1, 2)), max_nodes=max_nodes)


def _pda_inputs(rng, n_tracks=4, n_dets=6, m=2):
    means = rng.normal(0, 2, (n_tracks, m))
    a = rng.normal(0, 1, (n_tracks, m, m))
    covars = a @ a.transpose(0, 2, 1) + np.eye(m)
    dets = rng.normal(0, 2, (n_dets, m))
    return means, covars, dets


@pytest.mark.parametrize("kwargs", [
    {}, {"clutter_spatial_density": None}, {"include_all": True},
    {"gate": "random"}, {"angles": np.array([True, False, False])},
    {"gate": "random", "clutter_spatial_density": None, "prob_gate": 0.5},
    {"gate": "random", "clutter_spatial_density": None, "prob_gate": 1.0},
])
def test_pda_weight_kernel_matches_its_mirror(kwargs):
    rng = np.random.default_rng(8)
    means, covars, dets = _pda_inputs(rng, 5, 9, 3)
    if "angles" in kwargs:
        means[:, 0] = rng.uniform(-np.pi, np.pi, 5)
        dets[:, 0] = rng.uniform(-np.pi, np.pi, 9)
    gate = rng.random((5, 9)) < 0.7 if kwargs.get("gate") == "random" else np.ones((5, 9), bool)
    angles = kwargs.get("angles", np.zeros(3, bool))
    density = kwargs.get("clutter_spatial_density", 1e-3)
    from scipy.stats import chi2
    from scipy.special import gamma
    pg = kwargs.get("prob_gate", 0.99)
    threshold = chi2.ppf(pg, 3)
    factor = np.pi ** 1.5 / gamma(2.5) * threshold ** 1.5
    args = (means, covars, dets, angles, gate, 0.8, pg, threshold, density or 0.0, factor,
            kwargs.get("include_all", False))
    got, expected = np.empty((5, 10)), np.empty((5, 10))
    s1, s2 = np.empty(5, np.int64), np.empty(5, np.int64)
    kernels.pda_weight_matrix(*args, got, s1)
    reference.jpda.pda_weight_matrix(*args, expected, s2)
    np.testing.assert_array_equal(s1, s2)
    np.testing.assert_allclose(got, expected, rtol=1e-12, atol=0)
    assert (got[:, 1:] > 0).any()
    public = dict(kwargs, gate=gate, angles=angles)
    public.pop("prob_gate", None)
    limit = pg == 1.0 and density is None  # only its normalised rows are finite
    w = pda_weights(means, covars, dets, prob_detect=0.8, prob_gate=pg, normalise=limit,
                    **{"clutter_spatial_density": 1e-3, **public})
    if limit:
        expected /= expected.sum(axis=1, keepdims=True)
    np.testing.assert_allclose(w, expected, rtol=1e-12, atol=0)


def test_pda_weights_normalise_and_edge_cases():
    rng = np.random.default_rng(4)
    means, covars, dets = _pda_inputs(rng)
    raw = pda_weights(means, covars, dets, 0.9, 0.9, 0.01, normalise=False)
    np.testing.assert_allclose(pda_weights(means, covars, dets, 0.9, 0.9, 0.01),
                               raw / raw.sum(axis=1, keepdims=True), rtol=1e-15)
    assert pda_weights(means, covars, np.empty((0, 2)), 0.9).shape == (4, 1)
    assert pda_weights(np.empty((0, 2)), np.empty((0, 2, 2)), dets, 0.9).shape == (0, 7)
    far = pda_weights(means, covars, dets + 1e3, 0.9, 0.9, 0.01, normalise=False)
    np.testing.assert_allclose(far[:, 0], 1 - 0.81)
    assert (far[:, 1:] == 0).all()
    before = [a.copy() for a in (means, covars, dets)]
    pda_weights(means, covars, dets, gate=np.ones((4, 6), bool))
    for a, b in zip((means, covars, dets), before):
        np.testing.assert_array_equal(a, b)


def test_an_unbounded_gate_without_clutter_density_gives_the_limit_of_the_weights():
    """prob_gate = 1 without a clutter density: each row is its limit as prob_gate tends
    to 1 (the estimated density n / V tends to 0): missed detection 0, detections by their
    likelihoods, even where every likelihood underflows; no detection: missed only."""
    rng = np.random.default_rng(6)
    means, covars, dets = _pda_inputs(rng, 4, 5, 2)
    gate = np.ones((4, 5), bool)
    gate[3] = False  # nothing can associate with track 3
    got = pda_weights(means, covars, dets, 0.9, 1.0, gate=gate)
    for t in range(3):
        d2 = [float(v @ np.linalg.solve(covars[t], v)) for v in dets - means[t]]
        likelihood = np.exp(-0.5 * (np.array(d2) - min(d2)))
        np.testing.assert_allclose(got[t], np.r_[0.0, likelihood / likelihood.sum()],
                                   rtol=1e-12, atol=1e-300)
    np.testing.assert_array_equal(got[3], np.r_[1.0, np.zeros(5)])
    missed = [pda_weights(means[:3], covars[:3], dets, 0.9, pg)[:, 0]
              for pg in (0.99, 1 - 1e-6, 1 - 1e-15)]
    assert (np.diff(missed, axis=0) < 0).all()  # falling towards the limit's 0
    far = pda_weights(means[:1], np.eye(2)[None], means[:1] + [[1e3, 0.0], [0.0, 1.1e3]], 0.9,
                      1.0)  # both likelihoods exp(-d2 / 2) underflow
    np.testing.assert_array_equal(far, [[0.0, 1.0, 0.0]])


def test_pda_weights_wrap_angles():
    means = np.array([[np.pi - 0.01, 10.0]])
    covars = np.diag([0.01, 1.0])[None]
    dets = np.array([[-np.pi + 0.01, 10.0], [np.pi - 0.03, 10.0]])
    wrapped = pda_weights(means, covars, dets, 0.9, 0.99, 0.1, angles=[True, False],
                          normalise=False)
    plain = pda_weights(means, covars, dets, 0.9, 0.99, 0.1, normalise=False)
    np.testing.assert_allclose(wrapped[0, 1], wrapped[0, 2], rtol=1e-9)
    assert plain[0, 1] == 0 and plain[0, 2] == wrapped[0, 2]


@pytest.mark.parametrize("change, error, match", [
    ({"means": np.ones(3)}, ValueError, "means must be 2-D"),
    ({"means": np.full((4, 2), np.nan)}, ValueError, "means contains NaN"),
    ({"covars": np.ones((4, 2, 3))}, ValueError, r"covars must have shape \(4, 2, 2\)"),
    ({"covars": np.tile([[1.0, 2.0], [2.0, 1.0]], (4, 1, 1))}, ValueError,
     r"covars\[0\] is not positive definite"),
    ({"covars": np.tile([[1.0, 0.5], [0.0, 1.0]], (4, 1, 1))}, ValueError,
     r"covars\[0\] must be symmetric"),
    ({"detections": np.ones((6, 3))}, ValueError, r"detections must have shape \(M, 2\)"),
    ({"detections": "x"}, TypeError, "detections must be a numeric array"),
    ({"prob_detect": 1.5}, ValueError, r"prob_detect must lie in \[0, 1\]"),
    ({"prob_gate": -0.1}, ValueError, r"prob_gate must lie in \[0, 1\]"),
    ({"prob_detect": "0.9"}, TypeError, "prob_detect must be a real number"),
    ({"clutter_spatial_density": 0.0}, ValueError, "clutter_spatial_density must be finite"),
    ({"clutter_spatial_density": -1.0}, ValueError, "clutter_spatial_density"),
    ({"gate": np.ones((4, 6))}, TypeError, "gate must be a boolean array"),
    ({"gate": np.ones((4, 5), bool)}, ValueError, r"gate must have shape \(4, 6\)"),
    ({"angles": [1, 0]}, TypeError, "angles must be a boolean array"),
    ({"angles": [True]}, ValueError, r"angles must have shape \(2,\)"),
    ({"include_all": True, "clutter_spatial_density": None}, ValueError,
     "include_all=True needs a clutter_spatial_density"),
    ({"include_all": 1}, TypeError, "include_all must be a bool"),
    ({"normalise": None}, TypeError, "normalise must be a bool"),
    ({"prob_detect": 1.0, "prob_gate": 1.0, "detections": np.full((6, 2), 1e9)}, ValueError,
     "track 0 has no possible hypothesis"),
    ({"prob_gate": 1.0, "clutter_spatial_density": None, "normalise": False}, ValueError,
     "prob_gate=1 makes the gate infinite"),
    ({"clutter_spatial_density": 1e-320}, ValueError,
     "track 0's detection weights .* overflow: clutter_spatial_density=1e-320 is too small"),
])
def test_bad_pda_inputs(change, error, match):
    rng = np.random.default_rng(0)
    means, covars, dets = _pda_inputs(rng)
    args = dict(means=means, covars=covars, detections=dets, prob_detect=0.9, prob_gate=0.99,
                clutter_spatial_density=0.01)
    args.update(change)
    with pytest.raises(error, match=match):
        pda_weights(**args)


# --- parity with Stone Soup ----------------------------------------------------------------

T0 = datetime.datetime(2025, 1, 1)
DT = datetime.timedelta(seconds=1)
P0 = np.diag([1.0, 0.1, 1.0, 0.1])


def scenario(n, spacing=6.0, seed=0):
    """Targets on a jittered grid (/work/shared/stonesoup_mtt_baseline.py): 4-D initial
    states (x, vx, y, vy) and one position detection each, one second later."""
    rng = np.random.default_rng(seed)
    side = int(np.ceil(np.sqrt(n)))
    gx, gy = np.meshgrid(np.arange(side), np.arange(side))
    pos = np.c_[gx.ravel(), gy.ravel()][:n] * spacing + rng.normal(0, 1, (n, 2))
    vel = rng.normal(0, 1, (n, 2))
    return np.c_[pos[:, 0], vel[:, 0], pos[:, 1], vel[:, 1]], pos + vel + rng.normal(0, 1, (n, 2))


def stonesoup_matrix(result, tracks, detections):
    """Stone Soup's {track: MultipleHypothesis} as a (T, M + 1) matrix in our order."""
    column = {id(d): j + 1 for j, d in enumerate(detections)}
    out = np.zeros((len(tracks), len(detections) + 1))
    for i, track in enumerate(tracks):
        for hypothesis in result[track]:
            j = column[id(hypothesis.measurement)] if hypothesis else 0
            out[i, j] = float(hypothesis.probability)
    return out


@pytest.fixture(scope="module")
def linear_case():
    """10 close targets (6 m grid) and 10 clutter points, Kalman predictor and updater."""
    pytest.importorskip("stonesoup")
    from stonesoup.models.measurement.linear import LinearGaussian
    from stonesoup.models.transition.linear import (CombinedLinearGaussianTransitionModel,
                                                    ConstantVelocity)
    from stonesoup.types.detection import Clutter, Detection
    from stonesoup.types.state import GaussianState
    from stonesoup.types.track import Track
    transition = CombinedLinearGaussianTransitionModel([ConstantVelocity(0.05)] * 2)
    sensor = LinearGaussian(ndim_state=4, mapping=(0, 2), noise_covar=np.eye(2))
    n = 10
    x0, z = scenario(n, seed=2)
    lo, hi = z.min(0) - 10, z.max(0) + 10
    clutter = np.random.default_rng(3).uniform(lo, hi, (n, 2))
    points = np.vstack([z, clutter])
    tracks = [Track([GaussianState(x.reshape(4, 1), P0, timestamp=T0)]) for x in x0]
    detections = ([Detection(p.reshape(2, 1), timestamp=T0 + DT, measurement_model=sensor)
                   for p in z]
                  + [Clutter(p.reshape(2, 1), timestamp=T0 + DT, measurement_model=sensor)
                     for p in clutter])
    f, q = transition.matrix(time_interval=DT), transition.covar(time_interval=DT)
    h, r = sensor.matrix(), sensor.covar()
    means = x0 @ f.T @ h.T
    covars = np.broadcast_to(h @ (f @ P0 @ f.T + q) @ h.T + r, (n, 2, 2))
    return dict(transition=transition, sensor=sensor, tracks=tracks, detections=detections,
                means=means, covars=covars, points=points, density=n / float(np.prod(hi - lo)))


def _stonesoup_hypothesiser(case, **kwargs):
    from stonesoup.hypothesiser.probability import PDAHypothesiser
    from stonesoup.predictor.kalman import KalmanPredictor
    from stonesoup.updater.kalman import KalmanUpdater
    return PDAHypothesiser(KalmanPredictor(case["transition"]), KalmanUpdater(case["sensor"]),
                           prob_detect=0.9, prob_gate=0.99, **kwargs)


@pytest.mark.parametrize("density", ["given", None])
def test_weights_and_marginals_match_stonesoup_jpda(linear_case, density):
    from stonesoup.dataassociator.probability import JPDA, JPDAwithEHM
    case = linear_case
    lam = case["density"] if density else None
    hypothesiser = _stonesoup_hypothesiser(case, clutter_spatial_density=lam)
    tracks, detections = case["tracks"], case["detections"]
    w = pda_weights(case["means"], case["covars"], case["points"], 0.9, 0.99, lam)
    ss_weights = stonesoup_matrix(
        {t: hypothesiser.hypothesise(t, set(detections), T0 + DT) for t in tracks},
        tracks, detections)
    np.testing.assert_allclose(w, ss_weights, rtol=1e-12, atol=1e-300)
    assert 1 < len(components(w)) < len(tracks)  # several clusters, some shared detections
    assert (w[:, 1:] > 0).sum() > len(tracks)
    mine = jpda_marginals(w)
    np.testing.assert_allclose(clustered_marginals(w), mine, rtol=0, atol=1e-13)
    ehm = stonesoup_matrix(JPDAwithEHM(hypothesiser).associate(
        set(tracks), set(detections), T0 + DT), tracks, detections)
    np.testing.assert_allclose(mine, ehm, rtol=0, atol=1e-9)
    if density:  # enumeration over all tracks at once: 31,104 joint events
        full = stonesoup_matrix(JPDA(hypothesiser).associate(
            set(tracks), set(detections), T0 + DT), tracks, detections)
        np.testing.assert_allclose(mine, full, rtol=0, atol=1e-9)
        assert np.abs(mine - w).max() > 1e-3  # the joint constraint changes the weights


def test_bearing_range_weights_and_marginals_match_stonesoup():
    """Targets around the bearing discontinuity (-x axis) seen by a bearing-range sensor
    with an extended Kalman updater: the innovations' bearings wrap."""
    pytest.importorskip("stonesoup")
    from stonesoup.dataassociator.probability import JPDAwithEHM
    from stonesoup.hypothesiser.probability import PDAHypothesiser
    from stonesoup.models.measurement.nonlinear import CartesianToBearingRange
    from stonesoup.models.transition.linear import (CombinedLinearGaussianTransitionModel,
                                                    ConstantVelocity)
    from stonesoup.predictor.kalman import ExtendedKalmanPredictor
    from stonesoup.types.detection import Detection
    from stonesoup.types.state import GaussianState
    from stonesoup.types.track import Track
    from stonesoup.updater.kalman import ExtendedKalmanUpdater
    transition = CombinedLinearGaussianTransitionModel([ConstantVelocity(0.05)] * 2)
    sensor = CartesianToBearingRange(4, (0, 2), np.diag([np.radians(1.0) ** 2, 1.0]))
    rng = np.random.default_rng(6)
    n = 6
    y = np.linspace(-1.5, 1.5, n) + rng.normal(0, 0.1, n)
    x0 = np.c_[np.full(n, -100.0), np.zeros(n), y, np.zeros(n)]
    truth = x0 + rng.normal(0, 0.3, x0.shape)
    points = np.c_[np.arctan2(truth[:, 2], truth[:, 0]), np.hypot(truth[:, 0], truth[:, 2])]
    points[:, 1] += rng.normal(0, 1, n)
    points = np.vstack([points, [[np.pi - 0.004, 100.5], [-np.pi + 0.003, 99.0]]])
    points[:, 0] = np.mod(points[:, 0] + np.pi, 2 * np.pi) - np.pi
    tracks = [Track([GaussianState(x.reshape(4, 1), P0, timestamp=T0)]) for x in x0]
    detections = [Detection(p.reshape(2, 1), timestamp=T0 + DT, measurement_model=sensor)
                  for p in points]
    predictor, updater = ExtendedKalmanPredictor(transition), ExtendedKalmanUpdater(sensor)
    means, covars = [], []
    for track in tracks:
        prediction = updater.predict_measurement(predictor.predict(track, timestamp=T0 + DT))
        means.append(np.asarray(prediction.state_vector, dtype=float).ravel())
        covars.append(np.asarray(prediction.covar, dtype=float))
    hypothesiser = PDAHypothesiser(predictor, updater, clutter_spatial_density=0.05,
                                   prob_detect=0.9, prob_gate=0.99)
    w = pda_weights(np.array(means), np.array(covars), points, 0.9, 0.99, 0.05,
                    angles=[True, False])
    ss_weights = stonesoup_matrix(
        {t: hypothesiser.hypothesise(t, set(detections), T0 + DT) for t in tracks},
        tracks, detections)
    np.testing.assert_allclose(w, ss_weights, rtol=1e-9, atol=1e-300)
    crossing = np.sign(np.array(means)[:, 0])[:, None] != np.sign(points[:, 0])[None, :]
    assert (w[:, 1:][crossing] > 0).any()  # some gated pairs straddle +-pi
    ehm = stonesoup_matrix(JPDAwithEHM(hypothesiser).associate(
        set(tracks), set(detections), T0 + DT), tracks, detections)
    np.testing.assert_allclose(jpda_marginals(w), ehm, rtol=0, atol=1e-9)
