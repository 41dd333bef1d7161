"""The array forms of per-item computations equal the per-item forms, bit for bit.

The distributed filter is checked against the centralised one and the ROS stack against
the in-memory engine to the last bit, so every batched or cached path must reproduce the
float expression it replaces exactly (not just to a tolerance).
"""

from __future__ import annotations

import numpy as np
import pytest

from phd_swarm.core import models as core_models
from phd_swarm.core.controllers.power_lloyd.cumulative import cumulative_update_counts
from phd_swarm.core.exchange.voronoi_phd import context as context_mod
from phd_swarm.core.exchange.voronoi_phd.participant import FilterContext
from phd_swarm.core.geometry import ownership
from phd_swarm.core.geometry.grid import Environment, Grid
from phd_swarm.core.geometry.ownership import assign_bins, bins_owned_in_box
from phd_swarm.core.geometry.partition import cells
from phd_swarm.core.geometry.polygons import (
    points_in_any_polygon,
    points_in_polygon,
    points_in_polygons,
    polygon_distances,
    stack_polygons,
)


def _random_cells(rng: np.random.Generator, env: Environment, count: int) -> list[np.ndarray]:
    q = rng.uniform([env.xmin, env.ymin], [env.xmax, env.ymax], size=(count, 2))
    rho = rng.uniform(0.0, 3.0, count) if rng.random() < 0.5 else None
    return [c for c in cells(env, q, rho) if len(c)]


@pytest.mark.parametrize("res", [1.0, 0.5, 0.3, 0.1])
def test_disks_meet_equals_disk_bins_lookup(res: float) -> None:
    env = Environment(-1.5, 0.0, 28.5, 12.0) if res == 0.3 else Environment(0, 0, 30, 20)
    grid = Grid(env, res)
    rng = np.random.default_rng(7)
    for _ in range(60):
        flat = rng.choice(grid.size, size=int(rng.integers(0, 150)), replace=False)
        centres = rng.uniform(-8.0, 38.0, size=(30, 2))
        # Centres on bin centres and on bin edges, where the box and the <= test are tight.
        centres[:10] = grid.centres[rng.integers(grid.size, size=10)]
        centres[10:20] = np.round(centres[10:20] / res) * res
        radius = float(rng.choice([0.5 * res, 2.0 * res, 3.0 * res, 1.7, 5.0]))
        want = [np.isin(grid.disk_bins(c, radius), flat).any() for c in centres]
        np.testing.assert_array_equal(grid.disks_meet(flat, centres, radius), want)


def test_points_in_polygons_equals_one_polygon_at_a_time() -> None:
    env = Environment(0.0, 0.0, 20.0, 10.0)
    grid = Grid(env, 0.5)
    rng = np.random.default_rng(3)
    for _ in range(40):
        polys = _random_cells(rng, env, int(rng.integers(1, 25)))
        # A repeated vertex (a zero-length edge) and a polygon too small to hold anything.
        polys.append(np.vstack([polys[0][:1], polys[0]]))
        polys.append(polys[0][:2])
        pts = np.vstack([grid.centres[rng.choice(grid.size, 300, replace=False)],
                         np.concatenate(polys)])
        for tol in (0.0, 3e-8, -0.1):
            got = points_in_polygons(pts, polys, tol)
            for i, poly in enumerate(polys):
                np.testing.assert_array_equal(got[:, i], points_in_polygon(pts, poly, tol))
            np.testing.assert_array_equal(points_in_any_polygon(pts, polys, tol),
                                          got.any(axis=1))
    assert points_in_any_polygon(pts, [], 0.0).sum() == 0


def test_stack_polygons_edges_are_rolled_vertices() -> None:
    polys = [np.arange(6.0).reshape(3, 2), np.arange(8.0).reshape(4, 2) + 10.0,
             np.array([[1.0, 2.0]])]
    vertices, starts, following = stack_polygons(polys)
    np.testing.assert_array_equal(starts, [0, 3, 7])
    edges = vertices[following] - vertices
    for poly, start in zip(polys, starts, strict=True):
        np.testing.assert_array_equal(edges[start:start + len(poly)],
                                      np.roll(poly, -1, axis=0) - poly)


def test_cumulative_update_counts_at_once_equals_one_scan_at_a_time() -> None:
    rng = np.random.default_rng(5)
    alpha, n = np.zeros(50), np.zeros(50, dtype=np.int64)
    observed = np.zeros(50, dtype=np.int64)
    rewarded = np.zeros(50, dtype=np.int64)
    for _ in range(30):
        fov = rng.choice(50, size=int(rng.integers(0, 20)), replace=False)
        hit = bool(rng.random() < 0.5)
        one = np.zeros(50, dtype=np.int64)
        one[fov] = 1
        alpha, n = cumulative_update_counts(alpha, n, one, one * hit)
        observed[fov] += 1
        rewarded[fov] += hit
    got_alpha, got_n = cumulative_update_counts(np.zeros(50), np.zeros(50, dtype=np.int64),
                                                observed, rewarded)
    np.testing.assert_array_equal(got_alpha, alpha)
    np.testing.assert_array_equal(got_n, n)
    assert got_n.dtype == np.int64
    with pytest.raises(ValueError):
        cumulative_update_counts(alpha, n, observed, observed + 1)


def test_fov_bins_cache_returns_disk_bins_read_only() -> None:
    grid = Grid(Environment(0.0, 0.0, 40.0, 30.0), 0.5)
    ctx = FilterContext(grid, core_models.dames_static())
    radius = ctx.models.detection.radius
    rng = np.random.default_rng(2)
    sensors = rng.uniform(-2.0, 42.0, size=(context_mod._FOV_CACHE_SIZE + 20, 2))
    for q in sensors:
        disk = ctx.fov_bins(q)
        np.testing.assert_array_equal(disk, grid.disk_bins(q, radius))
        assert not disk.flags.writeable
        assert ctx.fov_bins(q.copy()) is disk  # keyed by the value, not the array
    # Bounded: the oldest disks were dropped, and a dropped one is recomputed the same.
    assert len(ctx._fov_cache) == context_mod._FOV_CACHE_SIZE
    np.testing.assert_array_equal(ctx.fov_bins(sensors[0]), grid.disk_bins(sensors[0], radius))


def test_contact_mask_equals_pairwise_rule() -> None:
    ctx = FilterContext(Grid(Environment(0.0, 0.0, 100.0, 100.0), 1.0),
                        core_models.dames_moving(), max_step=1.0)
    rng = np.random.default_rng(11)
    q = rng.uniform(0.0, 100.0, size=(400, 2))
    rho = rng.uniform(0.0, 5.0, 400) * (rng.random(400) < 0.5)
    radius = rng.uniform(0.0, 30.0, 400)
    got = ctx.contact_mask(q[0], rho[0], radius[0], q, rho, radius)
    bound_const = (max(ctx.models.detection.radius, ctx.reach) + 2.0 * ctx.contact_margin)
    for j in range(400):
        d = float(np.hypot(q[0][0] - q[j][0], q[0][1] - q[j][1]))
        want = d <= (2.0 * max(radius[0], radius[j]) + rho[0] + rho[j] + bound_const)
        assert got[j] == want == ctx.are_contacts(q[0], rho[0], radius[0], q[j], rho[j],
                                                  radius[j])
    assert 0 < got.sum() < 400


def _reference_polygon_distance(a: np.ndarray, b: np.ndarray) -> float:
    """One pair at a time: 0 on contact, else the smallest vertex-to-edge distance."""
    if points_in_polygon(a, b, tol=1e-9).any() or points_in_polygon(b, a, tol=1e-9).any():
        return 0.0

    def points_to_edges(points: np.ndarray, poly: np.ndarray) -> float:
        d = np.roll(poly, -1, axis=0) - poly
        len2 = np.maximum((d * d).sum(axis=1), 1e-300)
        rel = points[:, None, :] - poly[None, :, :]
        t = np.clip((rel * d[None]).sum(axis=2) / len2, 0.0, 1.0)
        closest = poly[None] + t[..., None] * d[None]
        return float(np.sqrt(((points[:, None, :] - closest) ** 2).sum(axis=2).min()))

    return min(points_to_edges(a, b), points_to_edges(b, a))


def test_polygon_distances_equal_pairwise_distances() -> None:
    env = Environment(0.0, 0.0, 100.0, 100.0)
    rng = np.random.default_rng(13)
    apart = 0
    for _ in range(60):
        polys = _random_cells(rng, env, int(rng.integers(3, 50)))
        got = polygon_distances(polys[0], polys[1:])
        want = [_reference_polygon_distance(polys[0], b) for b in polys[1:]]
        np.testing.assert_array_equal(got, want)
        apart += int(np.count_nonzero(got))
    assert apart > 100  # most pairs are apart, not only touching neighbours


@pytest.mark.parametrize("direct_pairs", [0, 1 << 14])
def test_bins_owned_in_box_equals_assign_bins(monkeypatch: pytest.MonkeyPatch,
                                              direct_pairs: int) -> None:
    # 0 forces the tiled, pruned path on every box; 2**14 takes the direct one on small boxes.
    monkeypatch.setattr(ownership, "_DIRECT_PAIRS", direct_pairs)
    rng = np.random.default_rng(17)
    for trial in range(120):
        res = (1.0, 0.5, 0.25, 0.1)[trial % 4]
        env = Environment(0.0, 0.0, 40.0, 30.0) if res > 0.2 else Environment(0, 0, 20, 15)
        grid = Grid(env, res)
        count = int(rng.integers(1, 40))
        if trial % 3 == 0:  # a crowded start: long wedge-shaped cells
            q = rng.uniform([5.0, 5.0], [12.0, 9.0], size=(count, 2))
        else:
            q = rng.uniform([0.0, 0.0], [env.xmax, env.ymax], size=(count, 2))
        if trial % 5 == 0 and count > 2:  # coincident generators, a generator on a bin
            q[1] = q[0]
            q[2] = grid.centres[rng.integers(grid.size)]
        if trial % 7 == 0:  # generators on bin edges: bin centres on bisectors, exact ties
            q = np.round(q / res) * res
        rho = None if trial % 2 else rng.uniform(0.0, 3.0, count) * (rng.random(count) < 0.6)
        iy0, ix0 = int(rng.integers(0, grid.ny // 2)), int(rng.integers(0, grid.nx // 2))
        iy1, ix1 = int(rng.integers(iy0 - 1, grid.ny)), int(rng.integers(ix0 - 1, grid.nx))
        iy, ix = np.meshgrid(np.arange(iy0, iy1 + 1), np.arange(ix0, ix1 + 1), indexing="ij")
        flat = (iy * grid.nx + ix).ravel()
        rows = assign_bins(grid.centres_of(flat), q, rho) if flat.size else flat
        for me in range(count):
            np.testing.assert_array_equal(
                bins_owned_in_box(grid, me, q, rho, (iy0, iy1, ix0, ix1)), flat[rows == me])
