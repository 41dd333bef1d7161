"""The registry: names -> parts, plugins from modules and files, clear errors."""

from __future__ import annotations

import subprocess
import sys

import pytest

from phd_swarm.core import registry
from phd_swarm.core.registry import RegistryError, load_plugins, lookup, names, register


def test_the_built_in_parts_are_registered():
    assert {"chen_o", "chen_p", "phd", "uniform"} <= set(names("controller"))
    assert "voronoi_phd" in names("exchange") and "grid_phd" in names("estimator")
    assert "disk" in names("sensor")
    assert lookup("exchange", "voronoi_phd").wire.endswith(":WIRE")


def test_the_table_of_built_in_parts_is_what_their_modules_register():
    registered = {(role, name, lookup(role, name).make.__module__)
                  for role in registry.ROLES for name in names(role)
                  if lookup(role, name).make.__module__.startswith("phd_swarm.core.")}
    table = {(role, name, module) for role, parts in registry.BUILTIN_PARTS.items()
             for name, module in parts.items()}
    assert registered == table


def test_a_lookup_imports_only_the_module_of_its_part():
    """A Dames robot does not import the other systems' parts (~0.3 s of start-up each)."""
    code = ("import sys\n"
            "from phd_swarm.core import registry\n"
            "for role, name in [('sensor', 'disk'), ('estimator', 'grid_phd'),\n"
            "                   ('exchange', 'voronoi_phd'), ('controller', 'phd')]:\n"
            "    registry.lookup(role, name)\n"
            "print(' '.join(sorted(m for m in sys.modules if m.startswith(\n"
            "    ('phd_swarm.core.estimators.', 'phd_swarm.core.controllers.', 'scipy.optimize',\n"
            "     'scipy.spatial')))))\n")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True).stdout.split()
    assert "phd_swarm.core.estimators.grid_phd.estimator" in out
    assert "phd_swarm.core.controllers.lloyd" in out
    others = [m for m in out if m.rsplit(".", 1)[-1] in
              {"papaioannou", "shirsat", "sung", "sat_search_track", "sung_planners"}]
    assert others == []
    assert not [m for m in out if m.startswith(("scipy.optimize", "scipy.spatial"))]


def test_unknown_names_and_roles_are_refused_with_the_choices():
    with pytest.raises(RegistryError, match=r"unknown controller 'lloyd'; expected one of"):
        lookup("controller", "lloyd")
    with pytest.raises(RegistryError, match="unknown role"):
        lookup("planner", "x")
    with pytest.raises(RegistryError, match="lower-case identifier"):
        register("controller", "Bad-Name", lambda s, r: None, description="x")


def test_a_name_taken_by_another_module_is_refused():
    def make(setup, rid):  # defined here: another module than phd_swarm.core.controllers
        return None

    with pytest.raises(RegistryError, match="already registered by"):
        register("controller", "phd", make, description="imposter")
    assert lookup("controller", "phd").make.__module__ != __name__


def test_plugins_from_a_file_and_a_module_register_once(tmp_path, monkeypatch):
    plugin = tmp_path / "my_parts.py"
    plugin.write_text("from phd_swarm.core import registry\n"
                      "COUNT = globals().get('COUNT', 0) + 1\n"
                      "registry.register('controller', 'test_file_part', lambda s, r: None,\n"
                      "                  description='test')\n")
    load_plugins([str(plugin)])
    load_plugins([str(plugin)])  # a second import is a no-op
    assert lookup("controller", "test_file_part").description == "test"
    module = next(m for n, m in sys.modules.items() if n.startswith("phd_swarm_plugin_")
                  and n.endswith("my_parts"))
    assert module.COUNT == 1
    (tmp_path / "my_module_parts.py").write_text(
        "from phd_swarm.core import registry\n"
        "registry.register('controller', 'test_module_part', lambda s, r: None,\n"
        "                  description='test')\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    load_plugins(["my_module_parts"])
    assert "test_module_part" in names("controller")
    for name in ("test_file_part", "test_module_part"):
        registry._PARTS["controller"].pop(name)


def test_a_plugin_that_cannot_load_is_named(tmp_path):
    with pytest.raises(RegistryError, match="plugin 'no_such_module' cannot be loaded"):
        load_plugins(["no_such_module"])
    with pytest.raises(RegistryError, match="no such file"):
        load_plugins([str(tmp_path / "missing.py")])
    broken = tmp_path / "broken.py"
    broken.write_text("raise RuntimeError('boom')\n")
    with pytest.raises(RegistryError, match="RuntimeError: boom"):
        load_plugins([str(broken)])


def test_hooks_are_typed_and_belong_to_their_role(monkeypatch):
    from phd_swarm.core import registry

    monkeypatch.setitem(registry._PARTS, "controller", dict(registry._PARTS["controller"]))
    with pytest.raises(registry.RegistryError, match="unknown hook 'figurez'"):
        registry.register("controller", "hook_probe", lambda s, r: None, description="x",
                          figurez=lambda *a: {})
    with pytest.raises(registry.RegistryError, match="'wire' is a hook of exchange parts, "
                                                     "not of a controller"):
        registry.register("controller", "hook_probe", lambda s, r: None, description="x",
                          wire="m:W")
    part = registry.register("controller", "hook_probe", lambda s, r: None,
                             description="x", figures=len)
    assert part.figures is len and part.central is None and part.wire == ""
    assert registry.lookup("estimator", "grid_phd").runs_in_exchange
    assert registry.lookup("sensor", "disk").simulate is not None
