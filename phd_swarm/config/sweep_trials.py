"""A sweep as trials: the validated spec (:class:`SweepSpec`) and each run of it (:class:`Trial`).

:mod:`phd_swarm.config.sweep_spec` reads and checks a spec file into a :class:`SweepSpec`;
the spec lists its trials (team sizes x target counts x grid resolutions x methods x
seeds), each a scenario, a controller, an engine and the way to score it, with the hash
of what determines its result (:mod:`phd_swarm.config.sweep_hash`).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from phd_swarm.config.sweep_hash import (  # noqa: F401  (re-exported)
    _LATER_OPTIONS,
    _plain,
    config_hash,
    controller_name,
    later_options,
    method_system,
    results_revisions,
)
from phd_swarm.core.registry import ROLES
from phd_swarm.core.system import SystemConfig
from phd_swarm.engines import ENGINES as ENGINE_CLASSES
from phd_swarm.sim.presets import PRESETS
from phd_swarm.sim.scenario import Scenario
from phd_swarm.sim.scenario_dict import scenario_from_dict

#: Ways to reduce a trial's per-step OSPA series to one number.
METRICS = ("final", "mean", "median")

#: Engines a trial can run on (:data:`phd_swarm.engines.ENGINES`): ``central``, one filter
#: and partition for the team, several times faster, or ``distributed``, the robots' agents
#: message by message, bit-equal to the ROS stack. Both give the same team PHD and paths up
#: to rounding (test/engines/test_central.py).
ENGINES = tuple(ENGINE_CLASSES)

class SpecError(ValueError):
    """A sweep spec is malformed; the message names the file and the key."""


@dataclass(frozen=True)
class Trial:
    """One run of a sweep: a scenario, a controller and the way to score it.

    Attributes
    ----------
    method : str
        The spec's label of the method (e.g. ``PHD``, ``D``).
    controller : str
        The method's system as text (:func:`controller_name`): the controller, with the
        options and non-default parts the method sets, if any.
    robots, targets : int
        Team size and number of targets drawn (static) or initial (moving) or in total
        (clustered).
    resolution : float
        Grid resolution [m].
    index : int
        Trial number i in 0..trials-1; the seed is ``base_seed + i``.
    seed : int
        Scenario seed.
    scenario : Scenario
        The full scenario of the run.
    metric : str
        One of :data:`METRICS`.
    window : (float, float)
        [start, end] of the mean / median window [s].
    config_hash : str
        Hash of everything the trial's result depends on (scenario, controller, metric,
        window, engine): a stored result is reused only if its hash matches.
    engine : str
        One of :data:`ENGINES`.
    """

    method: str
    controller: str
    robots: int
    targets: int
    resolution: float
    index: int
    seed: int
    scenario: Scenario
    metric: str
    window: tuple[float, float]
    config_hash: str
    engine: str = "central"

    @property
    def key(self) -> str:
        """File-name-safe id of the trial, unique within a sweep."""
        return (f"{self.method}_r{self.robots:03d}_t{self.targets:03d}_"
                f"res{self.resolution:g}_s{self.seed}")

    def cost(self) -> float:
        """Rough relative cost [a.u.], for scheduling the longest first and for the ETA.

        Fitted to engine timings on this project's 2-core machine. Distributed engine:
        time per step grows as about ``robots**1.2``, ~1.7x for Chen's scenario (5 m/s
        robots, clustered targets), ~1.3x at 0.5 m bins and ~6x at 0.1 m bins against 1 m.
        Central engine (2026-12-01): about ``robots**0.7`` (79 steps/s with 50 robots, 52
        with 100), ~1.4x for Chen's scenario, and 1 : 1.4 : 19 at 1 m, 0.5 m and 0.1 m.
        """
        inv_area = min(1.0, self.resolution) ** -2
        kind = 1.7 if self.scenario.targets.kind == "clustered_walk" else 1.0
        if self.engine == "central":
            return self.scenario.steps * self.robots ** 0.7 * (1.0 + 0.18 * inv_area) * kind
        return self.scenario.steps * self.robots ** 1.2 * (1.0 + 0.05 * inv_area) * kind


@dataclass(frozen=True)
class SweepSpec:
    """A validated sweep spec (one form: full or quick).

    Attributes
    ----------
    name : str
        Spec name (the file's stem unless ``name:`` is given).
    path : Path
        The file it came from.
    quick : bool
        True for the ``quick:`` form.
    preset : str
        Scenario preset (:data:`phd_swarm.sim.presets.PRESETS`).
    figure, description : str
        Plot title and free text.
    methods : dict of str to str
        Label -> controller kind, in plotting order.
    robots, targets : tuple of int
        Team sizes, target counts.
    resolutions : tuple of float
        Grid resolutions [m].
    trials, base_seed : int
        Seeds are ``base_seed + i`` for i < trials.
    duration : float
        Run length [s].
    metric : str
        One of :data:`METRICS`.
    window : (float, float)
        Window [s] of the mean / median OSPA (``(0, duration)`` when unset).
    engine : str
        One of :data:`ENGINES`: the engine the trials run on.
    scenario : Mapping
        The ``scenario:`` overrides.
    spec_engine : str
        The engine the spec's form names (``engine:``, default ``central``); ``engine``
        differs from it only when the command line asks for another one.
    base : str
        The spec this one is a variant of (``base:``), or empty.
    """

    name: str
    path: Path
    quick: bool
    preset: str
    figure: str
    description: str
    methods: dict[str, str]
    robots: tuple[int, ...]
    targets: tuple[int, ...]
    resolutions: tuple[float, ...]
    trials: int
    base_seed: int
    duration: float
    metric: str
    window: tuple[float, float]
    scenario: Mapping[str, Any]
    engine: str = "central"
    spec_engine: str = "central"
    base: str = ""

    @property
    def label(self) -> str:
        """The default output directory's name: ``name`` or ``name_quick``.

        ``_<engine>`` is appended only when the trials run on another engine than the
        spec's own (``--engine``), so that their rows never mix with the spec's.
        """
        label = f"{self.name}_quick" if self.quick else self.name
        return label if self.engine == self.spec_engine else f"{label}_{self.engine}"

    @property
    def metric_label(self) -> str:
        """Axis label of the metric, e.g. ``median OSPA over 300-1000 s [m]``."""
        if self.metric == "final":
            return "final OSPA [m]"
        a, b = self.window
        return f"{self.metric} OSPA over {a:g}-{b:g} s [m]"

    def base_scenario(self) -> Scenario:
        """The preset with the ``scenario:`` overrides and the duration applied."""
        doc = scenario_doc(self.preset, self.scenario, self.path.parent)
        return scenario_from_dict({**doc, "duration": self.duration}, where=str(self.path),
                                  base_dir=self.path.parent)

    def trials_list(self) -> list[Trial]:
        """Every trial of the sweep, in a fixed order (seed, robots, targets, res, method)."""
        base = self.base_scenario()
        out = []
        for i in range(self.trials):
            seed = self.base_seed + i
            for robots in self.robots:
                for targets in self.targets:
                    for res in self.resolutions:
                        sc = base.with_overrides(robots=robots, resolution=res, seed=seed,
                                                 targets=_with_count(base, targets).targets)
                        for label, kind in self.methods.items():
                            msc = sc.with_system(**method_system(kind))
                            out.append(Trial(label, kind, robots, targets, res, i, seed, msc,
                                             self.metric, self.window,
                                             config_hash(msc, kind, self.metric,
                                                         self.window, self.engine),
                                             self.engine))
        return out

    def to_dict(self) -> dict[str, Any]:
        """The resolved form as plain values (written next to the results)."""
        return {"name": self.name, "file": str(self.path), "quick": self.quick,
                "preset": self.preset, "figure": self.figure,
                "description": self.description, "methods": dict(self.methods),
                "robots": list(self.robots), "targets": list(self.targets),
                "resolutions": list(self.resolutions), "trials": self.trials,
                "base_seed": self.base_seed, "duration": self.duration,
                "metric": self.metric, "window": list(self.window),
                "engine": self.engine, "scenario": _plain(self.scenario),
                **({"base": self.base} if self.base else {})}


def scenario_doc(preset: str, scen: Mapping[str, Any], base_dir: Path) -> dict[str, Any]:
    """The ``scenario_from_dict`` mapping of a spec's preset and ``scenario:`` overrides.

    ``scenario.system`` replaces only what it names, as a method's block does: the
    preset's other parts stay, and so do its options that the parts then take, so a spec
    (or a variant) may set one option of, e.g., Sung & Tokekar's system without restating
    it.
    """
    doc = {"preset": preset, **scen}
    block = scen.get("system")
    if not isinstance(block, Mapping):
        return doc
    preset_system = PRESETS[preset]().system
    system = SystemConfig.from_dict(
        {**{r: getattr(preset_system, r) for r in ROLES},
         "plugins": list(preset_system.plugins), **block}, "scenario.system", base_dir)
    given = dict(block.get("options") or {})
    taken = dict(system.options)
    doc["system"] = {
        **{r: getattr(system, r) for r in ROLES}, "plugins": list(system.plugins),
        "options": {**{k: v for k, v in preset_system.options if k in taken},
                    **{k: taken[k] for k in given}}}
    return doc


def _with_count(base: Scenario, count: int) -> Scenario:
    """``base`` with ``count`` targets; clustered targets are split evenly over clusters."""
    t = base.targets
    if t.kind == "clustered_walk" and t.per_cluster:
        n = len(t.per_cluster)
        per = tuple(count // n + (1 if i < count % n else 0) for i in range(n))
        return base.with_overrides(targets=dataclasses.replace(t, count=count,
                                                               per_cluster=per))
    return base.with_overrides(targets=dataclasses.replace(t, count=count))


