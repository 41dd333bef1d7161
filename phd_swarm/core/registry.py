"""Names -> system parts: the one table the robot node, the engines and the sweeps read.

A system (one paper's algorithm) is a choice of four roles, named in the scenario config
(``scenario.system``, :class:`phd_swarm.core.system.SystemConfig`):

- **sensor**: field-of-view shape, detection, measurement and clutter models, shared by
  the world (to simulate scans) and the estimators (to filter them);
- **estimator**: the robot's belief about the targets (predict, update with a scan taken
  from a sensor pose, estimates);
- **exchange**: the transport-agnostic state machine of what robots tell each other
  (messages in, addressed messages out, ticks for time);
- **controller**: decides the robot's next goal from what it knows; it may keep state and
  gets the robot's seeded generator.

Each part is registered under a name with :func:`register`, from the module that implements
it, together with the options it takes (:class:`~phd_swarm.core.params.ParamSpec`, so every
option is validated and documented like a node parameter) and what it provides to and
requires of the other parts (e.g. the Lloyd controllers need a grid density over a cell).
A built-in part's module is imported when its name is first looked up
(:data:`BUILTIN_PARTS`), so that a robot process imports only its own system's parts (the
others cost ~0.3 s of start-up, SciPy's optimisers and spatial modules among them; listing
the names imports them all); other modules register theirs when imported, which a scenario
asks for with ``system.plugins`` (module names or ``.py`` files, :func:`load_plugins`).
Adding a system is writing its parts and registering them: the robot node, the engines and
the sweep runner look them up here.
"""

from __future__ import annotations

import importlib
import importlib.util
import sys
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from pathlib import Path
from types import ModuleType
from typing import Any

from .outputs import Observation, Output
from .params import ParamSpec

#: The roles a system is made of, in the order of a step (docs/architecture.md).
ROLES = ("sensor", "estimator", "exchange", "controller")

#: The built-in parts: role -> name -> the module that registers it (and defines its
#: ``make``), imported on the first lookup of the name; a test checks the table against
#: what the modules register.
BUILTIN_PARTS: dict[str, dict[str, str]] = {
    "sensor": {
        "disk": "phd_swarm.core.sensors.disk",
        "disk_false_positive": "phd_swarm.core.sensors.disk_false_positive",
        "disk_labelled": "phd_swarm.core.sensors.disk_labelled",
        "square_range_bearing": "phd_swarm.core.sensors.square_range_bearing",
    },
    "estimator": {
        "grid_phd": "phd_swarm.core.estimators.grid_phd.estimator",
        "papaioannou_sat": "phd_swarm.core.estimators.papaioannou.estimator",
        "shirsat_gmphd": "phd_swarm.core.estimators.shirsat.estimator",
        "sung_gmphd": "phd_swarm.core.estimators.sung.estimator",
    },
    "exchange": {
        "meet_merge": "phd_swarm.core.exchange.meet_merge",
        "none": "phd_swarm.core.exchange.none",
        "sat_share": "phd_swarm.core.exchange.sat_share",
        "voronoi_phd": "phd_swarm.core.exchange.voronoi_phd.part",
    },
    "controller": {
        "chen_o": "phd_swarm.core.controllers.power_lloyd.controller",
        "chen_p": "phd_swarm.core.controllers.power_lloyd.controller",
        "dtds_walk": "phd_swarm.core.controllers.dtds_walk.controller",
        "largest_gaussian": "phd_swarm.core.controllers.sung_planners",
        "lawnmower": "phd_swarm.core.controllers.sung_planners",
        "nearest_gaussian": "phd_swarm.core.controllers.sung_planners",
        "phd": "phd_swarm.core.controllers.lloyd",
        "sat_search_track": "phd_swarm.core.controllers.sat_search_track.controller",
        "uniform": "phd_swarm.core.controllers.lloyd",
    },
}


#: The observation of an estimator that declares none: the union of the robots' estimates.
NO_OBSERVATION = Observation()


#: Hook -> the roles that may declare it (:class:`Part`); ``results_revision`` any role.
HOOKS: dict[str, tuple[str, ...]] = {
    "simulate": ("sensor",), "simulate_labelled": ("sensor",),
    "central": ("estimator",), "runs_in_exchange": ("estimator",),
    "team_step": ("estimator",), "figures": ("estimator", "controller"),
    "view": ("exchange",), "wire": ("exchange",), "map_layer": ("exchange",),
    "counters": ("exchange",),
    "power_weight_guard": ("controller",), "results_revision": ROLES,
}


class RegistryError(ValueError):
    """An unknown part, a name registered twice, or a plugin that cannot be loaded."""


@dataclass(frozen=True)
class Part:
    """One registered implementation of a role.

    Attributes
    ----------
    role : str
        One of :data:`ROLES`.
    name : str
        The name a scenario config uses (``phd``, ``voronoi_phd``...).
    make : callable
        ``make(setup, robot_id)`` -> the robot's instance of the part; ``setup`` is what
        :attr:`setup` returned.
    setup : callable
        ``setup(scenario, system, **runtime)`` -> what every robot's instance shares
        (models, caches, resolved options), computed once per team; ``system`` is the
        :class:`~phd_swarm.core.system.SystemConfig` (names and options), ``runtime`` the
        transport's settings (e.g. ``timeout_ticks``), which a part may ignore.
    description : str
        One line for the docs (docs/architecture.md, docs/parameters.md).
    options : tuple of ParamSpec
        The options the part takes (``scenario.system.options.<name>``).
    provides, requires : frozenset of str
        Capabilities the part gives the others (e.g. ``grid_density``, ``cell``) and those
        it needs from the estimator and the exchange of the same system.
    outputs : tuple of Output
        The topics the part's robots publish besides the node's own
        (:mod:`phd_swarm.core.outputs`).
    observation : Observation
        An estimator's: how the observers score the team from those outputs.

    The role's hooks (:data:`HOOKS`: which role may declare which; None or empty when the
    part has none):

    simulate, simulate_labelled : callable
        A sensor's scan of the true targets from a pose (the world's), with labels.
    central : callable
        An estimator's central form: ``central(scenario)`` -> the team's filter over the
        whole map (the central engine's estimator, the distributed engine's reference).
    runs_in_exchange : bool
        An estimator the exchange runs (the grid PHD over the cells); the agent leaves it.
    team_step : callable
        An estimator's vectorised step of a whole team, equal robot by robot to each
        robot's predict and update.
    figures : callable
        An estimator's or controller's own per-step figures (e.g. Sung & Tokekar's tracks).
    view : callable
        An exchange's view of a step for the controller (e.g. the robot's cell and bins).
    wire : str
        An exchange's ROS wire, ``"module:NAME"`` (:mod:`phd_swarm.nodes.wire`).
    map_layer : callable
        An exchange's per-bin state over the whole map: ``map_layer(scenario, requires)`` ->
        an object that counts a step's scans (``observe``), gives a cell's values
        (``of(bins)``, fields of a controller's ``CellDensity``) and an image for the
        figures (``image()``); the central engine keeps it in place of the robots' own,
        a log's reader rebuilds it from the scans (Chen's cumulative density).
    counters : tuple of str
        An exchange's protocol counters (its robots' ``stats``) that a sweep sums over the
        team into results.csv.
    power_weight_guard : callable
        A controller's bound on the power weights at the partition (Chen's guard).
    results_revision : int or None
        Bumped when the part's results change for the same options
        (:mod:`phd_swarm.config.sweep_hash`); None: the module's ``RESULTS_REVISION``.
    """

    role: str
    name: str
    make: Callable[[Any, int], Any]
    setup: Callable[..., Any]
    description: str
    options: tuple[ParamSpec, ...] = ()
    provides: frozenset[str] = frozenset()
    requires: frozenset[str] = frozenset()
    outputs: tuple[Output, ...] = ()
    observation: Observation = NO_OBSERVATION
    simulate: Callable[..., Any] | None = None
    simulate_labelled: Callable[..., Any] | None = None
    central: Callable[[Any], Any] | None = None
    runs_in_exchange: bool = False
    team_step: Callable[..., Any] | None = None
    figures: Callable[..., Any] | None = None
    view: Callable[[Any], Any] | None = None
    wire: str = ""
    map_layer: Callable[[Any, frozenset[str]], Any] | None = None
    counters: tuple[str, ...] = ()
    power_weight_guard: Callable[[Any], Any] | None = None
    results_revision: int | None = None


_PARTS: dict[str, dict[str, Part]] = {role: {} for role in ROLES}
_builtins_loaded = False


def _no_setup(scenario: Any, system: Any, **runtime: Any) -> None:
    return None


def register(role: str, name: str, make: Callable[[Any, int], Any], *, description: str,
             setup: Callable[..., Any] = _no_setup,
             options: Iterable[ParamSpec] = (), provides: Iterable[str] = (),
             requires: Iterable[str] = (), outputs: Iterable[Output] = (),
             observation: Observation = NO_OBSERVATION, **hooks: Any) -> Part:
    """Register a part under ``name`` for ``role``; returns it.

    ``hooks`` are the role's hooks (:data:`HOOKS`, documented on :class:`Part`).

    Raises
    ------
    RegistryError
        For an unknown role, a name that is not a lower-case identifier, a hook that is
        not one of :data:`HOOKS` or not the role's, or a name already registered for the
        role by another module.
    """
    if role not in ROLES:
        raise RegistryError(f"unknown role {role!r}; expected one of {list(ROLES)}")
    if not name.isidentifier() or name.lower() != name:
        raise RegistryError(f"{role} name must be a lower-case identifier, got {name!r}")
    for hook in hooks:
        if hook not in HOOKS:
            raise RegistryError(f"{role} {name!r}: unknown hook {hook!r}; the hooks are "
                                f"{sorted(HOOKS)}")
        if role not in HOOKS[hook]:
            raise RegistryError(f"{role} {name!r}: {hook!r} is a hook of "
                                f"{' and '.join(HOOKS[hook])} parts, not of a {role}")
    part = Part(role, name, make, setup, description, tuple(options), frozenset(provides),
                frozenset(requires), tuple(outputs), observation, **hooks)
    old = _PARTS[role].get(name)
    if old is not None and old.make.__module__ != make.__module__:
        raise RegistryError(f"{role} {name!r} is already registered by {old.make.__module__}")
    builtin = BUILTIN_PARTS[role].get(name)
    if old is None and builtin is not None and make.__module__ != builtin:
        raise RegistryError(f"{role} {name!r} is already registered by {builtin} (built in)")
    _PARTS[role][name] = part
    return part


def _load_builtins() -> None:
    global _builtins_loaded
    if not _builtins_loaded:
        _builtins_loaded = True
        for module in sorted({m for parts in BUILTIN_PARTS.values() for m in parts.values()}):
            importlib.import_module(module)


def lookup(role: str, name: str) -> Part:
    """The part registered as ``name`` for ``role``; imports a built-in part's module.

    Raises
    ------
    RegistryError
        If there is none; the message lists the names there are.
    """
    if role not in ROLES:
        raise RegistryError(f"unknown role {role!r}; expected one of {list(ROLES)}")
    part = _PARTS[role].get(name)
    if part is None and name in BUILTIN_PARTS[role]:
        importlib.import_module(BUILTIN_PARTS[role][name])
        part = _PARTS[role].get(name)
    if part is None:
        raise RegistryError(f"unknown {role} {name!r}; expected one of {names(role)} (or "
                            f"register it from a plugin: system.plugins)")
    return part


def names(role: str) -> list[str]:
    """Sorted names registered for ``role``."""
    _load_builtins()
    return sorted(_PARTS[role])


def plugin_module_name(path: str | Path) -> str:
    """The module name a ``.py`` file is imported under: derived from its absolute path.

    The same in every process, so that two processes importing one file register the
    same names (and a file imported twice, by two routes, is one module).
    """
    resolved = Path(path).resolve()
    return "phd_swarm_plugin_" + "".join(c if c.isalnum() else "_"
                                         for c in str(resolved.with_suffix("")))


def import_file(path: str | Path) -> ModuleType:
    """The module of the ``.py`` file at ``path``, imported once (:func:`plugin_module_name`).

    What a plugin file, and a face or wire named by file (``"/path/faces.py:NAME"``,
    :mod:`phd_swarm.nodes.face`), are loaded with: a plugin is a file, not an importable
    module, so it is imported by path, not through ``sys.path``.

    Raises
    ------
    FileNotFoundError
        If there is no such file.
    Exception
        Whatever the module raises while importing (it is then not kept).
    """
    resolved = Path(path).resolve()
    module_name = plugin_module_name(resolved)
    module = sys.modules.get(module_name)
    if module is not None:
        return module
    spec = importlib.util.spec_from_file_location(module_name, resolved)
    if spec is None or spec.loader is None or not resolved.is_file():
        raise FileNotFoundError(f"no such file {resolved}")
    module = importlib.util.module_from_spec(spec)
    sys.modules[module_name] = module
    try:
        spec.loader.exec_module(module)
    except BaseException:
        del sys.modules[module_name]
        raise
    return module


def load_plugins(plugins: Iterable[str]) -> None:
    """Import the modules that register parts: module names, or paths of ``.py`` files.

    A file is imported once under a module name derived from its absolute path
    (:func:`import_file`), so that two processes importing the same file register the
    same names.

    Raises
    ------
    RegistryError
        If a module cannot be found or raises while importing; the message names it.
    """
    for plugin in plugins:
        try:
            if plugin.endswith(".py") or "/" in plugin:
                import_file(plugin)
            else:
                importlib.import_module(plugin)
        except RegistryError:
            raise
        except Exception as exc:  # noqa: BLE001 - any import failure, named
            raise RegistryError(f"plugin {plugin!r} cannot be loaded: "
                                f"{type(exc).__name__}: {exc}") from None
