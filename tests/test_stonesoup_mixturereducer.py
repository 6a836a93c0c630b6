"""The drop-in ``GaussianMixtureReducer`` against Stone Soup's own, on random mixtures:
the same components up to order and renamed tags, the same side effects."""
import copy

import numpy as np
import pytest

pytest.importorskip("stonesoup")
from stonesoup.mixturereducer.gaussianmixture import GaussianMixtureReducer as Original
from stonesoup.types.state import TaggedWeightedGaussianState, WeightedGaussianState

from fasttrack.stonesoup import GaussianMixtureReducer, fallbacks


def _components(seed, j, d, tagged=True, clusters=None):
    rng = np.random.default_rng(seed)
    centres = rng.uniform(-30.0, 30.0, size=(clusters or j // 3 + 1, d))
    means = centres[rng.integers(0, centres.shape[0], size=j)] + rng.normal(size=(j, d))
    a = rng.standard_normal((j, d, d)) * 0.5
    covars = a @ a.transpose(0, 2, 1) + np.eye(d) * rng.uniform(0.2, 2.0, size=(j, 1, 1))
    weights = 10.0 ** rng.uniform(-12, 0.3, size=j)
    kind = TaggedWeightedGaussianState if tagged else WeightedGaussianState
    extra = (lambda i: {"tag": f"t{i % max(j // 2, 1)}"}) if tagged else (lambda i: {})
    return [kind(means[i][:, None], covars[i], weight=weights[i], timestamp=i, **extra(i))
            for i in range(j)]


def _key(component):
    return (round(float(component.weight), 9), tuple(np.round(component.state_vector.ravel(), 6)))


def _same(got, want):
    assert len(got) == len(want)
    for g, w in zip(sorted(got, key=_key), sorted(want, key=_key)):
        assert type(g) is type(w)
        assert float(g.weight) == pytest.approx(float(w.weight), rel=1e-9, abs=1e-300)
        np.testing.assert_allclose(g.state_vector, w.state_vector, rtol=1e-9, atol=1e-9)
        np.testing.assert_allclose(g.covar, w.covar, rtol=1e-9, atol=1e-9)
        assert g.timestamp == w.timestamp


@pytest.mark.parametrize("seed", range(12))
def test_the_drop_in_reduces_as_stone_soup_does(seed):
    settings = [dict(), dict(prune_threshold=1e-6, merge_threshold=4.0),
                dict(prune_threshold=1e-3, merge_threshold=100.0, max_number_components=5),
                dict(merging=False, max_number_components=3), dict(pruning=False)][seed % 5]
    j = [1, 2, 30, 90, 150][seed % 5]
    components = _components(seed, j, 1 + seed % 4)
    theirs = copy.deepcopy(components)
    fallbacks(clear=True)
    got = GaussianMixtureReducer(**settings).reduce(components)
    want = Original(**settings).reduce(theirs)
    assert not fallbacks()
    _same(got, want)
    # the same side effects on the components given: weights of the kept raised in place
    for mine, original in zip(components, theirs):
        assert mine.weight == pytest.approx(original.weight, rel=1e-12)
    tags = [c.tag for c in got]
    assert len(set(tags)) == len(tags)  # shared tags renamed
    kept_tags = {c.tag for c in want if not c.tag.count("-")}  # not a fresh uuid
    assert kept_tags <= set(tags)


def test_untouched_components_are_returned_themselves():
    components = _components(0, 3, 2, clusters=3)
    components[1].state_vector[:] = 1e4
    reduced = GaussianMixtureReducer(prune_threshold=0.0).reduce(components)
    assert any(c is components[1] for c in reduced)


def test_untagged_components_merge_into_untagged_states():
    got = GaussianMixtureReducer(merge_threshold=1e6).reduce(_components(1, 6, 2, tagged=False))
    assert len(got) == 1 and type(got[0]) is WeightedGaussianState


def test_a_kd_tree_gate_runs_stone_soups_code_and_says_why():
    fallbacks(clear=True)
    GaussianMixtureReducer(kdtree_max_distance=5.0).reduce(_components(2, 10, 2))
    assert [reason for (_, _, reason) in fallbacks()] == ["a kd-tree gate (kdtree_max_distance)"]


def _edited(components, case):
    """``components`` with one of the inputs Stone Soup reduces and fasttrack's arrays
    refuse (or read otherwise)."""
    if case == "singular covariance":
        components[4].covar[:] = np.diag([1.0, 0.0])  # (a birth of no velocity spread)
    elif case == "negative weight kept":
        components[5].weight = -0.5
    elif case == "a component twice":
        components[7] = components[2]
    return components


@pytest.mark.parametrize("case, settings", [
    ("singular covariance", {}),
    ("negative weight kept", dict(prune_threshold=-1.0)),
    ("a component twice", {}),
    ("", dict(prune_threshold=float("nan"))),
    ("", dict(merge_threshold=float("nan"))),
    ("", dict(max_number_components=True)),
    ("", dict(max_number_components=2.5, merge_threshold=1e4)),
    ("", dict(merging=None)),
])
def test_what_fasttrack_refuses_or_reads_otherwise_is_reduced_as_stone_soup_reduces_it(
        case, settings):
    """A singular covariance, a negative weight left by a negative threshold, the same
    component twice (Stone Soup's merge counts it once), a NaN threshold (Stone Soup keeps
    w >= NaN: none) and settings Stone Soup reads by truthiness or slicing were refused with
    the arrays' names, reduced otherwise or merged a component with itself, and a refusal
    had already added the pruned mass to the caller's weights."""
    components = _edited(_components(3, 10, 2, clusters=4), case)
    theirs = copy.deepcopy(components)
    got = GaussianMixtureReducer(**settings).reduce(components)
    want = Original(**settings).reduce(theirs)
    _same(got, want)
    for mine, original in zip(components, theirs):
        assert mine.weight == pytest.approx(original.weight, rel=1e-12)


def test_a_weight_of_text_meets_stone_soups_error():
    """A weight '0.5' was read as 0.5 (Stone Soup's comparisons refuse it)."""
    components = _components(3, 10, 2, clusters=4)
    components[3].weight = "0.5"
    errors = []
    for reducer in (GaussianMixtureReducer, Original):
        with pytest.raises(TypeError) as error:
            reducer().reduce(copy.deepcopy(components))
        errors.append(str(error.value))
    assert errors[0] == errors[1]
