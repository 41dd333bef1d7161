"""The shared machinery names no system: nodes, engines and tools reach parts by declaration.

A system is its own modules (issue 35): its parts under ``core/{sensors,estimators,
exchange,controllers}``, its ROS faces under ``nodes/faces``. The robot node, the observers,
the engines and the generic tools must not import those modules nor name a built-in part by
string; they read what the parts declare (outputs, wires, hooks). Parsed, not imported, like
:mod:`test_layers`.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

from phd_swarm.core.registry import BUILTIN_PARTS

from .test_layers import PACKAGE, _imports

#: Packages whose modules belong to one system (their ``base`` modules are shared).
SYSTEM_PACKAGES = ("phd_swarm.core.sensors", "phd_swarm.core.estimators",
                   "phd_swarm.core.exchange", "phd_swarm.core.controllers",
                   "phd_swarm.nodes.faces")
#: Shared modules inside those packages: role bases and the exchange's transport models.
SHARED = ("phd_swarm.core.exchange.faults", "phd_swarm.core.exchange.contacts",
          "phd_swarm.core.exchange.radio")
#: Part names too common to tell a system by (``none`` is also an option value).
COMMON_NAMES = {"none"}
#: Tools that belong to one paper: its tables, fits and studies.
PAPER_TOOLS = {"fit_gp.py", "renewal.py", "loss_study.py", "sung_tables.py",
               "shirsat_tables.py", "papaioannou_tables.py"}

PART_NAMES = {n for names in BUILTIN_PARTS.values() for n in names} - COMMON_NAMES


def _system_module(module: str) -> bool:
    if module.endswith(".base") or module.startswith(SHARED):
        return False
    return module.startswith(SYSTEM_PACKAGES)


def offences(path: Path, text: str | None = None) -> list[str]:
    """What in ``path`` names a system: imports of its modules, part names as strings."""
    source = path.read_text() if text is None else text
    out = [f"line {line}: imports {m}" for line, m in _imports(path, source)
           if _system_module(m)]
    out += [f"line {n.lineno}: names part {n.value!r}" for n in ast.walk(ast.parse(source))
            if isinstance(n, ast.Constant) and isinstance(n.value, str)
            and n.value in PART_NAMES]
    return out


SHARED_MODULES = sorted(
    p for top in ("nodes", "engines", "tools") for p in (PACKAGE / top).rglob("*.py")
    if "faces" not in p.parts and p.name not in PAPER_TOOLS)


def _rel(p: Path) -> str:
    return str(p.relative_to(PACKAGE))


@pytest.mark.parametrize("path", SHARED_MODULES, ids=_rel)
def test_shared_modules_name_no_system(path):
    found = offences(path)
    assert not found, f"{_rel(path)} names a system: {found}"


def test_the_check_sees_system_imports_and_part_names():
    probe = PACKAGE / "nodes" / "probe.py"
    text = ("from phd_swarm.nodes.faces.voronoi_phd import WIRE\n"
            "from phd_swarm.core.controllers.base import Decision\n"
            "from phd_swarm.core.exchange.faults import LinkFaults\n"
            "def f(c):\n    return c == 'chen_o' or c == 'none'\n")
    assert offences(probe, text) == ["line 1: imports phd_swarm.nodes.faces.voronoi_phd",
                                     "line 5: names part 'chen_o'"]
