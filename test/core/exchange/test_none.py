from __future__ import annotations

import numpy as np

from phd_swarm.core.exchange.none import NoExchange
from phd_swarm.core.registry import lookup


def test_a_step_is_done_at_once_and_sends_nothing():
    ex = lookup("exchange", "none").make(None, 0)
    assert isinstance(ex, NoExchange) and ex.step == -1
    ex.initialise(np.array([0]), np.zeros((1, 2)))
    ex.observe_team(3, np.array([0]), np.zeros((1, 2)), np.array([True]))
    assert ex.start_step(3, np.zeros(2), 0.0, np.empty((0, 2))) == []
    assert ex.done and ex.step == 3
    assert ex.receive(object()) is False and ex.advance() == [] and ex.tick() == []
    assert ex.stats == {}
