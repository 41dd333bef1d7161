"""score_step: the one scoring of a step shared by the monitor, the evaluation and sweeps."""

from __future__ import annotations

import numpy as np
import pytest

from phd_swarm.core.extraction import ExtractionConfig
from phd_swarm.core.geometry.grid import Environment, Grid
from phd_swarm.core.scoring import score_step


def _grid() -> Grid:
    return Grid(Environment(0.0, 0.0, 20.0, 10.0), 1.0)


def test_two_peaks_one_target_gives_one_false_estimate():
    grid = _grid()
    image = np.zeros(grid.shape)
    image[2, 3] = 0.9          # bin centre (3.5, 2.5)
    image[7, 15] = 0.6         # bin centre (15.5, 7.5)
    image[5, 10] = 0.01        # below the 0.05 threshold
    truth = np.array([[3.5, 3.0]])
    s = score_step(grid, image, truth, ExtractionConfig(), c=10.0, p=1.0)
    np.testing.assert_allclose(s.estimates, [[3.5, 2.5], [15.5, 7.5]])
    assert (s.cardinality_true, s.cardinality_est) == (1, 2)
    assert s.expected_cardinality == pytest.approx(1.51)
    # p = 1: (0.5 + 10) / 2, split into localisation 0.25 and cardinality 5.
    assert s.ospa == pytest.approx(5.25)
    assert s.ospa_localisation == pytest.approx(0.25)
    assert s.ospa_cardinality == pytest.approx(5.0)
    assert set(s.row()) == {"ospa", "ospa_localisation", "ospa_cardinality",
                            "cardinality_true", "cardinality_est", "expected_cardinality"}


def test_bad_image_names_the_problem():
    grid = _grid()
    with pytest.raises(ValueError, match="finite"):
        score_step(grid, np.full(grid.shape, np.nan), np.empty((0, 2)), ExtractionConfig(),
                   10.0, 1.0)
