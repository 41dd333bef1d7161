"""StepSet and Timeline behave as the set and dict they replace, in memory of their changes."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from phd_swarm.nodes.step_sets import StepSet, Timeline

RUNS = settings(max_examples=300, deadline=None, derandomize=True, database=None)


@RUNS
@given(st.lists(st.integers(min_value=0, max_value=60), max_size=80))
def test_a_step_set_is_the_set_of_its_steps(steps):
    got, model = StepSet(), set()
    for k in steps:
        got.add(k)
        model.add(k)
        assert len(got) == len(model)
    assert list(got) == sorted(model)
    assert got == model and got == StepSet(sorted(model))
    assert all((k in got) == (k in model) for k in range(-2, 64))
    assert got.array().tolist() == sorted(model)
    assert got.last == max(model, default=None)
    for k in range(-2, 64):
        assert got.after(k) == min((j for j in model if j > k), default=None)
    runs = got.runs()  # disjoint, ascending, not touching
    assert all(a <= b and b + 1 < c for (a, b), (c, _) in zip(runs, runs[1:], strict=False))


def test_steps_in_order_are_one_run():
    steps = StepSet()
    for k in range(10_000):
        steps.add(k)
    assert steps.runs() == [(0, 9_999)] and len(steps) == 10_000
    assert 5_000 in steps and 10_000 not in steps and "5" not in steps


@RUNS
@given(st.lists(st.tuples(st.integers(min_value=0, max_value=30),
                          st.frozensets(st.integers(min_value=0, max_value=3))), max_size=60))
def test_a_timeline_is_the_dict_of_its_values(writes):
    got, model = Timeline(), {}
    for k, value in writes:
        got[k] = value
        model[k] = value
        assert len(got) == len(model)
        assert all(got.get(j) == model.get(j) for j in range(-1, 33)), (k, value)
    assert list(got) == sorted(model) and dict(got) == model
    assert got.last == max(model, default=None)


def test_a_timeline_stores_changes_only():
    alive = Timeline.flags()
    flags = np.ones(20, dtype=bool)
    for k in range(5_000):
        if k == 2_000:
            flags = flags.copy()
            flags[3] = False
        alive[k] = flags
    assert alive.changes() == 2 and len(alive) == 5_000
    assert alive[1_999].all() and not alive[2_000][3] and not alive[4_999][3]
    with pytest.raises(ValueError):
        alive[10][0] = False  # a stored value is read-only
    with pytest.raises(KeyError):
        alive[5_000]
