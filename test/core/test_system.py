"""The system block: names, fit, options with defaults, plugins relative to the config."""

from __future__ import annotations

import pytest

from phd_swarm.core import registry
from phd_swarm.core.system import SystemConfig


def test_defaults_are_dames_and_every_option_is_spelled_out():
    s = SystemConfig()
    assert (s.sensor, s.estimator, s.exchange, s.controller) == ("disk", "grid_phd",
                                                                 "voronoi_phd", "phd")
    # The grid PHD's extraction window (Dames Sec. IV: 3 bins of 1 m, kept in metres).
    grid = {"extraction_radius": 0.0, "extraction_window": 3.0}
    assert dict(s.options) == grid
    o = SystemConfig(controller="chen_o")
    assert dict(o.options) == {**grid, "cumulative_mode": "rate", "rho_cap": "fixed",
                               "rho_max": 0.0}
    assert SystemConfig.from_dict(o.to_dict()) == o


def test_with_parts_keeps_the_options_the_new_parts_take():
    o = SystemConfig(controller="chen_o", options=(("rho_max", 3),))
    assert o.option("rho_max") == 3.0
    p = o.with_parts(controller="chen_p")
    grid = {"extraction_radius": 0.0, "extraction_window": 3.0}
    assert dict(p.options) == {**grid, "rho_cap": "fixed", "rho_max": 3.0}
    assert dict(o.with_parts(controller="phd").options) == grid
    assert o.with_parts(options={"cumulative_mode": "laplace"}).option("cumulative_mode") \
        == "laplace"


@pytest.mark.parametrize(("block", "message"), [
    ({"controller": "lloyd"}, "system.controller: unknown controller 'lloyd'"),
    ({"estimator": 3}, "system.estimator: expected a string, got 3"),
    ({"radio": "x"}, "system.radio: unknown key"),
    ({"options": {"rho_max": 1.0}}, "system.options.rho_max: unknown option"),
    ({"controller": "chen_o", "options": {"cumulative_mode": "x"}},
     "system.options.cumulative_mode: expected one of ['rate', 'literal', 'laplace']"),
    ({"controller": "chen_p", "options": {"rho_max": "big"}},
     "system.options.rho_max: expected a number in [0, 1000000], got 'big'"),
    ({"plugins": "my.py"}, "system.plugins: expected a list"),
    ({"plugins": ["no_such_plugin_module"]}, "system.plugins: plugin 'no_such_plugin_module'"),
])
def test_bad_blocks_name_the_key(block, message):
    with pytest.raises(ValueError) as exc:
        SystemConfig.from_dict(block, "run.yaml: scenario.system")
    assert str(exc.value).startswith("run.yaml: scenario.system")
    assert message.removeprefix("system") in str(exc.value)


def test_parts_that_do_not_fit_are_refused():
    registry.register("controller", "test_needs_gm", lambda s, r: None,
                      description="test", requires=("gaussian_mixture",))
    try:
        with pytest.raises(ValueError, match=r"test_needs_gm needs \['gaussian_mixture'\]"):
            SystemConfig(controller="test_needs_gm")
    finally:
        registry._PARTS["controller"].pop("test_needs_gm")


def test_relative_plugin_files_are_taken_from_the_config_directory(tmp_path):
    (tmp_path / "parts.py").write_text(
        "from phd_swarm.core import registry\n"
        "registry.register('controller', 'test_relative', lambda s, r: None,\n"
        "                  description='test')\n")
    s = SystemConfig.from_dict({"controller": "test_relative", "plugins": ["parts.py"]},
                               base_dir=tmp_path)
    assert s.plugins == (str(tmp_path / "parts.py"),)
    registry._PARTS["controller"].pop("test_relative")
