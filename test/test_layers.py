"""Imports point one way: core <- sim <- engines <- config, logs <- nodes <- tools <- testing.

Every module of the package is parsed (not imported) and each ``phd_swarm`` import it makes,
at module level or inside a function, is checked against the layer order; the core also
imports no rclpy and no ROS message package.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parents[1] / "phd_swarm"

#: Layer of each top-level part of the package; a module may import from its own layer and
#: the ones below it only.
LAYERS = {"core": 0, "sim": 1, "engines": 2, "config": 3, "logs": 3, "nodes": 4, "tools": 5,
          "testing": 6}

#: Imports the core may not make: it is pure numpy/scipy.
ROS_MODULES = ("rclpy", "rcl_interfaces", "builtin_interfaces", "std_msgs", "geometry_msgs",
               "visualization_msgs", "rosgraph_msgs", "phd_swarm_msgs")


def _layer(module: str) -> int | None:
    parts = module.split(".")
    if parts[0] != "phd_swarm" or len(parts) < 2:
        return None
    return LAYERS.get(parts[1])


def _module_name(path: Path) -> str:
    rel = path.relative_to(PACKAGE.parent).with_suffix("")
    parts = list(rel.parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def _imports(path: Path, text: str | None = None) -> list[tuple[int, str]]:
    """(line, absolute module) of every import in ``path``, relative ones resolved.

    ``text`` stands in for the file's contents (the checker's own test).
    """
    name = _module_name(path)
    package = name if path.name == "__init__.py" else name.rsplit(".", 1)[0]
    out = []
    source = path.read_text() if text is None else text
    for node in ast.walk(ast.parse(source, str(path))):
        if isinstance(node, ast.Import):
            out += [(node.lineno, a.name) for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")
                base = base[:len(base) - node.level + 1]
                module = ".".join(base + ([node.module] if node.module else []))
            else:
                module = node.module or ""
            # ``from phd_swarm import config`` imports the submodule.
            out += [(node.lineno, f"{module}.{a.name}" if module == "phd_swarm" else module)
                    for a in node.names]
    return out


MODULES = sorted(p for p in PACKAGE.rglob("*.py"))


def test_every_part_of_the_package_has_a_layer():
    tops = {p.relative_to(PACKAGE).parts[0].removesuffix(".py") for p in MODULES}
    assert tops - {"__init__"} <= set(LAYERS), sorted(tops - set(LAYERS))


@pytest.mark.parametrize("path", MODULES, ids=lambda p: str(p.relative_to(PACKAGE)))
def test_imports_point_down_the_layers(path):
    own = _layer(_module_name(path))
    if own is None:
        return  # phd_swarm/__init__.py
    upward = [f"line {line}: {module}" for line, module in _imports(path)
              if (_layer(module) or 0) > own]
    assert not upward, f"{path.relative_to(PACKAGE)} imports from a layer above: {upward}"


@pytest.mark.parametrize("path", [p for p in MODULES if _layer(_module_name(p)) == 0],
                         ids=lambda p: str(p.relative_to(PACKAGE)))
def test_the_core_imports_no_ros(path):
    ros = [f"line {line}: {module}" for line, module in _imports(path)
           if module.split(".")[0] in ROS_MODULES]
    assert not ros, f"{path.relative_to(PACKAGE)} imports ROS: {ros}"


def test_the_check_sees_upward_and_relative_imports():
    probe = PACKAGE / "core" / "controllers" / "probe.py"
    text = ("from phd_swarm.nodes import robot\nfrom ...tools import sweep\n"
            "from ..registry import lookup\nfrom phd_swarm import config\n"
            "def f():\n    import rclpy\n")
    found = [m for _, m in _imports(probe, text)]
    assert found == ["phd_swarm.nodes", "phd_swarm.tools", "phd_swarm.core.registry",
                     "phd_swarm.config", "rclpy"]
    assert [_layer(m) for m in found[:4]] == [4, 5, 0, 3]
