"""Sweep specifications: which trials a parameter sweep runs and how each is scored.

A spec (``config/sweeps/*.yaml``) describes one experiment of the papers as a grid of
trials: team sizes x target counts x grid resolutions x methods x seeds, over a scenario
preset of :mod:`phd_swarm.sim.scenario`::

    preset: dames_static          # dames_static | dames_moving | chen_clustered
    figure: Dames (2020) Fig. 2   # title of the plots
    methods: {PHD: phd, uniform: uniform}   # label -> controller, or a system block
    robots: [10, 20, 30]          # team sizes
    targets: [10, 30, 50]         # optional: target counts (default: the preset's)
    resolutions: [1.0]            # optional: grid resolutions [m] (default: the preset's)
    trials: 10                    # trial i uses seed base_seed + i for every cell
    base_seed: 0
    duration: 250.0               # optional [s] (default: the preset's)
    metric: final                 # final | mean | median OSPA
    window: [250.0, 500.0]        # [s], for mean / median: steps with start <= k dt <= end
    engine: central               # optional: central (default) | distributed
    scenario: {...}               # optional: other overrides (scenario_from_dict keys)
    quick: {robots: [10], trials: 2}   # overrides of the keys above for --quick

A variant of a spec names it and gives only what it changes::

    base: sung_planners           # a spec of the same folder
    scenario: {system: {options: {merge_metric: candidate}}}   # merged into the base's
    figure: Sung & Tokekar (2022) Table V, merging in each candidate's metric

It is the base with those keys replaced: mappings under ``scenario`` merged key by key,
every other key (``methods``, ``quick``...) replaced whole. Its name, and so its output
folder, is its own file's stem. ``scenario.system`` replaces only the parts and options
it names of the preset's system.

Common random numbers: every method, team size and resolution of trial i uses the same
scenario seed, hence the same targets (the world draws them from their own stream,
:mod:`phd_swarm.sim.world`), so method comparisons are paired, as in Dames Sec. IV ("the
same collection of starting locations for the robots and targets").

Every error names the file and the key (``config/sweeps/x.yaml: quick.robots[1]: expected
an integer >= 1, got 'ten'``) and is raised before any trial runs.
"""

from __future__ import annotations

import dataclasses
import os
import re
from collections.abc import Mapping
from functools import partial
from pathlib import Path
from typing import Any

from phd_swarm.config import read_yaml
from phd_swarm.config.sweep_hash import (  # noqa: F401  (re-exported)
    _LATER_OPTIONS,
    _plain,
    config_hash,
    controller_name,
    later_options,
    method_system,
    results_revisions,
)
from phd_swarm.core.params import (
    Item,
    expect_int,
    expect_list,
    expect_mapping,
    expect_number,
    expect_str,
)
from phd_swarm.core.registry import ROLES
from phd_swarm.core.system import SystemConfig
from phd_swarm.sim.presets import PRESETS
from phd_swarm.sim.scenario_dict import preset_name, scenario_from_dict

from .sweep_trials import (  # noqa: F401  (re-exported)
    ENGINES,
    METRICS,
    SpecError,
    SweepSpec,
    Trial,
    _with_count,
    scenario_doc,
)

#: Keys of a spec that ``quick:`` may override.
OVERRIDABLE = ("figure", "description", "methods", "robots", "targets", "resolutions",
               "trials", "base_seed", "duration", "metric", "window", "engine", "scenario")

#: Top-level keys of a spec.
TOP_KEYS = ("base", "preset", "name", *OVERRIDABLE, "quick")

#: Scenario fields a sweep sets itself (through its axes), not allowed under ``scenario:``.
AXIS_FIELDS = ("preset", "robots", "seed", "resolution", "duration")

_LABEL = re.compile(r"^[A-Za-z0-9_]+$")



# ------------------------------------------------------------------------ finding a spec
def sweeps_dir() -> Path:
    """``config/sweeps`` of the repository (``$PHD_SWARM_ROOT`` if set)."""
    root = os.environ.get("PHD_SWARM_ROOT")
    base = Path(root) if root else Path(__file__).resolve().parents[2]
    return base / "config" / "sweeps"


def find_spec(name_or_path: str) -> Path:
    """The spec file: an existing path, or a name under :func:`sweeps_dir`.

    Raises
    ------
    SpecError
        If neither exists (the message lists the specs available).
    """
    p = Path(name_or_path)
    if p.suffix in (".yaml", ".yml") or os.sep in name_or_path:
        if p.is_file():
            return p
        raise SpecError(f"{name_or_path}: no such spec file")
    d = sweeps_dir()
    for ext in (".yaml", ".yml"):
        if (d / f"{name_or_path}{ext}").is_file():
            return d / f"{name_or_path}{ext}"
    known = sorted(q.stem for q in d.glob("*.yaml")) if d.is_dir() else []
    raise SpecError(f"{name_or_path}: unknown sweep spec; expected a path to a YAML file or "
                    f"one of {known} (in {d})")


# -------------------------------------------------------------------------- validation
# Each check takes (value, key path) and returns the value parsed or raises ValueError
# naming the key path; load_spec puts the file in front.

def _methods(value: Any, path: str, base: SystemConfig | None = None) -> dict[str, str]:
    """Label -> method text (:func:`controller_name`), each checked against the registry.

    A method is a controller name (``phd``) or a system block (``{controller: chen_o,
    options: {cumulative_mode: laplace}}``, :mod:`phd_swarm.core.system`); the older form
    ``{kind: chen_o, cumulative_mode: laplace}`` is read as the same.
    """
    m = expect_mapping(value, path)
    if not m:
        raise ValueError(f"{path}: expected at least one method (label: controller)")
    out = {}
    for label, method in m.items():
        name = f"{path}.{label}"
        if not isinstance(label, str) or not _LABEL.match(label):
            raise ValueError(f"{name}: a method label must be letters, digits and underscores")
        legacy = isinstance(method, Mapping) and "kind" in method
        if isinstance(method, str):
            block: dict[str, Any] = {"controller": method}
        elif isinstance(method, Mapping) and "kind" in method:
            opts = dict(method)
            block = {"controller": opts.pop("kind"), "options": opts}
        elif isinstance(method, Mapping):
            block = dict(method)
            if "plugins" in block:
                raise ValueError(f"{name}.plugins: list plugins once, under "
                                 f"scenario.system.plugins")
            if "controller" not in block:
                raise ValueError(f"{name}.controller: missing; expected a controller")
        else:
            raise ValueError(f"{name}: expected a controller or a system block, got "
                             f"{method!r}")
        try:
            if base is None or base == SystemConfig():
                system = SystemConfig.from_dict(block, "system")
            else:
                # The preset's other parts: the method's block replaces only what it names,
                # and its options are checked against the parts it ends up with.
                roles = {r: block[r] for r in ROLES if r in block}
                expect_mapping(block, "system", allowed=(*ROLES, "options"))
                parts = base.with_parts(**roles)
                given = expect_mapping(block.get("options") or {}, "system.options")
                system = SystemConfig(**{r: getattr(parts, r) for r in ROLES},
                                      options=tuple({**dict(parts.options),
                                                     **given}.items()),
                                      plugins=parts.plugins)
        except ValueError as exc:
            sub, _, msg = str(exc).removeprefix("system.").partition(": ")
            if legacy:
                sub = sub.removeprefix("options.").replace("controller", "kind")
            if isinstance(method, str) and sub == "controller":
                raise ValueError(f"{name}: {msg}") from None
            raise ValueError(f"{name}.{sub}: {msg}") from None
        parts = {r: block[r] for r in ROLES if r in block and r != "controller"}
        out[label] = controller_name(system.controller,
                                     {**parts, **dict(block.get("options") or {})})
    return out


def _window(value: Any, path: str) -> tuple[float, float]:
    w = _axis(partial(expect_number, low=0.0))(value, path)
    if len(w) != 2 or not w[1] > w[0]:
        raise ValueError(f"{path}: expected [start, end] in seconds with end > start, "
                         f"got {list(value)}")
    return w[0], w[1]


def _scenario(value: Any, path: str) -> dict[str, Any]:
    sc = expect_mapping(value, path)
    for name in sc:
        if name in AXIS_FIELDS:
            raise ValueError(f"{path}.{name}: set by the sweep; use the top-level keys "
                             f"robots / resolutions / duration / base_seed instead")
    if isinstance(sc.get("targets"), Mapping) and "count" in sc["targets"]:
        raise ValueError(f"{path}.targets.count: set by the sweep; use the top-level key "
                         f"targets instead")
    return dict(sc)


def _axis(item: Item) -> Item:
    """A check of a non-empty list of distinct values, each checked by ``item``."""
    return partial(expect_list, item=item, nonempty=True, distinct=True)


_positive = partial(expect_number, low=0.0, strict=True)

#: Key of a spec (or of its ``quick:`` block) -> its check.
_CHECKS: dict[str, Item] = {
    "figure": expect_str, "description": expect_str, "methods": _methods,
    "robots": _axis(partial(expect_int, low=1)), "targets": _axis(partial(expect_int, low=0)),
    "resolutions": _axis(_positive), "trials": partial(expect_int, low=1),
    "base_seed": partial(expect_int, low=0), "duration": _positive,
    "metric": partial(expect_str, choices=METRICS), "window": _window,
    "engine": partial(expect_str, choices=ENGINES), "scenario": _scenario}


def _form(doc: Mapping[str, Any], prefix: str, preset: str | None = None) -> dict[str, Any]:
    """The overridable keys present in ``doc``, checked and parsed.

    Methods are checked against the system of ``preset``: a method names the parts it
    changes, the preset's others stay (Dames' system when no preset is given).
    """
    base = PRESETS[preset]().system if preset is not None else SystemConfig()
    return {k: (_methods(v, f"{prefix}{k}", base) if k == "methods"
                else _CHECKS[k](v, f"{prefix}{k}"))
            for k, v in doc.items() if k in _CHECKS}


def load_spec(path: str | Path, quick: bool = False, engine: str | None = None) -> SweepSpec:
    """Read and validate a spec file; ``quick`` applies its ``quick:`` block.

    ``engine`` (one of :data:`ENGINES`), when given, replaces the spec's ``engine``.
    A spec with ``base:`` is read as its base (itself a valid spec of the same folder) with
    the spec's keys replaced (:func:`with_base`).

    Every trial's scenario is built once here, for the full and the quick form, so a bad
    value fails before anything runs.

    Raises
    ------
    SpecError
        Unreadable file, YAML error, unknown key, wrong type, empty list, unknown preset or
        method, a window outside the run, a scenario the presets reject, or an unknown or
        circular base; the message names the file and the key.
    """
    path = Path(path)
    if engine is not None and engine not in ENGINES:
        raise SpecError(f"engine: expected one of {list(ENGINES)}, got {engine!r}")
    doc, base = with_base(path)
    if base is not None:
        load_spec(base)  # a base is a spec in its own right; its errors name its file
    try:
        return _load(path, doc, quick, engine, base.stem if base else "")
    except SpecError:
        raise
    except ValueError as exc:
        raise SpecError(f"{path}: {exc}") from None


def with_base(path: Path, _chain: tuple[Path, ...] = ()) -> tuple[Any, Path | None]:
    """The spec document of ``path`` with its ``base:`` resolved, and the base's file.

    ``base: NAME`` names a spec of the same folder (``NAME.yaml`` or ``NAME.yml``), itself
    possibly a variant. The document is the base's (its ``name:`` aside) with the keys of
    ``path`` replacing it; mappings under ``scenario`` are merged key by key.

    Raises
    ------
    SpecError
        Unreadable file, or a base that is not a name, is not in the folder, or leads back
        to ``path`` (a cycle); the message names the file and the key.
    """
    try:
        doc = read_yaml(path, "sweep spec")
    except ValueError as exc:
        raise SpecError(str(exc)) from None
    doc = {} if doc is None else doc
    if not isinstance(doc, Mapping) or "base" not in doc:
        return doc, None
    name = doc["base"]
    folder = path.parent
    if not isinstance(name, str) or not _LABEL.match(name):
        raise SpecError(f"{path}: base: expected the name of a spec in the same folder "
                        f"({folder}), got {name!r}")
    found = [folder / f"{name}{ext}" for ext in (".yaml", ".yml")
             if (folder / f"{name}{ext}").is_file()]
    if not found:
        known = sorted({q.stem for q in folder.glob("*.y*ml")} - {path.stem})
        raise SpecError(f"{path}: base: unknown spec {name!r}; expected one of {known} "
                        f"(in {folder})")
    chain = (*_chain, path)
    if any(found[0].resolve() == p.resolve() for p in chain):
        cycle = " -> ".join(p.stem for p in (*chain, found[0]))
        raise SpecError(f"{path}: base: {name!r} makes a cycle ({cycle})")
    base_doc, _ = with_base(found[0], chain)
    if not isinstance(base_doc, Mapping):
        raise SpecError(f"{found[0]}: expected a mapping of spec keys")
    merged = {k: v for k, v in base_doc.items() if k != "name"}
    for key, value in doc.items():
        if key != "base":
            merged[key] = (_merged(merged[key], value) if key == "scenario" and key in merged
                           else value)
    return merged, found[0]


def _merged(base: Any, over: Any) -> Any:
    """``over`` merged into ``base``: mappings key by key, anything else replaced."""
    if isinstance(base, Mapping) and isinstance(over, Mapping):
        return {**base, **{k: _merged(base[k], v) if k in base else v
                           for k, v in over.items()}}
    return over


def _load(path: Path, doc: Any, quick: bool, engine: str | None,
          base: str = "") -> SweepSpec:
    """:func:`load_spec` of a parsed document; errors name the key, not the file."""
    expect_mapping(doc, "", TOP_KEYS)
    preset = preset_name(doc)
    name = expect_str(doc.get("name", path.stem), "name")
    if not _LABEL.match(name):
        raise ValueError("name: must be letters, digits and underscores")
    _load_spec_plugins(doc, path.parent)
    full = _form(doc, "", preset)
    for key in ("methods", "robots", "trials"):
        if key not in full:
            raise ValueError(f"{key}: missing")
    form = dict(full)
    qkeys: set[str] = set()
    if "quick" in doc:
        qform = _form(expect_mapping(doc["quick"], "quick", OVERRIDABLE), "quick.", preset)
        if quick:
            if "scenario" in qform:
                qform["scenario"] = {**form.get("scenario", {}), **qform["scenario"]}
            form.update(qform)
            qkeys = set(qform)
    elif quick:
        raise ValueError("quick: missing: this spec has no quick form")
    if "quick" in doc and not quick:
        # Check the quick form too, so a spec is known good in both forms.
        _load(path, doc, True, None)
    spec_engine = form.get("engine", "central")
    if engine is not None:
        form["engine"] = engine
    return dataclasses.replace(_resolve(name, path, quick, preset, form, qkeys),
                               spec_engine=spec_engine, base=base)


def _load_spec_plugins(doc: Mapping[str, Any], base: Path) -> None:
    """Import ``scenario.system.plugins`` first, so that methods may name their parts."""
    scen = doc.get("scenario")
    system = scen.get("system") if isinstance(scen, Mapping) else None
    if isinstance(system, Mapping) and "plugins" in system:
        SystemConfig.from_dict({"plugins": system["plugins"]}, "scenario.system", base)


def _resolve(name: str, path: Path, quick: bool, preset: str, form: dict[str, Any],
             qkeys: set[str]) -> SweepSpec:
    def key(k: str) -> str:
        return f"quick.{k}" if k in qkeys else k

    base_sc = PRESETS[preset]()
    scen = form.get("scenario", {})
    base = scenario_from_dict(scenario_doc(preset, scen, path.parent), where="scenario",
                              base_dir=path.parent)
    duration = form.get("duration", base.duration)
    try:
        base = base.with_overrides(duration=duration)
    except ValueError as exc:
        raise ValueError(f"{key('duration')}: {exc}") from None
    targets = form.get("targets", (base.targets.count,))
    resolutions = form.get("resolutions", (base_sc.resolution,))
    for i, r in enumerate(resolutions):
        try:
            base.with_overrides(resolution=r)
        except ValueError as exc:
            raise ValueError(f"{key('resolutions')}[{i}]: {exc}") from None
    for i, n in enumerate(targets):
        try:
            _with_count(base, n)
        except ValueError as exc:
            raise ValueError(f"{key('targets')}[{i}]: {exc}") from None
    metric = form.get("metric", "final")
    window = form.get("window")
    if window is None:
        if metric != "final":
            raise ValueError(f"{key('window')}: required for metric {metric!r}")
        window = (0.0, float(duration))
    steps = base.steps
    times = [k * base.dt for k in range(steps)]
    if not any(window[0] <= t <= window[1] for t in times):
        raise ValueError(f"{key('window')}: [{window[0]:g}, {window[1]:g}] s holds no step "
                         f"of a {duration:g} s run")
    spec = SweepSpec(
        name=name, path=path, quick=quick, preset=preset,
        figure=form.get("figure", name), description=form.get("description", ""),
        methods=form["methods"], robots=form["robots"], targets=tuple(targets),
        resolutions=tuple(float(r) for r in resolutions), trials=form["trials"],
        base_seed=form.get("base_seed", 0), duration=float(duration), metric=metric,
        window=(float(window[0]), float(window[1])), scenario=scen,
        engine=form.get("engine", "central"))
    spec.trials_list()
    return spec


__all__ = ["ENGINES", "METRICS", "SpecError", "SweepSpec", "Trial", "config_hash", "find_spec",
           "later_options", "load_spec", "results_revisions", "sweeps_dir", "with_base"]
