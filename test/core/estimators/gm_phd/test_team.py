"""Many robots' mixtures at once: each row as if alone, and equal to gm_phd, bit for bit."""

from __future__ import annotations

import numpy as np
import pytest

from phd_swarm.core.estimators.gm_phd.filter import (
    GaussianMixture,
    GmPhdModel,
    predict,
    prune_and_merge,
)
from phd_swarm.core.estimators.gm_phd.team import (
    PaddedMixtures,
    _reduceat_sums,
    predict_rows,
    prune_and_merge_rows,
)


def _model(prune=1e-3, merge=4.0, cap=7, f=None, metric="candidate"):
    return GmPhdModel(F=np.eye(2) if f is None else f, Q=0.2 * np.eye(2), H=np.eye(2),
                      R=0.25 * np.eye(2), p_s=0.1, birth_weights=np.empty(0),
                      birth_means=np.empty((0, 2)), birth_covs=np.empty((0, 2, 2)),
                      clutter_intensity=4e-3, prune_threshold=prune, merge_threshold=merge,
                      max_components=cap, merge_metric=metric)


def _mixture(rng, n, spread):
    """A mixture of n components, some below the pruning weight, some close enough to merge."""
    w = rng.random(n) * rng.choice([0.01, 1.0], n)
    w[rng.random(n) < 0.2] = 5e-4
    m = rng.random((n, 2)) * spread
    a = rng.standard_normal((n, 2, 2)) * 0.5
    p = a @ np.swapaxes(a, -1, -2) + 0.05 * np.eye(2)
    return GaussianMixture(w, m, 0.5 * (p + np.swapaxes(p, -1, -2)))


def _same(a: GaussianMixture, b: GaussianMixture) -> bool:
    return (len(a) == len(b) and np.array_equal(a.weights, b.weights)
            and np.array_equal(a.means, b.means) and np.array_equal(a.covs, b.covs))


@pytest.mark.parametrize("shape", [(), (2,), (2, 2)])
def test_group_sums_are_numpys_reduceat_bit_for_bit(shape):
    """Short groups, groups past numpy's 8-term loop and past its 128-term block."""
    rng = np.random.default_rng(0)
    for sizes in ([1, 2, 3, 7, 8, 9, 1], [16, 17, 40, 1], [129, 300, 2], [1]):
        sizes = np.array(sizes)
        first = np.r_[0, np.cumsum(sizes)[:-1]]
        x = rng.random((sizes.sum(), *shape)) * 10.0 ** rng.uniform(
            -3, 2, (sizes.sum(),) + (1,) * len(shape))
        assert np.array_equal(_reduceat_sums(x, first, sizes),
                              np.add.reduceat(x, first, axis=0))


@pytest.mark.parametrize("metric", ["candidate", "heaviest"])
@pytest.mark.parametrize("seed", range(4))
def test_each_row_is_computed_as_if_alone_and_equals_gm_phd(seed, metric):
    rng = np.random.default_rng(seed)
    model = _model(metric=metric)
    checked = 0
    for _ in range(60):
        mixes = [_mixture(rng, int(rng.integers(0, 14)), rng.uniform(0.5, 6.0))
                 for _ in range(int(rng.integers(1, 6)))]
        width = max(len(m) for m in mixes) + int(rng.integers(0, 3))    # extra padding
        team = prune_and_merge_rows(PaddedMixtures.from_mixtures(mixes, width),
                                    model.prune_threshold, model.merge_threshold,
                                    model.max_components, metric)
        for mix, got in zip(mixes, team, strict=True):
            alone = prune_and_merge_rows(PaddedMixtures.from_mixtures([mix]),
                                         model.prune_threshold, model.merge_threshold,
                                         model.max_components, metric)[0]
            assert _same(got, alone)
            assert _same(got, prune_and_merge(mix, model))
            checked += 1
    assert checked > 100


def test_merging_sums_groups_and_keeps_the_heaviest_first():
    """Two close components merge (weights add, mean is the weighted mean); a far one stays."""
    mix = GaussianMixture(np.array([0.2, 0.6, 0.3]),
                          np.array([[0.0, 0.0], [0.1, 0.0], [5.0, 5.0]]),
                          np.broadcast_to(np.eye(2), (3, 2, 2)).copy())
    out = prune_and_merge_rows(PaddedMixtures.from_mixtures([mix, GaussianMixture.empty(2)]),
                               1e-3, 4.0, 10)
    assert out[0].weights.tolist() == pytest.approx([0.8, 0.3])
    np.testing.assert_allclose(out[0].means[0], [0.075, 0.0])
    assert len(out[1]) == 0


def test_all_pruned_rows_give_empty_mixtures():
    mix = GaussianMixture(np.array([1e-4]), np.zeros((1, 2)), np.eye(2)[None])
    out = prune_and_merge_rows(PaddedMixtures.from_mixtures([mix]), 1e-3, 4.0, 10)
    assert len(out) == 1 and len(out[0]) == 0 and out[0].means.shape == (0, 2)


def test_predict_rows_equals_gm_phd_for_static_targets_and_is_row_independent():
    rng = np.random.default_rng(7)
    mixes = [_mixture(rng, n, 3.0) for n in (0, 3, 9)]
    model = _model()
    got = predict_rows(PaddedMixtures.from_mixtures(mixes), model.F, model.Q, model.p_s)
    for r, mix in enumerate(mixes):
        assert _same(got.row(r), predict(mix, model))
    f = np.array([[1.0, 0.3], [-0.2, 0.9]])                   # any F: rows as if alone
    team = predict_rows(PaddedMixtures.from_mixtures(mixes), f, model.Q, model.p_s)
    for r, mix in enumerate(mixes):
        alone = predict_rows(PaddedMixtures.from_mixtures([mix]), f, model.Q, model.p_s)
        assert _same(team.row(r), alone.row(0))
        np.testing.assert_allclose(team.row(r).covs,
                                   f @ mix.covs @ f.T + model.Q if len(mix) else
                                   np.empty((0, 2, 2)), rtol=1e-14, atol=1e-15)


def test_rows_round_trip():
    rng = np.random.default_rng(1)
    mixes = [_mixture(rng, n, 2.0) for n in (2, 0, 5)]
    padded = PaddedMixtures.from_mixtures(mixes, width=6)
    assert padded.weights.shape == (3, 6) and padded.count.tolist() == [2, 0, 5]
    assert padded.valid.sum() == 7
    for r, mix in enumerate(mixes):
        assert _same(padded.row(r), mix)
    padded.set_row(1, mixes[0])
    assert _same(padded.row(1), mixes[0])
