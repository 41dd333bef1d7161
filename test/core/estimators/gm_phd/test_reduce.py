"""Vo & Ma Table II under both merge metrics: hand-computed cases, both paths, today's bits."""

from __future__ import annotations

import numpy as np
import pytest

from phd_swarm.core.estimators.gm_phd import reduce as gm_reduce
from phd_swarm.core.estimators.gm_phd.filter import GaussianMixture, GmPhdModel, prune_and_merge
from phd_swarm.core.estimators.gm_phd.reduce import check_merge_metric, reduce_components
from phd_swarm.core.estimators.gm_phd.team import PaddedMixtures, prune_and_merge_rows

METRICS = ("candidate", "heaviest")


def _model(d=2, prune=1e-3, merge=4.0, cap=100, metric="candidate"):
    return GmPhdModel(F=np.eye(d), Q=np.eye(d), H=np.eye(d)[:2], R=np.eye(2), p_s=0.9,
                      birth_weights=np.empty(0), birth_means=np.empty((0, d)),
                      birth_covs=np.empty((0, d, d)), clutter_intensity=1e-3,
                      prune_threshold=prune, merge_threshold=merge, max_components=cap,
                      merge_metric=metric)


def _mix(weights, xs, variances) -> GaussianMixture:
    """Components on the x axis at ``xs`` [m] with covariances ``variance`` I [m^2]."""
    n = len(weights)
    means = np.column_stack([xs, np.zeros(n)])
    return GaussianMixture(np.array(weights, dtype=float), means,
                           np.array(variances, dtype=float)[:, None, None] * np.eye(2))


def _reduced(mix: GaussianMixture, metric: str, via: str, merge=4.0) -> GaussianMixture:
    """Table II by gm_phd (``pairs``, ``columns``: the path above _PAIRWISE_MAX) or rows."""
    if via == "rows":
        return prune_and_merge_rows(PaddedMixtures.from_mixtures([mix]), 1e-3, merge, 100,
                                    metric)[0]
    return prune_and_merge(mix, _model(merge=merge, metric=metric))


def _random_mixture(rng, n, d, spread) -> GaussianMixture:
    """Weights some below the pruning threshold, covariances of mixed scale and shape."""
    w = rng.random(n) * rng.choice([0.01, 1.0], n)
    w[rng.random(n) < 0.2] = 5e-4
    m = rng.random((n, d)) * spread
    a = rng.standard_normal((n, d, d)) * rng.choice([0.1, 0.5, 2.0], (n, 1, 1))
    p = a @ np.swapaxes(a, -1, -2) + 0.05 * np.eye(d)
    return GaussianMixture(w, m, 0.5 * (p + np.swapaxes(p, -1, -2)))


def _unchanged(out: GaussianMixture, mix: GaussianMixture) -> None:
    """``out`` is ``mix`` with each component its own group (to rounding of (w m) / w)."""
    assert len(out) == len(mix)
    order = np.argsort(-mix.weights, kind="stable")
    np.testing.assert_array_equal(out.weights, mix.weights[order])
    np.testing.assert_allclose(out.means, mix.means[order], rtol=1e-15)
    np.testing.assert_allclose(out.covs, mix.covs[order], rtol=1e-15)


def _same(a: GaussianMixture, b: GaussianMixture) -> bool:
    return (len(a) == len(b) and np.array_equal(a.weights, b.weights)
            and np.array_equal(a.means, b.means) and np.array_equal(a.covs, b.covs))


@pytest.fixture(params=["pairs", "columns", "rows"])
def via(request, monkeypatch):
    if request.param == "columns":
        monkeypatch.setattr(gm_reduce, "_PAIRWISE_MAX", 0)
    return request.param


# ------------------------------------------------------------------ hand-computed cases
# U = 4 throughout. In each, the squared distance between the two means is 9 [m^2].

def test_a_wide_component_merges_into_a_tight_heavy_one_only_in_its_own_metric(via):
    # j: w 0.9 at 0, P = I; i: w 0.3 at (3, 0), P = 25 I.
    # candidate: 9 / 25 = 0.36 <= 4, merged; heaviest: 9 / 1 = 9 > 4, apart.
    mix = _mix([0.9, 0.3], [0.0, 3.0], [1.0, 25.0])
    merged = _reduced(mix, "candidate", via)
    # w = 1.2; x = (0.9 * 0 + 0.3 * 3) / 1.2 = 0.75; offsets 0.75 and -2.25;
    # P_xx = (0.9 (1 + 0.5625) + 0.3 (25 + 5.0625)) / 1.2 = 10.425 / 1.2 = 8.6875,
    # P_yy = (0.9 + 7.5) / 1.2 = 7.
    np.testing.assert_allclose(merged.weights, [1.2], rtol=1e-15)
    np.testing.assert_allclose(merged.means, [[0.75, 0.0]], rtol=1e-15)
    np.testing.assert_allclose(merged.covs, [[[8.6875, 0.0], [0.0, 7.0]]], rtol=1e-14)
    _unchanged(_reduced(mix, "heaviest", via), mix)


def test_a_tight_component_merges_into_a_wide_heavy_one_only_in_the_heavy_ones_metric(via):
    # j: w 0.9 at 0, P = 25 I; i: w 0.3 at (3, 0), P = I.
    # candidate: 9 / 1 = 9 > 4, apart; heaviest: 9 / 25 = 0.36 <= 4, merged.
    mix = _mix([0.9, 0.3], [0.0, 3.0], [25.0, 1.0])
    _unchanged(_reduced(mix, "candidate", via), mix)
    merged = _reduced(mix, "heaviest", via)
    # w = 1.2, x = 0.75; P_xx = (0.9 (25 + 0.5625) + 0.3 (1 + 5.0625)) / 1.2
    # = 24.825 / 1.2 = 20.6875, P_yy = (22.5 + 0.3) / 1.2 = 19.
    np.testing.assert_allclose(merged.weights, [1.2], rtol=1e-15)
    np.testing.assert_allclose(merged.means, [[0.75, 0.0]], rtol=1e-15)
    np.testing.assert_allclose(merged.covs, [[[20.6875, 0.0], [0.0, 19.0]]], rtol=1e-14)


def test_three_components_group_differently_under_the_two_metrics(via):
    # j: w 1.0 at 0, P = I; k: w 0.5 at 3, P = 25 I; l: w 0.4 at 4.5, P = I.
    mix = _mix([1.0, 0.5, 0.4], [0.0, 3.0, 4.5], [1.0, 25.0, 1.0])
    # candidate: j takes k (9 / 25 = 0.36), not l (20.25 / 1); l alone.
    # {j, k}: w 1.5, x = 1.5 / 1.5 = 1, offsets 1 and -2;
    # P_xx = (1 (1 + 1) + 0.5 (25 + 4)) / 1.5 = 11, P_yy = (1 + 12.5) / 1.5 = 9.
    cand = _reduced(mix, "candidate", via)
    np.testing.assert_allclose(cand.weights, [1.5, 0.4], rtol=1e-15)
    np.testing.assert_allclose(cand.means, [[1.0, 0.0], [4.5, 0.0]], rtol=1e-15)
    np.testing.assert_allclose(cand.covs, [np.diag([11.0, 9.0]), np.eye(2)], rtol=1e-14)
    # heaviest: j takes neither (9 / 1, 20.25 / 1); then k leads and takes l
    # (1.5^2 / 25 = 0.09). {k, l}: w 0.9, x = (1.5 + 1.8) / 0.9 = 11/3, offsets 2/3 and
    # -5/6; P_xx = (0.5 (25 + 4/9) + 0.4 (1 + 25/36)) / 0.9 = 13.4 / 0.9 = 134/9,
    # P_yy = (12.5 + 0.4) / 0.9 = 43/3.
    heavy = _reduced(mix, "heaviest", via)
    np.testing.assert_allclose(heavy.weights, [1.0, 0.9], rtol=1e-15)
    np.testing.assert_allclose(heavy.means, [[0.0, 0.0], [11.0 / 3.0, 0.0]], rtol=1e-15)
    np.testing.assert_allclose(heavy.covs, [np.eye(2), np.diag([134.0 / 9.0, 43.0 / 3.0])],
                               rtol=1e-14)


def test_both_metrics_agree_when_the_covariances_are_equal(via):
    mix = _mix([0.9, 0.3, 0.2], [0.0, 1.5, 8.0], [1.0, 1.0, 1.0])
    assert _same(_reduced(mix, "candidate", via), _reduced(mix, "heaviest", via))


# ------------------------------------------------------------------ paths and today's bits

@pytest.mark.parametrize("metric", METRICS)
def test_the_pairwise_and_column_paths_and_the_rows_agree(metric, monkeypatch):
    rng = np.random.default_rng(11)
    checked = merged = 0
    for _ in range(80):
        mix = _random_mixture(rng, int(rng.integers(0, 30)), 2, rng.uniform(0.5, 8.0))
        model = _model(merge=float(rng.uniform(0.5, 8.0)), cap=int(rng.integers(1, 40)),
                       metric=metric)
        pairs = prune_and_merge(mix, model)
        with monkeypatch.context() as patch:
            patch.setattr(gm_reduce, "_PAIRWISE_MAX", 0)
            columns = prune_and_merge(mix, model)
        rows = prune_and_merge_rows(PaddedMixtures.from_mixtures([mix]),
                                    model.prune_threshold, model.merge_threshold,
                                    model.max_components, metric)[0]
        assert _same(pairs, columns) and _same(pairs, rows)
        checked += 1
        merged += len(pairs) < min(np.count_nonzero(mix.weights > 1e-3), model.max_components)
    assert checked == 80 and merged > 20


def _table_ii_as_before(mix: GaussianMixture, model: GmPhdModel) -> GaussianMixture:
    """``gm_phd.prune_and_merge`` as it was before ``merge_metric`` (issue 33), frozen.

    Its pairwise path without the shortcut for all-singleton mixtures (which is bit for bit
    the general path), and its column path when ``columns``.
    """
    keep = mix.weights > model.prune_threshold
    w, m, p = mix.weights[keep], mix.means[keep], mix.covs[keep]
    if w.size == 0:
        return GaussianMixture.empty(model.dim)
    p_inv = np.linalg.inv(p)
    n = w.size
    labels = np.full(n, -1)
    taken = np.zeros(n, dtype=bool)
    n_groups = 0
    close = None
    if n <= 256:
        diff = m[:, None, :] - m[None, :, :]
        close = np.einsum("ijd,ide,ije->ij", diff, p_inv, diff) <= model.merge_threshold
    for j in np.argsort(-w, kind="stable"):
        if taken[j]:
            continue
        if close is None:
            diff = m - m[j]
            dist = np.einsum("ni,nik,nk->n", diff, p_inv, diff)
            group = (dist <= model.merge_threshold) & ~taken
        else:
            group = close[:, j] & ~taken
        group[j] = True
        labels[group] = n_groups
        taken |= group
        n_groups += 1
    by_group = np.argsort(labels, kind="stable")
    starts = np.searchsorted(labels[by_group], np.arange(n_groups))
    wg, mg, pg = w[by_group], m[by_group], p[by_group]
    w_sum = np.add.reduceat(wg, starts)
    mean = np.add.reduceat(wg[:, None] * mg, starts) / w_sum[:, None]
    dm = mean[labels[by_group]] - mg
    spread = wg[:, None, None] * (pg + dm[:, :, None] * dm[:, None, :])
    cov = np.add.reduceat(spread, starts) / w_sum[:, None, None]
    cov = 0.5 * (cov + np.swapaxes(cov, -1, -2))
    order = np.argsort(-w_sum, kind="stable")[:model.max_components]
    return GaussianMixture(w_sum[order], mean[order], cov[order])


@pytest.mark.parametrize("d", [2, 4])
def test_candidate_is_the_reduction_of_before_bit_for_bit(d):
    rng = np.random.default_rng(d)
    for trial in range(60):
        n = int(rng.integers(257, 320)) if trial % 12 == 0 else int(rng.integers(0, 40))
        mix = _random_mixture(rng, n, d, rng.uniform(0.5, 10.0))
        model = _model(d=d, merge=float(rng.uniform(0.5, 8.0)),
                       cap=int(rng.integers(1, 50)))
        assert model.merge_metric == "candidate"                     # the library default
        assert _same(prune_and_merge(mix, model), _table_ii_as_before(mix, model))


@pytest.mark.parametrize("metric", METRICS)
@pytest.mark.parametrize("path", ["pairs", "columns"])
def test_the_sources_name_the_output_each_input_went_to(metric, path, monkeypatch):
    if path == "columns":
        monkeypatch.setattr(gm_reduce, "_PAIRWISE_MAX", 0)
    rng = np.random.default_rng(5)
    merged = 0
    for _ in range(60):
        mix = _random_mixture(rng, int(rng.integers(0, 30)), 2, rng.uniform(0.5, 8.0))
        args = (1e-3, float(rng.uniform(0.5, 8.0)), int(rng.integers(1, 40)), metric)
        w, m, p = reduce_components(mix.weights, mix.means, mix.covs, *args)
        w2, m2, p2, source = gm_reduce.reduce_with_sources(mix.weights, mix.means,
                                                           mix.covs, *args)
        # The same reduction, bit for bit.
        for x, y in ((w, w2), (m, m2), (p, p2)):
            assert np.array_equal(x, y)
        assert source.shape == (len(mix),) and set(source.tolist()) <= {-1, *range(len(w))}
        assert np.all(source[mix.weights <= 1e-3] == -1)
        # Each output is the moment match of exactly the inputs sent to it.
        np.testing.assert_allclose(gm_reduce.carry(source, mix.weights, len(w)), w,
                                   rtol=1e-12)
        moments = gm_reduce.carry(source, mix.weights[:, None] * mix.means, len(w))
        np.testing.assert_allclose(moments / w[:, None], m, rtol=1e-9, atol=1e-9)
        merged += len(w) < np.count_nonzero(source >= 0)
    assert merged > 10


def test_carry_sums_rows_and_drops_the_pruned():
    source = np.array([1, -1, 0, 1])
    values = np.array([[1.0, 0.0], [5.0, 5.0], [0.0, 2.0], [0.5, 0.25]])
    np.testing.assert_array_equal(gm_reduce.carry(source, values, 3),
                                  [[0.0, 2.0], [1.5, 0.25], [0.0, 0.0]])


def test_reduce_components_on_arrays_prunes_to_empty_arrays():
    w, m, p = reduce_components(np.array([1e-4, 2e-4]), np.zeros((2, 3)),
                                np.broadcast_to(np.eye(3), (2, 3, 3)), 1e-3, 4.0, 10,
                                "heaviest")
    assert w.shape == (0,) and m.shape == (0, 3) and p.shape == (0, 3, 3)


# ------------------------------------------------------------------ validation

@pytest.mark.parametrize("bad", ["Heaviest", "own", "", None, 1])
def test_an_unknown_merge_metric_is_refused_naming_the_field(bad):
    with pytest.raises(ValueError, match="merge_metric must be one of 'heaviest', "
                                         "'candidate'"):
        _model(metric=bad)
    with pytest.raises(ValueError, match="merge_metric"):
        prune_and_merge_rows(PaddedMixtures.empty(1, 2), 1e-3, 4.0, 10, bad)
    with pytest.raises(ValueError, match="merge_metric"):
        reduce_components(np.ones(1), np.zeros((1, 2)), np.eye(2)[None], 1e-3, 4.0, 10, bad)


def test_check_merge_metric_returns_a_known_value():
    assert [check_merge_metric(m) for m in METRICS] == list(METRICS)
    with pytest.raises(ValueError, match="system.options.merge_metric"):
        check_merge_metric("x", "system.options.merge_metric")
