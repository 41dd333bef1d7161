"""Lossy links: LinkFaults validation and FaultyLink statistics."""

from __future__ import annotations

import numpy as np
import pytest

from phd_swarm.core.exchange.faults import DROP, FaultyLink, LinkFaults


@pytest.mark.parametrize("kwargs, match", [
    ({"drop": -0.1}, r"drop must lie in \[0, 1\]"),
    ({"drop": 1.5}, r"drop must lie in \[0, 1\]"),
    ({"delay": 2.0}, r"delay must lie in \[0, 1\]"),
    ({"drop": "0.1"}, "drop must be a number"),
    ({"delay": True}, "delay must be a number"),
    ({"max_delay_rounds": 0}, "max_delay_rounds must be an integer >= 1"),
    ({"max_delay_rounds": 1.5}, "max_delay_rounds must be an integer >= 1"),
    ({"seed": -1}, "seed must be an integer >= 0"),
])
def test_link_faults_rejects_values_out_of_range(kwargs, match):
    with pytest.raises(ValueError, match=match):
        LinkFaults(**kwargs)


def test_link_faults_accepts_the_bounds():
    assert not LinkFaults().active
    assert LinkFaults(drop=1.0).active and LinkFaults(delay=1.0, max_delay_rounds=3).active


class _CountingGenerator:
    """A generator that fails the test if anything draws from it."""

    def random(self, *args, **kwargs):
        raise AssertionError("a link without faults drew a random number")


def test_a_link_without_faults_draws_nothing_and_changes_nothing():
    link = FaultyLink(LinkFaults(), _CountingGenerator())
    envelopes = [object() for _ in range(50)]
    now, later = link.route(envelopes)
    assert now == envelopes and later == []
    assert link.dropped == link.delayed == 0
    assert link.decide(7).tolist() == [0] * 7


def test_the_fraction_dropped_is_drop():
    link = FaultyLink.for_sender(LinkFaults(drop=0.05, seed=3), robot_id=2)
    fate = np.concatenate([link.decide(1000) for _ in range(100)])
    assert abs(np.mean(fate == DROP) - 0.05) < 0.005   # 100 000 draws: sd 0.0007
    assert np.all(fate <= 0)
    assert link.dropped == int(np.sum(fate == DROP)) and link.delayed == 0


def test_delay_applies_to_the_messages_not_dropped_uniformly_over_the_rounds():
    link = FaultyLink.for_sender(LinkFaults(drop=0.1, delay=0.2, max_delay_rounds=3,
                                            seed=1), robot_id=0)
    fate = link.decide(200_000)
    assert abs(np.mean(fate == DROP) - 0.1) < 0.004
    late = fate[fate > 0]
    assert abs(late.size / fate.size - 0.9 * 0.2) < 0.004
    counts = np.bincount(late, minlength=4)[1:]
    assert counts.min() > 0 and late.max() == 3
    np.testing.assert_allclose(counts / late.size, [1 / 3] * 3, atol=0.01)
    assert link.delayed == late.size


def test_route_keeps_the_order_and_pairs_delays_with_envelopes():
    link = FaultyLink.for_sender(LinkFaults(drop=0.2, delay=0.3, max_delay_rounds=2,
                                            seed=5), robot_id=1)
    twin = FaultyLink.for_sender(LinkFaults(drop=0.2, delay=0.3, max_delay_rounds=2,
                                            seed=5), robot_id=1)
    envelopes = list(range(400))
    now, later = link.route(envelopes)
    fate = twin.decide(400)
    assert now == [e for e in envelopes if fate[e] == 0]
    assert later == [(int(fate[e]), e) for e in envelopes if fate[e] > 0]
    assert link.dropped == int(np.sum(fate == DROP))


def test_links_are_reproducible_and_independent_per_sender():
    faults = LinkFaults(drop=0.3, seed=9)
    a1 = FaultyLink.for_sender(faults, 4).decide(500)
    a2 = FaultyLink.for_sender(faults, 4).decide(500)
    b = FaultyLink.for_sender(faults, 5).decide(500)
    c = FaultyLink.for_sender(LinkFaults(drop=0.3, seed=10), 4).decide(500)
    assert np.array_equal(a1, a2)
    assert not np.array_equal(a1, b) and not np.array_equal(a1, c)
    # The sender's generator is default_rng([seed, robot_id]), as a ROS node derives it.
    u = np.random.default_rng([9, 4]).random(500)
    assert np.array_equal(a1 == DROP, u < 0.3)


def test_an_empty_batch_draws_nothing():
    link = FaultyLink.for_sender(LinkFaults(drop=0.5, seed=0), 0)
    state = link.rng.bit_generator.state
    assert link.route([]) == ([], [])
    assert link.rng.bit_generator.state == state
