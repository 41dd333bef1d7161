"""The real-time hold on a robot's own verdicts (phd_swarm.nodes.silence)."""

from __future__ import annotations

import numpy as np

from phd_swarm.nodes.silence import SilenceHold

IDS = np.arange(4)
ALL = np.ones(4, dtype=bool)


def _alive(*dead: int) -> np.ndarray:
    out = ALL.copy()
    out[list(dead)] = False
    return out


def test_every_step_is_an_epoch_by_default_so_the_world_rules_as_in_lockstep():
    hold = SilenceHold(1)
    for k in range(5):
        assert hold.keep_dead(k, IDS, ALL, frozenset({2})) == frozenset()


def test_a_peer_declared_dead_on_silence_stays_dead_until_the_next_epoch():
    hold = SilenceHold(6)
    assert hold.keep_dead(7, IDS, ALL, frozenset({2, 3})) == {2, 3}
    assert hold.keep_dead(11, IDS, ALL, frozenset({2, 3})) == {2, 3}
    assert hold.keep_dead(12, IDS, ALL, frozenset({2, 3})) == frozenset()  # 12 mod 6 = 0


def test_the_worlds_verdicts_count_at_once():
    hold = SilenceHold(6)
    assert hold.keep_dead(7, IDS, ALL, frozenset({2, 3})) == {2, 3}
    # The world counts 2 dead: its word, not this robot's, from now on.
    assert hold.keep_dead(8, IDS, _alive(2), frozenset({2, 3})) == {3}
    # 2 is back in the world's eyes (dead -> alive): admitted at once, 3 still held.
    assert hold.keep_dead(9, IDS, ALL, frozenset({2, 3})) == {3}
    # A peer the world keeps alive but this robot never declared dead is not held.
    assert hold.keep_dead(10, IDS, ALL, frozenset({3})) == {3}
