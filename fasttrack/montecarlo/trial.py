"""One run: its seeds, its scenario and filter, and its scored steps; and a batch of runs,
the task of a worker."""
import hashlib
import inspect
import numbers
import pickle
import time
import traceback

import numpy as np

from .. import _jit
from .._validate import count, positive
from ..metrics import POWER_RANGE
from ..types import SingleHypothesis, time_interval
from ..simulate import MultiTargetScenario
from .metrics import (_check_mapping, _check_mapping_fits, _check_metrics, _row_dtype, _score,
                      _score_scans)
from .results import RunFailure


def run_seeds(seed, n_runs):
    """The per-run seeds of ``run_trials(..., n_runs, seed=seed)``:
    ``numpy.random.SeedSequence(seed).spawn(n_runs)``.

    Parameters
    ----------
    seed : None, int or numpy.random.SeedSequence
        Root seed, as for :func:`run_trials` (None: fresh entropy, so new seeds each call).
    n_runs : int
        Number of runs, >= 1.

    Returns
    -------
    list of numpy.random.SeedSequence
        One per run, in run order.
    """
    return _children(_root_seed(seed), count(n_runs, "n_runs"))


def _root_seed(seed):
    if seed is None or isinstance(seed, np.random.SeedSequence):
        return np.random.SeedSequence(seed) if seed is None else seed
    if not isinstance(seed, numbers.Integral) or isinstance(seed, bool):
        raise TypeError(f"seed must be None, an int or a numpy.random.SeedSequence, "
                        f"got {type(seed).__name__}")
    if seed < 0:
        raise ValueError(f"seed must be >= 0, got {seed}")
    return np.random.SeedSequence(int(seed))


def _check_run(scenario, make_filter, gospa_cutoff):
    """The GOSPA cut-off (in [1e-300, 1e300], the range of GOSPA's c ** p at p = 1), after a
    TypeError for a ``scenario`` or ``make_filter`` that is not callable, or a ``scenario``
    that takes no ``seed`` keyword."""
    for name, value in (("scenario", scenario), ("make_filter", make_filter)):
        if not callable(value):
            raise TypeError(f"{name} must be callable, got {type(value).__name__}")
    try:
        inspect.signature(scenario).bind(seed=None)
    except TypeError:
        raise TypeError(f"scenario must take a seed keyword (each run calls "
                        f"scenario(seed=seed_sequence)), got {scenario!r}") from None
    except ValueError:  # (no signature to read: the call will tell)
        pass
    cutoff = positive(gospa_cutoff, "gospa_cutoff")
    low, high = POWER_RANGE
    if not low <= cutoff <= high:
        raise ValueError(f"gospa_cutoff must lie in [{low:g}, {high:g}] (GOSPA sums distances "
                         f"cut off at it), got {cutoff:g}")
    return cutoff


def _world(scenario, seed):
    """``scenario(seed=seed)``, checked to be a :class:`~fasttrack.scenarios.Scenario` (or an
    object with its ``truth``, ``detections`` and ``prior``) or a
    :class:`~fasttrack.simulate.MultiTargetScenario`."""
    world = scenario(seed=seed)
    if not (isinstance(world, MultiTargetScenario)
            or all(hasattr(world, name) for name in ("truth", "detections", "prior"))):
        raise TypeError(f"scenario(seed=...) must return a Scenario (truth, detections, "
                        f"prior) or a MultiTargetScenario, got {type(world).__name__}")
    return world


def _children(seed, n):
    """What ``seed.spawn(n)`` gives on a fresh ``seed``, whatever it has spawned already."""
    return [np.random.SeedSequence(seed.entropy, spawn_key=seed.spawn_key + (k,),
                                   pool_size=seed.pool_size) for k in range(n)]


def run_trial(scenario, make_filter, run_seed, metrics=None, position_mapping=(0, 2),
              gospa_cutoff=10.0):
    """Track one run and score every step: what :func:`run_trials` does for each run.

    Parameters
    ----------
    scenario : callable
        ``scenario(seed=seed_sequence)`` returns the run's scenario, as for
        :func:`run_trials`.
    make_filter : callable
        ``make_filter(scenario, rng)`` returns ``(predictor, updater)``, as for
        :func:`run_trials`.
    run_seed : numpy.random.SeedSequence
        The run's seed, e.g. ``run_seeds(seed, n_runs)[i]`` or a failure's ``seed``.
    metrics : sequence of str, optional
        As for :func:`run_trials`.
    position_mapping : sequence of int
        State components of the position, as for :func:`run_trials`.
    gospa_cutoff : float
        As for :func:`run_trials`.

    Returns
    -------
    numpy.ndarray
        The run's rows of the table of :class:`TrialResults` (``run`` = -1).

    Raises
    ------
    Exception
        Whatever the scenario, the filter or the scoring raises.
    """
    gospa_cutoff = _check_run(scenario, make_filter, gospa_cutoff)
    mapping = _check_mapping(position_mapping)
    if not isinstance(run_seed, np.random.SeedSequence):
        raise TypeError(f"run_seed must be a numpy.random.SeedSequence (see run_seeds), "
                        f"got {type(run_seed).__name__}")
    _jit.kernels_from_now()  # a run's results are the same bits in every process
    scenario_seed, filter_seed = _children(run_seed, 2)
    world = _world(scenario, scenario_seed)
    multi_target = isinstance(world, MultiTargetScenario)
    metrics = _check_metrics(metrics, multi_target)
    _check_mapping_fits(world, mapping)
    if multi_target:
        tracker = make_filter(world, np.random.default_rng(filter_seed))
        return _track_scans(world, tracker, metrics, mapping, gospa_cutoff)
    predictor, updater = make_filter(world, np.random.default_rng(filter_seed))
    truth = {state.timestamp: state for state in world.truth}
    rows = np.zeros(len(world.detections), _row_dtype(metrics))
    rows["run"] = -1
    state, start = world.prior, None
    for step, detection in enumerate(world.detections):
        if detection.timestamp not in truth:
            raise ValueError(f"the scenario has no true state at detection {step}'s time "
                             f"{detection.timestamp}")
        start = detection.timestamp if start is None else start
        tic = time.perf_counter()
        hypothesis = SingleHypothesis(predictor.predict(state, timestamp=detection.timestamp),
                                      detection)
        state = updater.update(hypothesis)
        effective = getattr(state, "ess", None)  # a particle filter's, before resampling
        effective = np.nan if effective is None else effective
        seconds = time.perf_counter() - tic
        elapsed = time_interval(detection.timestamp, start, "detection.timestamp")
        model = detection.measurement_model or getattr(updater, "measurement_model", None)
        rows[step] = (-1, step, elapsed,
                      *_score(metrics, state, truth[detection.timestamp], hypothesis, model,
                              mapping, effective, seconds))
    return rows


def _track_scans(world, tracker, metrics, mapping, cutoff):
    """Run a multi-target ``tracker`` (``step(detections, time)`` returning the tracks, with
    ``means`` (K, d)) over the scans of ``world`` and score them."""
    tracks, seconds = [], []
    d = world.transition_model.ndim_state
    for t, scan in enumerate(world.detections):
        tic = time.perf_counter()
        tracks.append(tracker.step(scan, t * world.time_interval))
        seconds.append(time.perf_counter() - tic)
        shape = np.shape(getattr(tracks[-1], "means", None))
        if len(shape) != 2 or shape[1] != d:
            raise ValueError(f"the tracker's step must return tracks with means of shape "
                             f"(K, {d}) (the scenario's states), got "
                             f"{type(tracks[-1]).__name__} with means of shape {shape}")
    rows = np.zeros(len(world.detections), _row_dtype(metrics))
    rows["run"] = -1
    rows["step"] = np.arange(rows.size)
    rows["time"] = rows["step"] * world.time_interval
    scores = _score_scans(metrics, world, tracks, mapping, seconds, cutoff)
    for column, name in enumerate(metrics):
        rows[name] = scores[:, column]
    return rows


#: Payloads (digests of their pickles, or the ids of scenario and make_filter) warmed in this
#: process.
_WARMED = set()


def _run_batch(payload, runs):
    """Run ``runs`` (index, seed) pairs in this process: the task of a worker.

    ``payload`` is (scenario, make_filter, metrics, position_mapping, gospa_cutoff, threads),
    pickled for
    another process. The first batch of a payload in a process is preceded by one untimed
    run of its first seed, so that compilation is not timed as a step.
    Returns the rows of the completed runs and the failures."""
    key = hashlib.sha256(payload).digest() if isinstance(payload, bytes) \
        else tuple(map(id, payload[:2]))
    if isinstance(payload, bytes):
        payload = pickle.loads(payload)
    scenario, make_filter, metrics, mapping, cutoff, threads = payload
    if threads is not None:
        import numba
        from ..threads import set_threads
        set_threads(min(threads, numba.config.NUMBA_NUM_THREADS))
    if runs and key not in _WARMED:
        _WARMED.add(key)
        try:
            run_trial(scenario, make_filter, runs[0][1], metrics, mapping, cutoff)
        except Exception:  # the timed run reports it
            pass
    tables, failures = [], []
    for run, run_seed in runs:
        try:
            rows = run_trial(scenario, make_filter, run_seed, metrics, mapping, cutoff)
        except Exception as error:  # a failing run is reported, the others go on
            failures.append(RunFailure(run, run_seed, f"{type(error).__name__}: {error}",
                                       traceback.format_exc()))
            continue
        rows["run"] = run
        tables.append(rows)
    return tables, failures
