"""The config value validators (``expect_*``) and ParamSpec, which checks through them."""

from __future__ import annotations

import math
from functools import partial

import numpy as np
import pytest

from phd_swarm.core.params import (
    ParamSpec,
    expect_bool,
    expect_box,
    expect_int,
    expect_list,
    expect_mapping,
    expect_number,
    expect_str,
)


def refused(check, value, *args, **kwargs) -> str:
    """The message of the ValueError ``check(value, *args, **kwargs)`` raises."""
    with pytest.raises(ValueError) as exc:
        check(value, *args, **kwargs)
    return str(exc.value)


# ------------------------------------------------------------------------------ numbers
@pytest.mark.parametrize("value", [0, 3, 2.5, -1e9, np.float64(0.5), np.int32(7)])
def test_a_number_comes_back_as_a_float(value):
    out = expect_number(value, "a.b")
    assert type(out) is float and out == float(value)


@pytest.mark.parametrize("value", ["1.0", None, [1.0], True, False, 1j])
def test_what_is_not_a_real_number_is_refused(value):
    assert refused(expect_number, value, "targets.speed") == \
        f"targets.speed: expected a number, got {value!r}"


@pytest.mark.parametrize("value", [math.nan, math.inf, -math.inf, np.float64("nan")])
def test_nan_and_infinities_are_refused(value):
    assert refused(expect_number, value, "dt") == f"dt: expected a finite number, got {value!r}"


def test_allow_inf_lets_infinities_through_but_not_nan_and_bounds_still_apply():
    assert expect_number(math.inf, "ospa_p", low=1.0, allow_inf=True) == math.inf
    assert expect_number(-math.inf, "x", allow_inf=True) == -math.inf
    assert refused(expect_number, -math.inf, "ospa_p", low=1.0, allow_inf=True) == \
        "ospa_p: expected a number >= 1, got -inf"
    assert refused(expect_number, math.nan, "ospa_p", allow_inf=True) == \
        "ospa_p: expected a number, got nan"


@pytest.mark.parametrize(("kwargs", "good", "bad", "text"), [
    ({"low": 0.0}, [0.0, 1e9], [-1e-12], "expected a number >= 0"),
    ({"low": 0.0, "strict": True}, [1e-12], [0.0, -1.0], "expected a number > 0"),
    ({"high": 1.0}, [1.0, -5.0], [1.5], "expected a number <= 1"),
    ({"low": 0.0, "high": 1.0}, [0.0, 0.5, 1.0], [-0.1, 1.1], "expected a number in [0, 1]"),
    ({"low": 0.0, "high": 1.0, "strict": True}, [1.0], [0.0], "expected a number in (0, 1]"),
    ({"low": 0.01, "high": 1e6}, [0.01], [0.001], "expected a number in [0.01, 1000000]"),
    ({"low": 0.1}, [0.1], [0.05], "expected a number >= 0.1"),
])
def test_number_bounds_and_their_text(kwargs, good, bad, text):
    for v in good:
        assert expect_number(v, "p", **kwargs) == v
    for v in bad:
        assert refused(expect_number, v, "p", **kwargs) == f"p: {text}, got {v!r}"


# ----------------------------------------------------------------------------- integers
def test_an_integer_comes_back_as_an_int():
    assert expect_int(3, "robots") == 3
    out = expect_int(np.int64(4), "robots")
    assert type(out) is int and out == 4


@pytest.mark.parametrize("value", [True, False, 2.0, 2.5, "3", None, math.nan])
def test_bools_floats_and_strings_are_not_integers(value):
    assert refused(expect_int, value, "robots") == f"robots: expected an integer, got {value!r}"


def test_integer_bounds_and_their_text():
    assert expect_int(1, "robots", low=1) == 1
    assert refused(expect_int, 0, "robots", low=1) == "robots: expected an integer >= 1, got 0"
    assert refused(expect_int, True, "robots", low=1) == \
        "robots: expected an integer >= 1, got True"
    assert refused(expect_int, 65, "observers", low=0, high=64) == \
        "observers: expected an integer in [0, 64], got 65"
    assert refused(expect_int, 11, "n", high=10) == "n: expected an integer <= 10, got 11"


# ---------------------------------------------------------------------- strings, bools
def test_strings_choices_and_non_empty():
    assert expect_str("", "name") == ""
    assert refused(expect_str, 3, "system.estimator") == \
        "system.estimator: expected a string, got 3"
    assert refused(expect_str, "", "name", nonempty=True) == \
        "name: expected a non-empty string, got ''"
    assert expect_str("mean", "metric", choices=("final", "mean")) == "mean"
    for bad in ("max", 3, None):
        assert refused(expect_str, bad, "metric", choices=("final", "mean")) == \
            f"metric: expected one of ['final', 'mean'], got {bad!r}"


@pytest.mark.parametrize("value", [0, 1, "true", "yes", None, np.float64(1.0)])
def test_only_true_and_false_are_bools(value):
    assert refused(expect_bool, value, "targets.birth") == \
        f"targets.birth: expected true or false, got {value!r}"
    assert expect_bool(True, "b") is True and expect_bool(False, "b") is False


# -------------------------------------------------------------------------------- lists
def test_a_list_comes_back_as_a_tuple_with_its_items_checked():
    assert expect_list([1, "a"], "xs") == (1, "a")
    assert expect_list((), "xs") == ()
    assert expect_list([1, 2.5], "xs", item=expect_number) == (1.0, 2.5)
    assert refused(expect_list, [1, "two"], "quick.robots", item=partial(expect_int, low=1)) \
        == "quick.robots[1]: expected an integer >= 1, got 'two'"


@pytest.mark.parametrize("value", ["abc", b"ab", {"a": 1}, 3, None])
def test_strings_and_mappings_are_not_lists(value):
    assert refused(expect_list, value, "robots") == f"robots: expected a list, got {value!r}"


def test_non_empty_and_distinct():
    assert refused(expect_list, [], "robots", nonempty=True) == \
        "robots: expected a non-empty list, got []"
    assert expect_list([1, 2], "robots", distinct=True) == (1, 2)
    assert refused(expect_list, [1, 2, 1], "robots", distinct=True) == \
        "robots: expected distinct values, got [1, 2, 1]"
    # Distinct after conversion: 1 and 1.0 are one resolution.
    assert "distinct" in refused(expect_list, [1, 1.0], "res", item=expect_number,
                                 distinct=True)


# -------------------------------------------------------------------------------- boxes
def test_a_box_is_four_finite_numbers_with_max_above_min():
    assert expect_box([0, 0, 1, 2], "b") == (0.0, 0.0, 1.0, 2.0)
    assert expect_box((0.5, -1, 1, 2), "b") == (0.5, -1.0, 1.0, 2.0)
    out = expect_box(np.array([0, 0, 1, 2]), "b")
    assert out == (0.0, 0.0, 1.0, 2.0) and all(type(v) is float for v in out)
    shape = "expected four numbers (xmin, ymin, xmax, ymax)"
    for bad in ([0, 0, 1], [0, 0, 1, 1, 1], "0011", 3, {"x": 1}):
        assert refused(expect_box, bad, "robot_start_box") == \
            f"robot_start_box: {shape}, got {bad!r}"
    assert refused(expect_box, [0, 0, 1, "x"], "targets.clusters[0]") == \
        "targets.clusters[0][3]: expected a number, got 'x'"
    assert refused(expect_box, [0, 0, math.inf, 1], "b") == \
        "b[2]: expected a finite number, got inf"
    assert refused(expect_box, [0, 0, True, 1], "b") == "b[2]: expected a number, got True"
    for bad in ([1, 0, 1, 1], [0, 2, 1, 1]):
        assert refused(expect_box, bad, "b") == \
            f"b: {shape} with xmax > xmin and ymax > ymin, got {bad!r}"


# ----------------------------------------------------------------------------- mappings
def test_mappings_and_unknown_keys_named_by_their_path():
    d = {"a": 1}
    assert expect_mapping(d, "x") is d
    assert expect_mapping({"zz": 1}, "x") == {"zz": 1}
    assert refused(expect_mapping, [1], "targets") == "targets: expected a mapping, got [1]"
    assert refused(expect_mapping, {"b": 1, "sped": 2, "a": 3}, "targets", ["speed", "b"]) \
        == "targets.a: unknown key; expected one of ['b', 'speed']"
    # At the root the key is its own path.
    assert refused(expect_mapping, {"robot": 3}, "", ["robots"]) == \
        "robot: unknown key; expected one of ['robots']"
    assert refused(expect_mapping, 3, "") == "expected a mapping, got 3"


# ---------------------------------------------------------------------------- ParamSpec
def test_param_spec_checks_by_the_type_of_its_default():
    f = ParamSpec("step_timeout", 15.0, "d", low=0.1, high=3600.0)
    assert f.check(5) == 5.0 and type(f.check(5)) is float
    assert f.check(np.float64(2.0), "node /world") == 2.0
    assert refused(f.check, 0.05, "cfg.yaml: world") == \
        "cfg.yaml: world: step_timeout: expected a number in [0.1, 3600], got 0.05"
    assert refused(f.check, math.nan) == \
        "step_timeout: expected a finite number in [0.1, 3600], got nan"
    assert refused(f.check, True) == "step_timeout: expected a number in [0.1, 3600], got True"
    i = ParamSpec("observers", 0, "d", low=0, high=64)
    assert i.check(3) == 3
    assert refused(i.check, 3.0, "w") == "w: observers: expected an integer in [0, 64], got 3.0"
    b = ParamSpec("publish_markers", True, "d")
    assert b.check(False) is False
    assert refused(b.check, 1) == "publish_markers: expected true or false, got 1"
    s = ParamSpec("mode", "lockstep", "d", choices=("lockstep", "realtime"))
    assert s.check("realtime") == "realtime"
    assert refused(s.check, "fast") == \
        "mode: expected one of ['lockstep', 'realtime'], got 'fast'"
    free = ParamSpec("output", "run.mcap", "d")
    assert free.check("") == "" and "expected a string" in refused(free.check, 3)


def test_param_spec_refuses_a_default_it_cannot_check():
    with pytest.raises(TypeError, match="default must be"):
        ParamSpec("xs", [1, 2], "d")
    with pytest.raises(TypeError, match="choices"):
        ParamSpec("n", 1, "d", choices=("1", "2"))
