"""The perfect sweep's bound on Fig. 5a's tracking ratio, against hand computations."""

from __future__ import annotations

import math

import numpy as np
import pytest

from phd_swarm.core.analysis.tracking_bound import first_sight_pmf, tracking_ratio_bound

# One agent with a 5 m square on 100 m^2, covering 25 m^2 more per step: c = sqrt(2) a d
# = 25 for d = 25 / (5 sqrt 2); the first sight is uniform on {0, 1, 2, 3}.
SMALL = {"area": 100.0, "side": 5.0, "move": 25.0 / (5.0 * math.sqrt(2.0)),
         "target_speed": 0.0}


def test_the_first_sight_law_by_hand():
    np.testing.assert_allclose(first_sight_pmf(1, **SMALL), [0.25, 0.25, 0.25, 0.25])
    # The paper's geometry, 10 agents: 10 % of the area at once, then
    # sqrt(2) 10 x 10 x (4 + sqrt 2) = 765.7 m^2 a step.
    p = first_sight_pmf(10)
    c = math.sqrt(2.0) * 100.0 * (4.0 + math.sqrt(2.0)) / 1e4
    assert p[0] == pytest.approx(0.1) and p[1] == pytest.approx(c)
    assert p.sum() == pytest.approx(1.0) and len(p) == 13
    assert first_sight_pmf(100).tolist() == [1.0]            # the squares cover the area


def test_the_bound_by_hand_for_given_lifetimes():
    # L = 4 always: tracked 4, 3, 2, 1 steps for j = 0..3.
    assert tracking_ratio_bound(1, np.array([4]), **SMALL) == pytest.approx(10 / 16)
    assert tracking_ratio_bound(1, np.array([4]), "per_target", **SMALL) == \
        pytest.approx(10 / 16)
    # L in {2, 4}: E(2 - j)+ = 3/4, E(4 - j)+ = 10/4.
    lives = np.array([2, 4])
    assert tracking_ratio_bound(1, lives, **SMALL) == pytest.approx((0.75 + 2.5) / 6)
    assert tracking_ratio_bound(1, lives, "per_target", **SMALL) == \
        pytest.approx((0.75 / 2 + 2.5 / 4) / 2)


def test_geometric_lifetimes_follow_the_closed_form_and_the_paper_sits_at_the_bound():
    p = first_sight_pmf(10)
    q = 1.0 - 1.0 / 30.0
    closed = float(np.sum(p * q ** np.arange(len(p))))
    assert tracking_ratio_bound(10, 30.0) == pytest.approx(closed, rel=1e-9)
    # Fig. 5a's 0.83 for 10 agents is the pooled bound itself; the per-target mean cannot
    # exceed ~0.63, and static targets (s = 0) cap the pooled ratio at ~0.78.
    assert tracking_ratio_bound(10, 30.0) == pytest.approx(0.83, abs=0.005)
    assert tracking_ratio_bound(10, 30.0, "per_target") == pytest.approx(0.633, abs=0.005)
    assert tracking_ratio_bound(10, 30.0, target_speed=0.0) == pytest.approx(0.784, abs=0.005)
    bounds = [tracking_ratio_bound(n, 30.0) for n in (2, 4, 6, 8, 10)]
    assert bounds == sorted(bounds) and bounds[0] > 0.25          # Fig. 5a's 2 agents


def test_bad_input_is_refused():
    with pytest.raises(ValueError, match="agents"):
        first_sight_pmf(0)
    with pytest.raises(ValueError, match="reading"):
        tracking_ratio_bound(2, 30.0, "median")
    with pytest.raises(ValueError, match="lifetimes"):
        tracking_ratio_bound(2, np.array([0.0, 3.0]))
    with pytest.raises(ValueError, match="nothing moves"):
        first_sight_pmf(1, move=0.0, target_speed=0.0)
