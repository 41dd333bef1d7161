"""The per-bin layers that travel with the bins: none, or Chen's cumulative alpha and n."""

from __future__ import annotations

import numpy as np

from phd_swarm.core.exchange.voronoi_phd.context import FilterContext
from phd_swarm.core.exchange.voronoi_phd.layers import BinLayer, CumulativeLayer, layer_for
from phd_swarm.core.geometry.grid import Environment, Grid
from phd_swarm.core.models import PhdModels

GRID = Grid(Environment(0.0, 0.0, 10.0, 10.0), 1.0)


def test_the_context_picks_the_layer():
    assert type(layer_for(FilterContext(GRID, PhdModels()))) is BinLayer
    assert type(layer_for(FilterContext(GRID, PhdModels(), cumulative=True))) is CumulativeLayer


def test_the_plain_layer_carries_nothing():
    layer = BinLayer()
    layer.reset(4)
    layer.observe(np.array([0, 1]), True)
    layer.apply()
    layer.take_over(2, [(np.array([0]), (np.array([1.0]), np.array([2.0])))])
    assert layer.alpha is None and layer.count is None
    assert layer.parcel(np.array([0])) == (None, None)


def test_the_scans_of_a_step_count_at_its_end():
    # Chen eq. 9-10: bin 0 seen by one scan with a detection, bin 2 by that scan and by
    # one without, bin 1 by none.
    layer = CumulativeLayer()
    layer.reset(3)
    layer.observe(np.array([0, 2]), True)
    layer.observe(np.array([2]), False)
    np.testing.assert_array_equal(layer.alpha, [0.0, 0.0, 0.0])  # not before the end
    layer.apply()
    np.testing.assert_array_equal(layer.alpha, [1.0, 0.0, 1.0])
    np.testing.assert_array_equal(layer.count, [1, 0, 2])
    layer.apply()  # a step without scans changes nothing
    np.testing.assert_array_equal(layer.count, [1, 0, 2])


def test_the_layer_goes_with_the_bins_and_orphans_start_unobserved():
    layer = CumulativeLayer()
    layer.reset(3)
    layer.observe(np.array([0, 1, 2]), True)
    layer.apply()
    layer.observe(np.array([1]), False)
    layer.apply()  # alpha (1, 1, 1), n (1, 2, 1)
    kept = layer.parcel(np.array([True, False, True]))
    given = layer.parcel(np.array([1]))
    np.testing.assert_array_equal(given[0], [1.0])
    np.testing.assert_array_equal(given[1], [2])
    # Four bins afterwards: the kept two at positions 0 and 3, bin 1 from a robot without
    # a layer, bin 2 from nobody (an orphan).
    layer.take_over(4, [(np.array([0, 3]), kept), (np.array([1]), (None, None))])
    np.testing.assert_array_equal(layer.alpha, [1.0, 0.0, 0.0, 1.0])
    np.testing.assert_array_equal(layer.count, [1.0, 0.0, 0.0, 1.0])


def test_the_map_layer_is_asked_for_by_the_controller():
    from phd_swarm.config import load_run_config
    from phd_swarm.core.exchange.voronoi_phd.layers import CumulativeMapLayer, MapLayer, map_layer

    scenario = load_run_config("config/chen_clustered.yaml").scenario
    plain = map_layer(scenario, frozenset({"cell"}))
    assert type(plain) is MapLayer and plain.of(np.arange(3)) == {} and plain.image() is None
    layer = map_layer(scenario, frozenset({"cell", "cumulative"}))
    assert isinstance(layer, CumulativeMapLayer) and layer.mode == "rate"
    # Chen eq. 9-10 over the map: one scan with a measurement, one without, overlapping.
    grid, radius = scenario.grid, scenario.models.detection.radius
    a, b = np.array([20.0, 20.0]), np.array([24.0, 20.0])
    layer.observe([(a, np.array([[20.0, 21.0]])), (b, np.empty((0, 2)))])
    both = np.intersect1d(grid.disk_bins(a, radius), grid.disk_bins(b, radius))
    only_b = np.setdiff1d(grid.disk_bins(b, radius), grid.disk_bins(a, radius))
    cell = layer.of(np.concatenate([both, only_b]))
    np.testing.assert_array_equal(cell["count"], [2] * both.size + [1] * only_b.size)
    np.testing.assert_array_equal(cell["alpha"], [1.0] * both.size + [0.0] * only_b.size)
    assert layer.image().shape == grid.shape
