"""The PHD as an OccupancyGrid: scale, origin, resolution and the row order of DensityGrid."""

from __future__ import annotations

import numpy as np
import pytest
from std_msgs.msg import Header

from phd_swarm.core.geometry.grid import Environment, Grid
from phd_swarm.nodes import convert, occupancy


def _values(msg) -> np.ndarray:
    return np.frombuffer(bytes(msg.data), dtype=np.int8).reshape(msg.info.height,
                                                                 msg.info.width)


@pytest.mark.parametrize("resolution", [1.0, 0.5, 0.1])
def test_100_is_one_target_per_square_metre_whatever_the_bin(resolution):
    full = resolution ** 2                      # 1 target / m^2 in one bin
    mass = np.array([0.0, 0.004 * full, 0.006 * full, 0.05 * full, 0.5 * full, full,
                     3 * full, -0.1])
    assert occupancy.scale(resolution) == pytest.approx(full)
    assert occupancy.occupancy_values(mass, resolution).tolist() == [0, 0, 1, 5, 50, 100, 100,
                                                                     0]


def test_a_mass_that_is_not_a_number_is_unknown():
    got = occupancy.occupancy_values(np.array([[np.nan, np.inf], [0.2, 0.0]]), 1.0)
    assert got.dtype == np.int8 and got.tolist() == [[-1, -1], [20, 0]]


def test_a_window_keeps_its_origin_resolution_frame_and_row_order():
    grid = Grid(Environment(-10.0, 5.0, 30.0, 25.0), 2.0)       # nx 20, ny 10
    ny, nx = grid.shape
    image = np.zeros((ny, nx))
    # an asymmetric window: rows 3..4, columns 6..8
    image[3, 6], image[3, 8], image[4, 7] = 0.4, 4.0, 2.0
    bins = np.flatnonzero(image)
    density = convert.density_grid(5, 12, grid, bins, image.ravel()[bins], 0.5, "world")
    msg = occupancy.from_density(density)
    assert msg.header == density.header and msg.header.frame_id == "world"
    assert msg.info.map_load_time == density.header.stamp
    assert (msg.info.width, msg.info.height) == (density.width, density.height) == (3, 2)
    assert msg.info.resolution == pytest.approx(2.0)
    origin = msg.info.origin
    assert (origin.position.x, origin.position.y) == (-10.0 + 6 * 2.0, 5.0 + 3 * 2.0)
    assert (origin.orientation.w, origin.position.z) == (1.0, 0.0)
    # value for value the DensityGrid's row-major data, scaled (4 m^2 bins: 100 = 4.0)
    window = np.frombuffer(density.data).reshape(2, 3)
    assert _values(msg).tolist() == [[10, 0, 100], [0, 50, 0]]
    assert np.array_equal(_values(msg), occupancy.occupancy_values(window, 2.0))
    # row r is at y = origin.y + r * resolution, as in the grid's image (row = y index)
    back = occupancy.to_mass(msg)
    assert back.shape == (2, 3) and back[1, 1] == pytest.approx(2.0)


def test_the_team_image_covers_the_map_from_its_corner():
    grid = Grid(Environment(0.0, 0.0, 4.0, 3.0), 1.0)
    image = np.arange(12, dtype=float).reshape(grid.shape) / 100.0
    h = convert.header(3, 0.5, "map")
    msg = occupancy.occupancy_grid(h, image, grid.env.xmin, grid.env.ymin, grid.resolution)
    assert (msg.info.width, msg.info.height) == (4, 3)
    assert (msg.info.origin.position.x, msg.info.origin.position.y) == (0.0, 0.0)
    assert _values(msg).ravel().tolist() == list(range(12))
    assert np.allclose(occupancy.to_mass(msg), image)


def test_an_empty_window_is_an_empty_grid():
    grid = Grid(Environment(0.0, 0.0, 4.0, 4.0), 1.0)
    density = convert.density_grid(1, 0, grid, np.array([], dtype=int), np.array([]), 0.5,
                                   "map")
    msg = occupancy.from_density(density)
    assert (msg.info.width, msg.info.height, len(msg.data)) == (0, 0, 0)
    assert occupancy.occupancy_grid(Header(), np.zeros((0, 0)), 0, 0, 1.0).info.width == 0
