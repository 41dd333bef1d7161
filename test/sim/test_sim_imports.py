"""Imports inside the simulator point one way: no module of ``phd_swarm.sim`` imports itself.

Every module under ``phd_swarm/sim`` is parsed (not imported) and each import it makes of
another sim module, at module level, inside a function or under ``TYPE_CHECKING``, is an
edge; the graph must have no cycle. So the scenario's dataclasses sit above the target
kinds, and the world and the presets above the scenario, with nothing pointing back.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

SIM = Path(__file__).resolve().parents[2] / "phd_swarm" / "sim"
PACKAGE = "phd_swarm.sim"


def _module(path: Path) -> str:
    parts = list(path.relative_to(SIM).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join([PACKAGE, *parts])


def sim_imports(path: Path, text: str | None = None, known: set[str] | None = None
                ) -> set[str]:
    """The sim modules that the module at ``path`` imports (``text``: its source instead).

    ``from phd_swarm.sim import walkers`` imports the module ``phd_swarm.sim.walkers``;
    relative imports are resolved against the module's package; ``known`` are the modules
    that exist (default: those under ``phd_swarm/sim``).
    """
    known = MODULES if known is None else known
    name = _module(path)
    package = name if path.name == "__init__.py" else name.rsplit(".", 1)[0]
    out = set()
    for node in ast.walk(ast.parse(path.read_text() if text is None else text, str(path))):
        if isinstance(node, ast.Import):
            targets = [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                up = package.split(".")[:len(package.split(".")) - node.level + 1]
                base = ".".join(up + ([node.module] if node.module else []))
            # A name imported from a package may be its submodule.
            targets = [base] + [f"{base}.{a.name}" for a in node.names]
        else:
            continue
        out |= {t for t in targets if t in known and t != name}
    return out


MODULES = {_module(p) for p in SIM.rglob("*.py")}
GRAPH = {_module(p): sim_imports(p) for p in sorted(SIM.rglob("*.py"))}


def find_cycle(graph: dict[str, set[str]]) -> list[str] | None:
    """One import cycle of ``graph`` (module -> modules it imports) as a path, or None."""
    done: set[str] = set()

    def visit(node: str, path: list[str]) -> list[str] | None:
        if node in path:
            return path[path.index(node):] + [node]
        if node in done:
            return None
        for nxt in sorted(graph.get(node, ())):
            cycle = visit(nxt, path + [node])
            if cycle:
                return cycle
        done.add(node)
        return None

    for start in sorted(graph):
        cycle = visit(start, [])
        if cycle:
            return cycle
    return None


def test_the_sim_modules_import_each_other_without_a_cycle():
    cycle = find_cycle(GRAPH)
    assert cycle is None, "import cycle in phd_swarm/sim: " + " -> ".join(cycle)


def test_the_checker_sees_every_form_of_import_and_finds_a_cycle(tmp_path):
    known = {f"{PACKAGE}.a", f"{PACKAGE}.b", f"{PACKAGE}.c", f"{PACKAGE}.presets",
             f"{PACKAGE}.presets.registry"}
    path = SIM / "presets" / "chen.py"   # resolved as phd_swarm.sim.presets.chen
    text = ("from typing import TYPE_CHECKING\n"
            "from phd_swarm.sim import a\n"
            "from .registry import preset\n"
            "import phd_swarm.sim.b\n"
            "if TYPE_CHECKING:\n    from ..c import X\n"
            "def f():\n    from phd_swarm.sim.presets import registry\n")
    assert sim_imports(path, text, known) == {f"{PACKAGE}.a", f"{PACKAGE}.b", f"{PACKAGE}.c",
                                              f"{PACKAGE}.presets",
                                              f"{PACKAGE}.presets.registry"}
    assert find_cycle({"a": {"b"}, "b": {"c"}, "c": {"a"}}) == ["a", "b", "c", "a"]
    assert find_cycle({"a": {"b", "c"}, "b": {"c"}, "c": set()}) is None


def _reach(module: str) -> set[str]:
    """The sim modules ``module`` imports, directly or not."""
    seen, todo = set(), [module]
    while todo:
        m = todo.pop()
        if m not in seen:
            seen.add(m)
            todo += GRAPH.get(m, ())
    return seen - {module}


@pytest.mark.parametrize("high, low", [("targets", "target_kinds"), ("scenario", "targets"),
                                       ("world", "scenario"), ("presets.registry", "scenario")])
def test_the_layers_of_the_simulator_point_down(high, low):
    # The target kinds below the scenario, the scenario below the world and the presets
    # (and, as there is no cycle, never the other way).
    assert f"{PACKAGE}.{low}" in _reach(f"{PACKAGE}.{high}")
