"""Every decoder and loader, fuzzed: bytes nobody anticipated get a clear error, nothing else.

Property-based (hypothesis), on the targets of :mod:`phd_swarm.tools.fuzz_targets`: their
valid seeds mutated (bit flips, 32-bit words set to edge values, cuts, insertions, deletions,
splices of two seeds) and plain random bytes. Derandomised, so a run is the same on every
machine: a new finding fails the commit that brings it, not a later one by chance. The
long, coverage-guided run is ``scripts/bench.sh fuzz --minutes N``.
"""

from __future__ import annotations

import pytest
from hypothesis import HealthCheck, given, settings

from phd_swarm.testing import fuzzed_bytes
from phd_swarm.tools.fuzz_targets import Finding, Target, exercise, targets

#: Examples per target: cheap decoders get more.
BUDGET = {"config": 60, "sweep_spec": 25, "log": 25, "evaluate": 8}


@pytest.mark.parametrize("name", sorted(targets()))
def test_every_input_is_decoded_or_refused_clearly(name):
    target = targets()[name]
    for seed in target.seeds():  # the seeds themselves are valid inputs
        target.run(seed)

    @settings(max_examples=BUDGET.get(name, 150), deadline=None, derandomize=True,
              database=None, suppress_health_check=[HealthCheck.too_slow,
                                                    HealthCheck.data_too_large])
    @given(fuzzed_bytes(target.seeds()))
    def survives(data: bytes) -> None:
        exercise(target, data)

    survives()


def test_an_unexpected_error_is_a_finding():
    def crash(data: bytes) -> None:
        raise IndexError("boom")

    with pytest.raises(Finding, match="t: IndexError: boom"):
        exercise(Target("t", crash, (ValueError,), list), b"")


def test_an_error_that_does_not_name_its_file_is_a_finding():
    def refuse(data: bytes) -> None:
        raise ValueError("bad")

    target = Target("f", refuse, (ValueError,), list, lambda: "/x/config.yaml")
    with pytest.raises(Finding, match="does not name /x/config.yaml"):
        exercise(target, b"")
    exercise(Target("g", refuse, (ValueError,), list), b"")  # no file: any text will do
