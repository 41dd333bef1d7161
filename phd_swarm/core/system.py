"""Which system a run uses: one part per role and their options (``scenario.system``).

In a config file::

    scenario:
      system:
        sensor: disk             # field of view, detection, measurement, clutter
        estimator: grid_phd      # the robot's belief about the targets
        exchange: voronoi_phd    # what the robots tell each other (Dames Alg. 1-2)
        controller: chen_o       # where the robot goes next
        options: {cumulative_mode: rate, rho_max: 0.0}
        plugins: []              # modules or .py files that register more parts

Every key is optional (the defaults are Dames' system with the PHD-weighted Lloyd
controller). :class:`SystemConfig` checks the names against the registry
(:mod:`phd_swarm.core.registry`), that the parts fit together (what the controller and the
exchange require, the estimator and the exchange provide), and every option against the
options the chosen parts declare; it holds every option, defaults included, so a resolved
config spells them all out.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace
from functools import partial
from pathlib import Path
from typing import Any

from .outputs import system_outputs
from .params import expect_list, expect_mapping, expect_str
from .registry import ROLES, Part, RegistryError, load_plugins, lookup

#: Dames (2020): disk sensor, grid PHD, Voronoi hand-over, PHD-weighted Lloyd.
DEFAULT_PARTS = {"sensor": "disk", "estimator": "grid_phd", "exchange": "voronoi_phd",
                 "controller": "phd"}

#: Keys of a ``system`` mapping.
KEYS = (*ROLES, "options", "plugins")


@dataclass(frozen=True)
class SystemConfig:
    """One part name per role, every option of those parts, and the plugins to import.

    Build it with :meth:`from_dict` (or the constructor): names and options are checked
    against the registry, missing options take their defaults.

    Attributes
    ----------
    sensor, estimator, exchange, controller : str
        Registered part names (:mod:`phd_swarm.core.registry`).
    options : tuple of (name, value)
        Every option of the chosen parts, sorted by name (a tuple keeps the config
        hashable); :meth:`option` reads one.
    plugins : tuple of str
        Modules or ``.py`` files imported before the names are looked up.
    """

    sensor: str = DEFAULT_PARTS["sensor"]
    estimator: str = DEFAULT_PARTS["estimator"]
    exchange: str = DEFAULT_PARTS["exchange"]
    controller: str = DEFAULT_PARTS["controller"]
    options: tuple[tuple[str, Any], ...] = ()
    plugins: tuple[str, ...] = ()

    def __post_init__(self) -> None:
        object.__setattr__(self, "plugins", expect_list(
            self.plugins, "system.plugins", item=partial(expect_str, nonempty=True)))
        try:
            load_plugins(self.plugins)
        except RegistryError as exc:
            raise ValueError(f"system.plugins: {exc}") from None
        parts = {}
        for role in ROLES:
            try:
                parts[role] = lookup(role, getattr(self, role))
            except RegistryError as exc:
                raise ValueError(f"system.{role}: {exc}") from None
        _check_fit(parts)
        object.__setattr__(self, "options", _resolve_options(parts, dict(self.options)))

    @classmethod
    def from_dict(cls, d: Mapping[str, Any], where: str = "system",
                  base_dir: str | Path | None = None) -> SystemConfig:
        """Build from a mapping (a ``system`` block); errors start with ``where``.

        Plugin files given relative (``my_parts.py``) are taken relative to ``base_dir``
        (the directory of the config file) and stored absolute, so that a node started
        elsewhere from the resolved config finds them.
        """
        d = expect_mapping(d, where, allowed=KEYS)
        kw: dict[str, Any] = {role: expect_str(d[role], f"{where}.{role}")
                              for role in ROLES if role in d}
        kw["options"] = tuple(expect_mapping(d.get("options") or {}, f"{where}.options").items())
        if "plugins" in d:
            plugins = d["plugins"] or ()
            if base_dir is not None and isinstance(plugins, Sequence) \
                    and not isinstance(plugins, str):
                plugins = [_absolute(p, Path(base_dir)) for p in plugins]
            kw["plugins"] = plugins
        try:
            return cls(**kw)
        except ValueError as exc:
            raise ValueError(f"{where}.{str(exc).removeprefix('system.')}") from None

    def parts(self) -> dict[str, Part]:
        """Role -> the registered part (:class:`~phd_swarm.core.registry.Part`).

        Imports the plugins first (a no-op once imported): a config unpickled in another
        process (a sweep worker) finds its parts too.
        """
        load_plugins(self.plugins)
        return {role: lookup(role, getattr(self, role)) for role in ROLES}

    def option(self, name: str) -> Any:
        """Value of option ``name`` (KeyError if no chosen part takes it)."""
        for key, value in self.options:
            if key == name:
                return value
        raise KeyError(f"system option {name!r}; the parts take {[k for k, _ in self.options]}")

    def with_parts(self, **changes: Any) -> SystemConfig:
        """A copy with some parts, options (a mapping, merged) or plugins replaced.

        Options that the new parts do not take are dropped; those they take keep their
        value unless ``options`` sets them.
        """
        options = {**dict(self.options), **dict(changes.pop("options", {}) or {})}
        new = replace(self, options=(), **changes)
        taken = {k for k, _ in new.options}
        return replace(new, options=tuple((k, v) for k, v in options.items() if k in taken))

    def to_dict(self) -> dict[str, Any]:
        """Plain mapping, the inverse of :meth:`from_dict`."""
        return {**{role: getattr(self, role) for role in ROLES},
                "options": dict(self.options), "plugins": list(self.plugins)}

    def label(self) -> str:
        """Short text for logs and run names: the controller, or every non-default part."""
        other = [getattr(self, r) for r in ROLES
                 if r != "controller" and getattr(self, r) != DEFAULT_PARTS[r]]
        return "+".join([*other, self.controller])


def _absolute(plugin: Any, base: Path) -> Any:
    """A relative plugin file taken relative to ``base``; module names as they are."""
    if isinstance(plugin, str) and (plugin.endswith(".py") or "/" in plugin) \
            and not Path(plugin).is_absolute():
        return str((base / plugin).resolve())
    return plugin


def _check_fit(parts: dict[str, Part]) -> None:
    """Refuse parts that do not fit.

    Each needs what the others provide, no topic has two writers, and the observers read
    only declared outputs.
    """
    available = parts["sensor"].provides | parts["estimator"].provides \
        | parts["exchange"].provides
    for role in ("estimator", "exchange", "controller"):
        missing = sorted(parts[role].requires - available)
        if missing:
            raise ValueError(f"system.{role}: {parts[role].name} needs {missing}, which "
                             f"{', '.join(f'{r} {parts[r].name}' for r in ROLES if r != role)} "
                             f"do not provide")
    try:
        declared = {o.topic for o in system_outputs(parts)}
    except ValueError as exc:
        raise ValueError(f"system: {exc}") from None
    unread = [t for t in parts["estimator"].observation.inputs if t not in declared]
    if unread:
        raise ValueError(f"system.estimator: {parts['estimator'].name} is observed through "
                         f"{unread}, which no part of the system publishes")


def _resolve_options(parts: dict[str, Part], given: dict[str, Any]) -> tuple:
    """Every option of ``parts``: the given value (checked) or the default, sorted."""
    specs = {}
    for part in parts.values():
        for spec in part.options:
            other = specs.get(spec.name)
            if other is not None and other != spec:
                raise ValueError(f"system.options.{spec.name}: declared differently by two "
                                 f"parts ({part.role} {part.name} and another)")
            specs[spec.name] = spec
    for name in given:
        if name not in specs:
            raise ValueError(f"system.options.{name}: unknown option; the parts "
                             f"{[p.name for p in parts.values()]} take {sorted(specs)}")
    out = []
    for name in sorted(specs):
        value = specs[name].default
        if name in given:
            try:
                value = specs[name].check(given[name])
            except ValueError as exc:
                raise ValueError(f"system.options.{exc}") from None
        out.append((name, value))
    return tuple(out)
