"""The GM-CPHD filter on arrays: the ESFs and their leave-one-out forms against direct
evaluation (over values spread across hundreds of orders of magnitude), the update and the
cardinality prediction against a term-by-term mirror, the closed forms (Poisson CPHD = PHD,
the Kalman filter), and bad input."""
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.stats import multivariate_normal, poisson

import fasttrack as ft
from fasttrack._jit import cphd as kernels
from fasttrack.core import cphd, cphd_numpy, phd
from reference import cphd as mirror

SENSOR = ft.LinearGaussian(4, (0, 2), np.diag([0.75, 0.75]))


def _mixture(seed, j):
    rng = np.random.default_rng(seed)
    means = rng.normal(size=(j, 4)) * [20.0, 1.0, 20.0, 1.0]
    a = rng.standard_normal((j, 4, 4)) * 0.5
    covars = a @ a.transpose(0, 2, 1) + np.eye(4)
    return means, covars, np.log(rng.uniform(0.05, 1.0, j))


def _log_esf_direct(log_values):
    """log e_j by summing every j-subset's product, in logs (exponential: small m only)."""
    from itertools import combinations
    from scipy.special import logsumexp
    m = len(log_values)
    return np.array([logsumexp([sum(c) for c in combinations(log_values, j)]) if j else 0.0
                     for j in range(m + 1)])


def _kernel_esf(log_values):
    out = np.empty(log_values.size + 1)
    kernels.log_esf(log_values, out)
    return out


def _kernel_esf_without(log_values, log_e):
    out = np.empty((log_values.size, log_values.size))
    kernels.log_esf_without(log_values, log_e, out)
    return out


ESFS = {"kernels": (_kernel_esf, _kernel_esf_without),
        "numpy": (cphd_numpy.log_esf, cphd_numpy.log_esf_without)}


@pytest.mark.parametrize("path", ESFS)
@settings(max_examples=60, deadline=None)
@given(log_values=st.lists(st.one_of(st.floats(-300.0, 300.0), st.just(-np.inf)), min_size=0,
                           max_size=7))
def test_esfs_and_their_leave_one_out_forms_equal_direct_sums(path, log_values):
    log_esf, log_esf_without = ESFS[path]
    log_values = np.array(log_values, dtype=float)
    log_e = log_esf(log_values)
    with np.errstate(divide="ignore"):
        want = _log_esf_direct(list(log_values))
    np.testing.assert_allclose(log_e, want, rtol=1e-12, atol=1e-9)
    without = log_esf_without(log_values, log_e)
    for z in range(log_values.size):
        rest = np.delete(log_values, z)
        with np.errstate(divide="ignore"):
            want = _log_esf_direct(list(rest))
        # e_j relative error 1e-9 (the logs' absolute error), -inf where e_j = 0
        np.testing.assert_array_equal(without[z] == -np.inf, want == -np.inf)
        finite = want > -np.inf
        np.testing.assert_allclose(without[z][finite], want[finite], rtol=0, atol=1e-9)


@pytest.mark.parametrize("path", ESFS)
def test_leave_one_out_esfs_of_many_spread_values_stay_accurate(path):
    log_esf, log_esf_without = ESFS[path]
    rng = np.random.default_rng(3)
    log_values = rng.uniform(-40.0, 40.0, 60)
    log_e = log_esf(log_values)
    without = log_esf_without(log_values, log_e)
    for z in (0, 17, 59):
        np.testing.assert_allclose(without[z], log_esf(np.delete(log_values, z))[:60],
                                   rtol=0, atol=1e-9)


@pytest.mark.parametrize("seed", range(3))
@pytest.mark.parametrize("p_d", [0.9, 1.0])
def test_the_kernels_and_their_numpy_twins_agree(seed, p_d):
    rng = np.random.default_rng(seed)
    m, size = 12, 20
    log_values = np.where(rng.uniform(size=m) < 0.2, -np.inf, rng.uniform(-30.0, 30.0, m))
    log_e = _kernel_esf(log_values)
    without = _kernel_esf_without(log_values, log_e)
    card = np.log(rng.dirichlet(np.ones(size)))
    card[3] = -np.inf
    with np.errstate(divide="ignore"):
        arguments = (log_e, without, card, np.log1p(-p_d), np.log(7.5), np.log(4.0))
    posterior, out_without = np.empty(size), np.empty(m)
    missed = kernels.update_sums(*arguments, posterior, out_without)
    want = cphd_numpy.update_sums(*arguments)
    np.testing.assert_allclose(posterior, want[0], rtol=1e-11, atol=1e-11)
    assert missed == pytest.approx(want[1], rel=1e-11, abs=1e-11)
    np.testing.assert_allclose(out_without, want[2], rtol=1e-11, atol=1e-11)
    mirrored = np.empty(size), np.empty(m)  # the mirrors, term by term in the linear domain
    assert mirror.update_sums(*arguments, *mirrored) == pytest.approx(missed, abs=1e-9)
    np.testing.assert_allclose(mirrored[0], posterior, rtol=0, atol=1e-9)
    np.testing.assert_allclose(mirrored[1], out_without, rtol=0, atol=1e-9)
    esfs = np.empty(m + 1), np.empty((m, m))
    mirror.log_esf(log_values, esfs[0])
    mirror.log_esf_without(log_values, log_e, esfs[1])
    np.testing.assert_allclose(esfs[0], log_e, rtol=0, atol=1e-9)
    np.testing.assert_allclose(esfs[1], without, rtol=0, atol=1e-9)
    for p_s, birth in ((0.95, 2.0), (0.0, 0.5), (1.0, 0.0)):
        with np.errstate(divide="ignore"):
            logs = (card, np.log(p_s), np.log1p(-p_s), birth)
        out, mirrored = np.empty(size), np.empty(size)
        kernels.predict_cardinality(*logs, out)
        np.testing.assert_allclose(out, cphd_numpy.predict_cardinality(*logs), rtol=1e-11,
                                   atol=1e-11)
        mirror.predict_cardinality(*logs, mirrored)
        np.testing.assert_allclose(out, mirrored, rtol=0, atol=1e-9)


def _likelihoods(means, covars, detections):
    h = np.zeros((2, 4))
    h[0, 0] = h[1, 2] = 1.0
    return np.array([[multivariate_normal.pdf(z, h @ m, h @ p @ h.T + SENSOR.noise_covar)
                      for z in detections] for m, p in zip(means, covars)])


@pytest.mark.parametrize("seed", range(4))
def test_the_update_is_the_formula(seed):
    means, covars, log_weights = _mixture(seed, 5)
    rng = np.random.default_rng(seed + 10)
    detections = means[rng.choice(5, 3), ::2] + rng.normal(size=(3, 2))
    detections = np.vstack([detections, rng.normal(size=(2, 2)) * 20.0])
    card = rng.uniform(0.1, 1.0, 13)
    card /= card.sum()
    p_d, rate, kappa = 0.8, 3.0, 3.0 / 4000.0
    got = cphd.update(SENSOR, means, covars, log_weights, np.log(card), detections, p_d, rate,
                      kappa)
    missed, detected, cardinality = mirror.weights(
        np.exp(log_weights), _likelihoods(means, covars, detections), card, p_d, rate, kappa)
    weights = np.exp(got[2])
    np.testing.assert_allclose(weights[:5], missed, rtol=1e-9)
    np.testing.assert_allclose(weights[5:], detected[got[3][5:], got[4][5:]], rtol=1e-9)
    np.testing.assert_allclose(np.exp(got[5]), cardinality, rtol=1e-9, atol=1e-300)
    same = phd.update(SENSOR, means, covars, log_weights, detections, p_d, kappa)
    for a, b in zip(got[:5], same):  # the components are the PHD update's
        np.testing.assert_array_equal(a if a.ndim > 1 or a.dtype.kind == "i" else 0,
                                      b if b.ndim > 1 or b.dtype.kind == "i" else 0)


@pytest.mark.parametrize("gate", [None, 16.0])
def test_a_poisson_cardinality_gives_the_phd_weights(gate):
    means, covars, log_weights = _mixture(1, 6)
    detections = np.vstack([means[:4, ::2] + 0.5, [[300.0, -300.0]]])
    total = np.exp(log_weights).sum()
    card = poisson.logpmf(np.arange(80), total)
    card -= np.logaddexp.reduce(card)
    got = cphd.update(SENSOR, means, covars, log_weights, card, detections, 0.9, 5.0, 5e-4,
                      gate)
    want = phd.update(SENSOR, means, covars, log_weights, detections, 0.9, 5e-4, gate)
    np.testing.assert_allclose(got[2], want[2], rtol=0, atol=1e-9)


def test_one_target_always_detected_without_clutter_is_the_kalman_filter():
    prior = ft.GaussianState([[1.0], [0.5], [-2.0], [0.1]], np.diag([4.0, 1.0, 4.0, 1.0]))
    z = ft.Detection([[1.5], [-1.0]], measurement_model=SENSOR)
    kalman = ft.KalmanUpdater(SENSOR).update(ft.SingleHypothesis(prior, z))
    card = np.log([1e-12, 1.0 - 2e-12, 1e-12])
    means, covars, log_weights, _, _, posterior = cphd.update(
        SENSOR, prior.state_vector.T, prior.covar[None], [0.0], card, z.state_vector.T, 1.0,
        1e-12, 1e-300)
    assert np.exp(log_weights).tolist() == [0.0, pytest.approx(1.0, rel=1e-9)]
    np.testing.assert_allclose(means[1], kalman.state_vector.ravel(), rtol=1e-12)
    np.testing.assert_allclose(np.exp(posterior), [0.0, 1.0, 0.0], atol=1e-9)


def test_an_empty_scan_and_an_empty_intensity():
    means, covars, log_weights = _mixture(0, 3)
    card = np.log(np.full(6, 1 / 6))
    out = cphd.update(SENSOR, means, covars, log_weights, card, np.empty((0, 2)), 0.7, 2.0,
                      1e-3)
    missed, _, want = mirror.weights(np.exp(log_weights), np.empty((3, 0)), np.exp(card), 0.7,
                                    2.0, 1e-3)
    np.testing.assert_allclose(np.exp(out[2]), missed, rtol=1e-10)
    np.testing.assert_allclose(np.exp(out[5]), want, rtol=1e-10)
    none = cphd.update(SENSOR, np.empty((0, 4)), np.empty((0, 4, 4)), np.empty(0),
                       [0.0, -np.inf], [[0.0, 1.0], [5.0, 5.0]], 0.9, 2.0, 1e-3)
    assert none[2].size == 0 and np.exp(none[5]).tolist() == [1.0, 0.0]


@pytest.mark.parametrize("rate", [4.0, 1e7, 1e20, 1e200])
def test_a_large_clutter_rate_keeps_the_update_consistent(rate):
    """exp(-rate) is a factor of every term: left out, it cannot swamp them (at 1e7 the
    cardinality summed to 1 + 8e-10 before, at 1e20 to 11). The updated intensity's mass
    is the posterior cardinality's mean (a CPHD identity)."""
    means, covars, log_weights = _mixture(1, 5)
    detections = np.vstack([means[:3, ::2] + 0.2, [[500.0, 500.0]]])
    out = cphd.update(SENSOR, means, covars, log_weights, np.full(11, -np.log(11)),
                      detections, 0.9, rate, rate * 1e-6)
    card = np.exp(out[5])
    assert card.sum() == pytest.approx(1.0, rel=1e-12)
    assert np.exp(out[2]).sum() == pytest.approx(np.arange(11) @ card, rel=1e-11)


def test_an_update_without_a_defined_answer_is_refused():
    means, covars, log_weights = _mixture(0, 3)
    with pytest.raises(ValueError, match="log_weights are all -inf"):
        cphd.update(SENSOR, means, covars, np.full(3, -np.inf), np.full(4, -np.log(4)),
                    [[0.0, 1.0]], 0.9, 2.0, 1e-3)
    with pytest.raises(ValueError, match="the detections have probability 0"):
        cphd.update(SENSOR, means, covars, log_weights, [-np.inf, 0.0], np.empty((0, 2)),
                    1.0, 2.0, 1e-3)  # a target certainly there and certainly detected


def test_many_detections_do_not_overflow():
    means, covars, log_weights = _mixture(2, 40)
    clutter = np.random.default_rng(0).uniform(1000.0, 2000.0, size=(160, 2))  # far away
    detections = np.vstack([means[:, ::2] + 0.1, clutter])
    card = np.full(101, -np.log(101))
    out = cphd.update(SENSOR, means, covars, log_weights, card, detections, 0.95, 160.0,
                      160.0 / 1000.0 ** 2)
    assert np.isfinite(out[2]).all() and np.isfinite(out[5]).any()
    assert np.exp(out[5]).sum() == pytest.approx(1.0, rel=1e-12)
    assert 40 <= np.argmax(out[5]) <= 43  # all 40 seen, at P_D 0.95


def test_five_hundred_detections_a_scan():
    means, covars, log_weights = _mixture(5, 100)
    rng = np.random.default_rng(1)
    detections = np.vstack([means[:, ::2] + rng.normal(size=(100, 2)),
                            rng.uniform(-100.0, 100.0, size=(400, 2))])
    card = np.full(201, -np.log(201))
    out = cphd.update(SENSOR, means, covars, log_weights, card, detections, 0.95, 400.0,
                      400.0 / 200.0 ** 2, 25.0)
    assert np.isfinite(out[2]).all() and np.exp(out[5]).sum() == pytest.approx(1.0)
    assert 60 <= np.argmax(out[5]) <= 140


@pytest.mark.parametrize("p_s,birth", [(0.99, 0.3), (0.5, 2.0), (1.0, 0.0), (0.0, 1.0)])
def test_the_cardinality_prediction_is_the_formula(p_s, birth):
    card = np.random.default_rng(4).uniform(size=15)
    card /= card.sum()
    with np.errstate(divide="ignore"):
        got = cphd.predict_cardinality(np.log(card), p_s, birth)
    want = np.empty(card.size)
    with np.errstate(divide="ignore"):
        mirror.predict_cardinality(np.log(card), np.log(p_s), np.log1p(-p_s), birth, want)
    np.testing.assert_allclose(np.exp(got), np.exp(want), rtol=1e-10, atol=1e-300)


@pytest.mark.parametrize("change,message", [
    (dict(log_cardinality=[0.0, 0.0]), "log_cardinality must sum to 1"),
    (dict(log_cardinality=[np.nan]), "log_cardinality must be N \\+ 1 >= 1"),
    (dict(log_cardinality=[]), "log_cardinality must be N \\+ 1 >= 1"),
    (dict(clutter_rate=0.0), "clutter_rate must be finite and > 0"),
    (dict(clutter_intensity=np.inf), "clutter_intensity must be finite"),
    (dict(prob_detect=1.5), "prob_detect"),
    (dict(detections=[[0.0, 1.0, 2.0]]), "detections must have shape"),
])
def test_bad_updates_are_refused_naming_the_argument(change, message):
    arguments = dict(model=SENSOR, means=np.zeros((2, 4)), covars=[np.eye(4)] * 2,
                     log_weights=[0.0, 0.0], log_cardinality=np.log([0.2, 0.3, 0.5]),
                     detections=[[0.0, 1.0]], prob_detect=0.9, clutter_rate=2.0,
                     clutter_intensity=1e-4)
    arguments.update(change)
    with pytest.raises(ValueError, match=message):
        cphd.update(**arguments)


def test_more_detections_than_targets_are_clutter_in_logs():
    card = cphd.update(SENSOR, np.zeros((1, 4)), [np.eye(4)], [0.0], [0.0], [[0.0, 1.0]] * 3,
                       1.0, 1e-300, 1e-300)[5]
    assert card.tolist() == [0.0]  # no target: three clutter detections of rate 1e-300


def test_births_alone_are_poisson():
    with np.errstate(divide="ignore"):
        log_card = np.log([1.0, 0.0, 0.0, 0.0, 0.0])
    predicted = np.exp(cphd.predict_cardinality(log_card, 1.0, 1.3))
    assert math.isclose(predicted[2], poisson.pmf(2, 1.3) / poisson.cdf(4, 1.3),
                        rel_tol=1e-12)


def _trackers(scenario, **settings):
    from fasttrack.scenarios import vo_linear_birth
    common = dict(transition_model=scenario.transition_model,
                  measurement_model=scenario.measurement_model, birth=vo_linear_birth(),
                  prob_detect=0.98, prob_survival=0.99,
                  clutter_intensity=scenario.clutter_density, gate_threshold=13.8)
    return (ft.PHDTracker(**common),
            ft.CPHDTracker(**common, clutter_rate=30.0, **dict(dict(max_targets=30), **settings)))


def test_the_cphd_tracker_counts_the_targets_better_than_the_phd_tracker():
    from fasttrack.scenarios import vo_linear
    scenario = vo_linear(clutter_rate=30.0, seed=3)
    phd_tracker, cphd_tracker = _trackers(scenario)
    truth = np.array([len(t) for t in scenario.truths])
    phd_counts = [len(e) for e in phd_tracker.run(scenario.detections)]
    cphd_counts, expected = [], []
    for t, scan in enumerate(scenario.detections):
        found = cphd_tracker.step(scan, float(t))
        assert len(set(found.labels.tolist())) == len(found)  # distinct labels
        cphd_counts.append(len(found))
        assert len(found) == min(cphd_tracker.most_probable_number, len(cphd_tracker.mixture))
        assert np.exp(cphd_tracker.log_cardinality).sum() == pytest.approx(1.0, rel=1e-12)
        expected.append(cphd_tracker.expected_number)
    # a miss takes a PHD target below 0.5 for a scan; the CPHD's cardinality holds it:
    # measured 0.44-0.51 against 0.31-0.39 a scan over seeds 0-2
    cphd_error = np.abs(np.array(cphd_counts) - truth).mean()
    assert cphd_error < 0.45 and cphd_error < np.abs(np.array(phd_counts) - truth).mean()
    assert np.abs(np.array(expected) - truth).mean() < 0.5


def test_the_cphd_tracker_refuses_bad_settings():
    from fasttrack.scenarios import vo_linear
    scenario = vo_linear(clutter_rate=30.0, seed=0)
    with pytest.raises(ValueError, match="max_targets must be >= 1"):
        _trackers(scenario, max_targets=0)
    with pytest.raises(TypeError, match="max_targets must be an int"):
        _trackers(scenario, max_targets=2.5)
    phd_tracker, _ = _trackers(scenario)
    with pytest.raises(ValueError, match="clutter_rate must be finite and > 0"):
        ft.CPHDTracker(phd_tracker.transition_model, phd_tracker.measurement_model,
                       phd_tracker.birth, 0.9, 0.99, 1e-5, clutter_rate=-1.0)


def _vo_scenario(seed):
    from fasttrack.scenarios import vo_linear
    return vo_linear(clutter_rate=10.0, seed=seed)


def _make_cphd(scenario, rng):
    from fasttrack.scenarios import vo_linear_birth
    return ft.CPHDTracker(scenario.transition_model, scenario.measurement_model,
                          vo_linear_birth(), 0.98, 0.99, scenario.clutter_density, 10.0,
                          max_targets=30, gate_threshold=13.8)


def test_monte_carlo_runs_score_the_cphd_tracker_scan_by_scan():
    from fasttrack import montecarlo as mc
    results = mc.run_trials(_vo_scenario, _make_cphd, 3, seed=1, processes=1, progress=False,
                            gospa_cutoff=100.0)  # Vo's c: the detections' noise is 10 m
    assert not results.failures and len(results.table) == 3 * 100
    world = _vo_scenario(mc.run_seeds(1, 3)[1].spawn(2)[0])
    estimates = _make_cphd(world, None).run(world.detections)
    row = results.table[results.table["run"] == 1]
    assert row["n_tracks"].tolist() == [len(e) for e in estimates]
    assert row["cardinality_error"].tolist() == [abs(len(e) - len(x))
                                                 for e, x in zip(estimates, world.truths)]
    per_run = results.per_run()  # measured 0.22-0.55 against 7.7 for no estimates
    assert (per_run["mean_cardinality_error"] < 1.0).all()
    no_estimates = np.mean([50.0 * len(x) for x in world.truths])  # c / 2 a missed target
    assert (per_run["mean_gospa"] < 0.4 * no_estimates).all()  # measured 0.25


@pytest.mark.parametrize("unscented", [None, (0.5, 2.0, None)])
def test_the_trackers_count_and_find_the_targets_through_a_radar(unscented):
    from fasttrack.scenarios import vo_linear, vo_linear_birth
    scenario = vo_linear(clutter_rate=10.0, seed=2)
    radar = ft.CartesianToBearingRange(4, (0, 2), np.diag([0.003 ** 2, 5.0 ** 2]),
                                       translation_offset=[0.0, -1500.0])
    rng = np.random.default_rng(5)
    lo, hi = np.array([0.2, 300.0]), np.array([np.pi - 0.2, 2800.0])  # bearing, range
    scans = []
    for truths in scenario.truths:
        seen = truths[rng.uniform(size=len(truths)) < 0.98]
        z = np.array([radar.function(ft.GaussianState(x[:, None], np.eye(4))).ravel()
                      for x in seen]).reshape(-1, 2)
        scans.append(np.vstack([z + rng.normal(size=z.shape) * [0.003, 5.0],
                                rng.uniform(lo, hi, size=(rng.poisson(10), 2))]))
    kappa = 10.0 / np.prod(hi - lo)
    for tracker in (ft.PHDTracker(scenario.transition_model, radar, vo_linear_birth(), 0.98,
                                  0.99, kappa, gate_threshold=13.8, unscented=unscented),
                    ft.CPHDTracker(scenario.transition_model, radar, vo_linear_birth(), 0.98,
                                   0.99, kappa, 10.0, max_targets=30, gate_threshold=13.8,
                                   unscented=unscented)):
        estimates = tracker.run(scans)
        # measured 0.22 (PHD) and 0.14 (CPHD) a scan, against 7.7 for no estimates
        assert np.mean([abs(len(e) - len(x)) for e, x in zip(estimates, scenario.truths)]) < 0.4
        distances = [ft.metrics.gospa(x[:, [0, 2]], e.means[:, [0, 2]], c=100.0).distance
                     for e, x in zip(estimates, scenario.truths)]
        assert np.mean(distances) < 60.0  # measured 44-47 m; 380 m for no estimates


_FIRST_SCANS = """
import json, sys
import numpy as np
import fasttrack as ft
from fasttrack import _jit
from fasttrack.scenarios import vo_linear, vo_linear_birth
if sys.argv[1] == "kernels":
    _jit.kernels_from_now()
scenario = vo_linear(clutter_rate=30.0, seed=4)
tracker = ft.CPHDTracker(scenario.transition_model, scenario.measurement_model,
                         vo_linear_birth(), 0.98, 0.99, scenario.clutter_density, 30.0,
                         max_targets=30, gate_threshold=13.8)
before = "numba" in sys.modules
first = tracker.step(scenario.detections[0], 0.0)
cardinality = tracker.log_cardinality.tolist()
rest = tracker.run(scenario.detections[1:12])
print(json.dumps({"numba_before_update": before, "first": first.means.ravel().tolist(),
                  "cardinality": cardinality,
                  "last": [e.means.ravel().tolist() for e in rest[-3:]]}))
"""


def test_a_first_update_in_numpy_equals_the_kernels():
    import json
    import subprocess
    import sys
    runs = {}
    for path in ("numpy", "kernels"):
        done = subprocess.run([sys.executable, "-c", _FIRST_SCANS, path], capture_output=True,
                              text=True, timeout=600, check=True)
        runs[path] = json.loads(done.stdout.splitlines()[-1])
    assert not runs["numpy"]["numba_before_update"]
    np.testing.assert_allclose(runs["numpy"]["cardinality"], runs["kernels"]["cardinality"],
                               rtol=1e-10, atol=1e-10)
    np.testing.assert_allclose(runs["numpy"]["first"], runs["kernels"]["first"], rtol=1e-10)
    for a, b in zip(runs["numpy"]["last"], runs["kernels"]["last"]):
        np.testing.assert_allclose(a, b, rtol=1e-9, atol=1e-9)


def test_a_large_cardinality_prediction_takes_the_kernel(monkeypatch):
    """The NumPy twin builds (N + 1)^2 tables: at N = 10,000 a process's first prediction
    took 3.8 GiB and 12 s (50,000 was killed for memory); such sizes take the kernel."""
    from fasttrack import _jit
    monkeypatch.setattr(_jit, "kernels_loaded", lambda: False)  # a new process
    monkeypatch.setattr(_jit, "_numpy_work", _jit.NUMPY_WORK)
    twin = []
    monkeypatch.setattr(cphd_numpy, "predict_cardinality", lambda *args: twin.append(args))
    c = np.full(10_001, -np.inf)
    c[0] = 0.0
    predicted = cphd.predict_cardinality(c, 0.99, 0.1)
    assert not twin and np.exp(predicted[:3]) == pytest.approx(poisson.pmf([0, 1, 2], 0.1))
    cphd.predict_cardinality(c[:31], 0.99, 0.1)  # N_max 30: NumPy
    assert len(twin) == 1
