"""Render ``docs/topics.md`` and ``docs/parameters.md`` from the code's own tables.

Usage::

    python -m phd_swarm.tools.gen_docs            # (re)write both files
    python -m phd_swarm.tools.gen_docs --check    # exit 1 with a diff summary if stale
    python -m phd_swarm.tools.gen_docs --plugins my_parts.py --out DIR
                                                  # topics.md and parameters.md of the
                                                  # built-in parts and a plugin's, in DIR

The tables come from :mod:`phd_swarm.nodes.topics` (names, types, QoS names, writers,
rates), :mod:`phd_swarm.nodes.qos` (what each QoS name means for writer and reader),
:mod:`phd_swarm.config.node_params` (node parameters), the registered scenario presets
(:mod:`phd_swarm.sim.presets`, through :func:`phd_swarm.config.flatten`, exactly the
``scenario.*`` parameters the nodes declare) and target kinds
(:mod:`phd_swarm.sim.target_kinds`: which kind reads which ``targets.*`` field). What the
code cannot say, one line per topic and per scenario key, is kept in
:mod:`phd_swarm.tools.doc_texts` (:data:`DESCRIPTIONS`, :data:`SCENARIO_MEANINGS`);
rendering fails if one is missing, or if a ``targets.*`` line names other kinds than those
that read the field, so a new topic, field or kind cannot go undocumented, and the test
suite runs ``--check`` so the files never go stale.

The package's docs show its own parts only. A user who adds a system from outside the
package (``scenario.system.plugins``) gets the same two files with the plugin's parts in
them, their declared outputs in the topic table and their options in the parameter
tables, with ``--plugins`` (modules or ``.py`` files, as ``system.plugins`` takes them)
and ``--out``.
"""

from __future__ import annotations

import argparse
import difflib
import os
import re
import sys
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

from rclpy.qos import HistoryPolicy, QoSProfile

from phd_swarm.config import flatten, scenario_to_dict
from phd_swarm.core import registry
from phd_swarm.core.params import ParamSpec
from phd_swarm.nodes import qos, topics
from phd_swarm.sim.presets import PRESETS
from phd_swarm.sim.target_kinds import lookup
from phd_swarm.sim.targets import TARGET_KINDS
from phd_swarm.tools.doc_texts import (  # noqa: F401  (re-exported for tests)
    _GENERATED,
    DESCRIPTIONS,
    INBOX_KINDS,
    NODE_TABLES,
    PARAMETERS_TEMPLATE,
    ROBOT_PATTERN,
    SCENARIO_MEANINGS,
    TOPICS_TEMPLATE,
)


# ---------------------------------------------------------------------------- helpers
def _cell(text: Any) -> str:
    """Text safe inside a Markdown table cell."""
    return str(text).replace("|", "\\|").replace("\n", " ")


def _table(header: Sequence[str], rows: Sequence[Sequence[Any]]) -> str:
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    lines += ["| " + " | ".join(_cell(c) for c in row) + " |" for row in rows]
    return "\n".join(lines)


def _value(value: Any) -> str:
    """A parameter value as written in a YAML parameter file."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, str):
        return f"'{value}'" if value == "" else value
    if isinstance(value, (list, tuple)):
        return "[" + ", ".join(_value(v) for v in value) + "]"
    return repr(value)


def _missing(what: str, keys: set[str], table: str) -> None:
    if keys:
        raise ValueError(f"{what} without a line in phd_swarm/tools/gen_docs.py {table}: "
                         f"{sorted(keys)}")


# ----------------------------------------------------------------------------- topics
def _documented_parts(plugins: Sequence[str] = ()) -> list[tuple[str, str, Any]]:
    """(role, name, part) of every built-in part, and of the parts ``plugins`` register.

    ``plugins``: modules or ``.py`` files (as ``system.plugins`` lists them), imported here;
    a plugin loaded into this process by other means (a test, a sweep) is not documented.
    """
    registry.load_plugins(plugins)
    # A part belongs to the module that defines its make (as the registry tells owners).
    modules = {registry.plugin_module_name(p) if p.endswith(".py") or "/" in p else p
               for p in plugins}
    out = []
    for role in registry.ROLES:
        for name in registry.names(role):
            part = registry.lookup(role, name)
            module = part.make.__module__
            if module.startswith("phd_swarm.") or module in modules:
                out.append((role, name, part))
    return out


def documented_topics(plugins: Sequence[str] = ()
                      ) -> list[tuple[str, tuple[str, str, str, str], str]]:
    """Every topic as shown in docs/topics.md: name, (type, QoS name, writer, rate), text.

    Team topics first, by their absolute names, then the robot topics as
    ``/robot_<id>/<relative>``: those of every robot, then the outputs the registered parts
    declare (:mod:`phd_swarm.core.outputs`), one row per declaration with the parts that
    make it: the built-in parts and those ``plugins`` register (:func:`_documented_parts`).
    """
    team = [(name, spec, DESCRIPTIONS.get(name, "")) for name, spec in topics.TEAM_TOPICS.items()]
    own = [(ROBOT_PATTERN.format(rel), spec, DESCRIPTIONS.get(ROBOT_PATTERN.format(rel), ""))
           for rel, spec in topics.ROBOT_TOPICS.items()]
    by: dict[Any, dict[str, list[str]]] = {}
    for role, name, part in _documented_parts(plugins):
        for out in part.outputs:
            by.setdefault(out, {}).setdefault(role, []).append(f"`{name}`")

    def makers(roles: dict[str, list[str]]) -> str:
        return "; ".join(f"{role}{'s' if len(n) > 1 else ''} {', '.join(n)}"
                         for role, n in roles.items())

    declared = [(ROBOT_PATTERN.format(o.topic),
                 (o.type, o.qos, "robot", f"{topics.output_rate(o)} ({makers(roles)})"),
                 o.description) for o, roles in sorted(by.items(), key=lambda i: i[0].topic)]
    return team + own[:-1] + declared + own[-1:]


def _history(p: QoSProfile) -> str:
    return "keep all" if p.history == HistoryPolicy.KEEP_ALL else f"depth {p.depth}"


def _depths(writer: QoSProfile, reader: QoSProfile) -> str:
    if _history(writer) == _history(reader):
        return _history(writer)
    return f"{_history(writer)} (writer) / {_history(reader)} (reader)"


def qos_summary(name: str) -> str:
    """One-line meaning of the QoS named ``name`` (a key of :data:`qos.BY_NAME`).

    E.g. ``reliable, transient local, depth 16 (writer) / 1000 (reader)``.
    """
    writer, reader = qos.BY_NAME[name]
    if (writer.reliability, writer.durability) != (reader.reliability, reader.durability):
        return (f"writer {_policy(writer)}, {_depths(writer, writer)}; reader "
                f"{_policy(reader)}, {_depths(reader, reader)}")
    return f"{_policy(writer)}, {_depths(writer, reader)}"


def _policy(p: QoSProfile) -> str:
    return (f"{p.reliability.name.lower().replace('_', ' ')}, "
            f"{p.durability.name.lower().replace('_', ' ')}")


def _plugin_sources(plugins: Sequence[str]) -> str:
    """What the generated line adds for ``plugins`` (nothing without)."""
    return f" and the plugins {', '.join(plugins)}" if plugins else ""


def render_topics(plugins: Sequence[str] = ()) -> str:
    """The text of docs/topics.md; with ``plugins``, their parts' outputs too."""
    shown = documented_topics(plugins)
    _missing("topics", {n for n, _, text in shown if not text}, "DESCRIPTIONS")
    _missing("inbox kinds", set(topics.INBOX) - set(INBOX_KINDS), "INBOX_KINDS")
    header = ("topic", "type", "QoS", "writer", "rate", "description")

    def rows(names: list[tuple[str, tuple[str, str, str, str], str]]) -> list[list[str]]:
        return [[f"`{name}`", f"`{typ}`", f"`{q}`: {qos_summary(q)}", writer, rate, text]
                for name, (typ, q, writer, rate), text in names]

    n_team = len(topics.TEAM_TOPICS)
    used = {q for _, (_, q, _, _), _ in shown}
    qos_rows = []
    for name, (writer, reader) in qos.BY_NAME.items():
        qos_rows.append([f"`{name}`", _policy(writer), writer.depth, _policy(reader),
                         reader.depth, "yes" if name in used else "no"])
    qos_table = _table(("name", "writer", "writer depth", "reader", "reader depth",
                        "used by a topic"), qos_rows)
    return TOPICS_TEMPLATE.format(
        generated=_GENERATED.format(
            sources="phd_swarm/nodes/topics.py, qos.py and the parts' declared outputs"
                    + _plugin_sources(plugins)),
        team_table=_table(header, rows(shown[:n_team])),
        robot_table=_table(header, rows(shown[n_team:])),
        inbox_table=_table(("kind", "type", "carries"),
                           [[f"`{k}`", f"`{topics.INBOX[k]}`", text]
                            for k, text in INBOX_KINDS.items()]),
        qos_table=qos_table)


# ------------------------------------------------------------------------- parameters
_ROS_TYPE = {bool: "bool", int: "integer", float: "double", str: "string"}


def _range(spec: ParamSpec) -> str:
    if spec.choices:
        return "one of " + ", ".join(spec.choices)
    if spec.low is not None and spec.high is not None:
        return f"[{_value(spec.default.__class__(spec.low))}, " \
               f"{_value(spec.default.__class__(spec.high))}]"
    if spec.low is not None:
        return f">= {_value(spec.low)}"
    if spec.high is not None:
        return f"<= {_value(spec.high)}"
    return ""


def scenario_defaults() -> dict[str, dict[str, Any]]:
    """Preset name -> its flattened scenario parameters (keys without ``scenario.``)."""
    return {name: flatten(scenario_to_dict(make())) for name, make in PRESETS.items()}


def _kinds_using(key: str, meaning: str) -> set[str] | None:
    """Target kinds that read a ``targets.*`` field (None: not a kind's field, every preset).

    The kinds' own declarations (:attr:`~phd_swarm.sim.target_kinds.TargetKind.fields`);
    the meaning must name the same kinds in its clauses (``"dames_walk: ..."``,
    ``"static: ...; dames_walk: ..."``), else ValueError.
    """
    if not key.startswith("targets.") or key == "targets.kind":
        return None
    field = key.removeprefix("targets.")
    kinds = {name for name in TARGET_KINDS if field in lookup(name).fields}
    named = set(re.findall(r"(?:^|; )(\w+): ", meaning)) & set(TARGET_KINDS)
    if named != kinds:
        raise ValueError(f"SCENARIO_MEANINGS[{key!r}] in phd_swarm/tools/doc_texts.py names "
                         f"the kinds {sorted(named)}, but {sorted(kinds)} read the field")
    return kinds


def render_parameters(plugins: Sequence[str] = ()) -> str:
    """The text of docs/parameters.md; with ``plugins``, their parts and options too."""
    tables = []
    for heading, block, specs in NODE_TABLES:
        rows = [[f"`{s.name}`", _ROS_TYPE[type(s.default)], f"`{_value(s.default)}`",
                 _range(s), "yes" if s.read_only else "no", s.description] for s in specs]
        tables.append(f"### {heading}\n\nConfig-file block `{block}`.\n\n"
                      + _table(("name", "type", "default", "range", "read-only",
                                "description"), rows))

    defaults = scenario_defaults()
    # A preset's part options are listed with the parts (the options table below).
    keys = {k for flat in defaults.values() for k in flat if not k.startswith("system.options.")}
    _missing("scenario keys", keys - set(SCENARIO_MEANINGS), "SCENARIO_MEANINGS")
    rows = []
    for key, meaning in SCENARIO_MEANINGS.items():
        if key not in keys:
            continue
        kinds = _kinds_using(key, meaning)
        values = [f"`{_value(flat[key])}`"
                  if key in flat and (kinds is None or flat["targets.kind"] in kinds) else "-"
                  for flat in defaults.values()]
        rows.append([f"`scenario.{key}`", *values, meaning])
    scenario_table = _table(("parameter", *defaults, "meaning"), rows)
    # The package's own parts (and those of the plugins asked for): a plugin a test or
    # sweep has loaded into this process is not part of the docs.
    parts = [part for _, _, part in _documented_parts(plugins)]
    parts_table = _table(("role", "name", "options", "provides", "requires", "description"),
                         [[p.role, f"`{p.name}`",
                           ", ".join(f"`{o.name}`" for o in p.options) or "-",
                           ", ".join(sorted(p.provides)) or "-",
                           ", ".join(sorted(p.requires)) or "-", p.description]
                          for p in parts])
    options = {o.name: o for p in parts for o in p.options}
    options_table = _table(("option", "type", "default", "range", "description"),
                           [[f"`scenario.system.options.{o.name}`", _ROS_TYPE[type(o.default)],
                             f"`{_value(o.default)}`", _range(o), o.description]
                            for o in sorted(options.values(), key=lambda o: o.name)])
    return PARAMETERS_TEMPLATE.format(
        generated=_GENERATED.format(sources="phd_swarm/config/node_params.py, the scenario "
                                            "presets and the registry"
                                            + _plugin_sources(plugins)),
        node_tables="\n\n".join(tables), scenario_table=scenario_table,
        parts_table=parts_table, options_table=options_table)


# ------------------------------------------------------------------------------ files
#: Generated files, relative to the repository root, and their renderers.
FILES: dict[str, Callable[..., str]] = {
    "docs/topics.md": render_topics,
    "docs/parameters.md": render_parameters,
}


def generate() -> dict[str, str]:
    """Relative path -> the text it should have."""
    return {path: render() for path, render in FILES.items()}


def write_with_plugins(out: Path, plugins: Sequence[str]) -> list[Path]:
    """Write topics.md and parameters.md of the built-in parts and ``plugins`` into ``out``.

    ``plugins``: modules or ``.py`` files that register parts (as ``system.plugins``).
    Returns the files written.
    """
    out.mkdir(parents=True, exist_ok=True)
    written = []
    for path, render in FILES.items():
        target = out / Path(path).name
        target.write_text(render(plugins))
        written.append(target)
    return written


def check(root: Path, max_lines: int = 40) -> list[str]:
    """Differences between the files under ``root`` and what would be generated.

    Returns
    -------
    list of str
        Empty when every file is up to date; else, per stale file, a summary line and the
        first ``max_lines`` lines of a unified diff (file on disk -> generated).
    """
    out: list[str] = []
    for path, text in generate().items():
        target = root / path
        current = target.read_text() if target.exists() else None
        if current == text:
            continue
        if current is None:
            out.append(f"{path}: missing")
            continue
        diff = list(difflib.unified_diff(current.splitlines(), text.splitlines(),
                                         f"{path} (on disk)", f"{path} (generated)",
                                         lineterm=""))
        changed = sum(1 for d in diff if d[:1] in "+-" and d[:3] not in ("+++", "---"))
        out.append(f"{path}: out of date ({changed} lines differ)")
        out.extend(diff[:max_lines])
        if len(diff) > max_lines:
            out.append(f"... {len(diff) - max_lines} more diff lines")
    return out


def write(root: Path) -> list[Path]:
    """Write every generated file under ``root``; returns the files that changed."""
    changed = []
    for path, text in generate().items():
        target = root / path
        if not target.exists() or target.read_text() != text:
            target.parent.mkdir(parents=True, exist_ok=True)
            target.write_text(text)
            changed.append(target)
    return changed


def main(argv: Sequence[str] | None = None) -> int:
    """Command line; returns the exit code (1 if ``--check`` finds stale files)."""
    parser = argparse.ArgumentParser(prog="python -m phd_swarm.tools.gen_docs",
                                     description=__doc__.split("\n\n")[0])
    parser.add_argument("--check", action="store_true",
                        help="do not write; exit 1 and show a diff if a file is stale")
    parser.add_argument("--root", type=Path,
                        default=Path(os.environ.get("PHD_SWARM_ROOT", ".")),
                        help="repository root (default: $PHD_SWARM_ROOT, set by "
                             "scripts/env.sh, else the current directory)")
    parser.add_argument("--plugins", nargs="+", default=[], metavar="PLUGIN",
                        help="also document the parts these modules or .py files register "
                             "(with --out; the package's docs show its own parts only)")
    parser.add_argument("--out", type=Path,
                        help="with --plugins: the directory to write topics.md and "
                             "parameters.md into")
    args = parser.parse_args(argv)
    if args.plugins or args.out is not None:
        if args.check or not args.plugins or args.out is None:
            parser.error("--plugins and --out go together, without --check (docs/ shows "
                         "the package's own parts)")
        try:
            written = write_with_plugins(args.out, args.plugins)
        except registry.RegistryError as exc:
            parser.error(str(exc))
        print("\n".join(f"wrote {p}" for p in written))
        return 0
    if args.check:
        problems = check(args.root)
        if problems:
            print("\n".join(problems))
            print("run `python -m phd_swarm.tools.gen_docs` to regenerate", file=sys.stderr)
            return 1
        print(f"{', '.join(FILES)}: up to date")
        return 0
    changed = write(args.root)
    print("\n".join(f"wrote {p}" for p in changed) or "nothing to do: up to date")
    return 0


if __name__ == "__main__":
    sys.exit(main())
