"""Gaussian mixture reduction (prune, merge, cap) of a GM-PHD's posterior: J components in
4-D (x, vx, y, vy) around J / 10 targets at a fixed density (one target per 400 m^2), ten
components each (the prediction and its updates, a few metres apart), weights from 1e-12
to 1, prune 1e-8, merge 5 (Stone Soup's GM-PHD tutorial). fasttrack's kernel (textbook and
Stone Soup rules) against a NumPy reference (vectorised over the candidates of each merge,
textbook rules) and Stone Soup's ``GaussianMixtureReducer`` with the drop-in, in the same
run."""
import numpy as np
import pytest

from fasttrack.core import mixture

PRUNE, MERGE = 1e-8, 5.0


def components(j, seed=0):
    """Means (J, 4), covariances (J, 4, 4) and weights (J,)."""
    rng = np.random.default_rng(seed)
    targets = max(j // 10, 1)
    side = 20.0 * np.sqrt(targets)
    centres = np.c_[rng.uniform(0, side, targets), rng.normal(0, 1, targets),
                    rng.uniform(0, side, targets), rng.normal(0, 1, targets)]
    means = centres[np.arange(j) % targets] + rng.normal(0, [2.0, 0.3, 2.0, 0.3], (j, 4))
    block = np.array([[1.0, 0.2], [0.2, 0.3]])  # position and velocity, correlated
    covars = np.kron(np.eye(2), block) * rng.uniform(0.5, 2.0, (j, 1, 1))
    return means, covars, 10.0 ** rng.uniform(-12, 0, j)


def numpy_reduce(means, covars, weights):
    """Textbook prune and merge in NumPy: each merge's distances in one vectorised step."""
    keep = weights > PRUNE
    m, p, w = means[keep], covars[keep], weights[keep]
    inverses = np.linalg.inv(p)
    alive = np.ones(w.size, dtype=bool)
    out = []
    for best in np.argsort(w, kind="stable")[::-1]:
        if not alive[best]:
            continue
        live = np.flatnonzero(alive)
        v = m[live] - m[best]
        group = live[np.einsum("ki,ij,kj->k", v, inverses[best], v) <= MERGE]
        alive[group] = False
        total = w[group].sum()
        mean = w[group] @ m[group] / total
        spread = m[group] - mean
        covar = (np.einsum("k,kij->ij", w[group], p[group])
                 + (spread.T * w[group]) @ spread) / total
        out.append((mean, covar, total))
    return out


@pytest.mark.parametrize("mode", ["textbook", "stonesoup"])
@pytest.mark.parametrize("j", [500, 1000, 2000, 5000, 10_000, 20_000])
def test_reduce_fasttrack(benchmark, j, mode):
    benchmark.group = f"mixture-reduce J={j}"
    benchmark.extra_info["mode"] = mode
    means, covars, weights = components(j)
    reduced = mixture.reduce(means, covars, weights, mode=mode, prune_threshold=PRUNE,
                             merge_threshold=MERGE)
    assert 0 < reduced[2].size < j
    benchmark.pedantic(mixture.reduce, (means, covars, weights),
                       dict(mode=mode, prune_threshold=PRUNE, merge_threshold=MERGE),
                       rounds=20 if j <= 5000 else 5, warmup_rounds=1)


@pytest.mark.parametrize("j", [500, 5000])
def test_reduce_numpy_reference(benchmark, j):
    benchmark.group = f"mixture-reduce J={j}"
    means, covars, weights = components(j)
    want = mixture.reduce(means, covars, weights, prune_threshold=PRUNE, merge_threshold=MERGE)
    got = numpy_reduce(means, covars, weights)
    np.testing.assert_allclose([total for *_, total in got], want[2], rtol=1e-9)
    benchmark.pedantic(numpy_reduce, (means, covars, weights), rounds=3 if j > 500 else 5,
                       warmup_rounds=0)


def _stonesoup_components(j):
    from stonesoup.types.state import TaggedWeightedGaussianState
    means, covars, weights = components(j)
    return [TaggedWeightedGaussianState(means[i][:, None], covars[i], weight=weights[i],
                                        tag=str(i)) for i in range(j)]


@pytest.mark.parametrize("implementation", ["stonesoup", "dropin"])
@pytest.mark.parametrize("j", [500, 1000])
def test_reduce_stonesoup(benchmark, j, implementation):
    """Each round reduces fresh copies (the reducers change their input's weights)."""
    pytest.importorskip("stonesoup")
    import copy
    if implementation == "stonesoup":
        from stonesoup.mixturereducer.gaussianmixture import GaussianMixtureReducer
    else:
        from fasttrack.stonesoup import GaussianMixtureReducer
    benchmark.group = f"mixture-reduce J={j}"
    reducer = GaussianMixtureReducer(prune_threshold=PRUNE, merge_threshold=MERGE)
    original = _stonesoup_components(j)
    reduced = reducer.reduce(copy.deepcopy(original))
    assert len(reduced) == mixture.reduce(*components(j), mode="stonesoup",
                                          prune_threshold=PRUNE, merge_threshold=MERGE)[2].size
    benchmark.pedantic(reducer.reduce, setup=lambda: ((copy.deepcopy(original),), {}),
                       rounds=3)
