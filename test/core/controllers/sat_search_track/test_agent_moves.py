"""Papaioannou et al.'s admissible moves (eq. 4): 17 actions, staying first, inside the region."""

from __future__ import annotations

import numpy as np
import pytest

from phd_swarm.core.controllers.sat_search_track.agent_moves import (
    action_offsets,
    admissible_positions,
)


def test_the_papers_settings_give_17_actions_in_a_fixed_order():
    off = action_offsets(2.0, 2, 8)
    assert off.shape == (17, 2)
    np.testing.assert_array_equal(off[0], [0.0, 0.0])
    np.testing.assert_allclose(off[1], [2.0, 0.0])
    np.testing.assert_allclose(off[3], [0.0, 2.0], atol=1e-15)         # 90 degrees
    np.testing.assert_allclose(off[9], [4.0, 0.0])                     # second ring
    np.testing.assert_allclose(np.hypot(*off[1:9].T), 2.0)
    np.testing.assert_allclose(np.hypot(*off[9:].T), 4.0)
    assert len({tuple(np.round(o, 9)) for o in off}) == 17


def test_moves_leaving_the_region_are_not_admissible_and_staying_always_is():
    pos, ok = admissible_positions([1.0, 50.0], action_offsets(2.0, 2, 8), (0, 0, 100, 100))
    np.testing.assert_allclose(pos[9], [5.0, 50.0])
    assert ok[0] and ok[1] and not ok[5] and not ok[13]                # 180 degrees: x < 0
    _, corner = admissible_positions([0.0, 0.0], action_offsets(2.0, 2, 8), (0, 0, 1, 1))
    assert corner.tolist() == [True] + [False] * 16


@pytest.mark.parametrize("args", [(0.0, 2, 8), (2.0, 0, 8), (2.0, 2, 1.5)])
def test_bad_settings_are_refused(args):
    with pytest.raises(ValueError):
        action_offsets(*args)
