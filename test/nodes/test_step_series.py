"""StepSeries: the monitor's rows as typed columns, the same rows back."""

import math

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from phd_swarm.nodes.monitor import figure_means
from phd_swarm.nodes.step_series import StepSeries

KEYS = ("step", "ospa", "cardinality_est", "tracks")
VALUES = st.one_of(st.integers(min_value=-10**6, max_value=10**6),
                   st.floats(allow_nan=False, allow_infinity=False, width=64))
ROWS = st.lists(st.dictionaries(st.sampled_from(KEYS), VALUES), max_size=40)


@settings(max_examples=300, deadline=None, derandomize=True, database=None)
@given(ROWS)
def test_the_rows_come_back_as_appended(rows):
    series = StepSeries()
    for row in rows:
        series.append(row)
    assert len(series) == len(rows)
    # A key some row lacks is left out of those rows again; ints stay equal (as ints, or
    # as floats in a column that also holds floats).
    assert list(series) == rows
    assert series[:] == rows
    if rows:
        assert series[-1] == rows[-1]
    for key in KEYS:
        want = [r.get(key, math.nan) for r in rows]
        assert np.array_equal(series.column(key), np.array(want, dtype=float), equal_nan=True)


def test_columns_keep_their_types_and_grow_by_eight_bytes_a_figure():
    series = StepSeries()
    for k in range(10_000):
        series.append({"step": k, "t": 0.5 * k, "ospa": 1.0 / (k + 1), "cardinality_est": 3})
    row = series[1234]
    assert row == {"step": 1234, "t": 617.0, "ospa": 1.0 / 1235, "cardinality_est": 3}
    assert type(row["step"]) is int and type(row["t"]) is float
    assert series.nbytes() <= 2 * 10_000 * 4 * 8


def test_a_figure_some_steps_lack_is_averaged_over_the_steps_that_have_it():
    series = StepSeries()
    for k, row in enumerate([{"tracks": 2.0}, {}, {"tracks": 4.0, "new": 1.0}, {"tracks": None}]):
        series.append({"step": k, **row})
    assert [r.get("tracks") for r in series] == [2.0, None, 4.0, None]
    assert list(series)[3] == {"step": 3}
    assert figure_means(series, ["tracks", "new", "absent"]) == {
        "tracks": 3.0, "new": 1.0, "absent": None}
