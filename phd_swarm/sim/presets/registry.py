"""Names -> scenario presets: the papers' settings, each registered by its paper's module.

A preset is a function that builds a :class:`~phd_swarm.sim.scenario.Scenario` from a few
arguments, all with defaults (the paper's values), registered with the :func:`preset`
decorator as a :class:`Preset`: its name (the function's), the paper and section it
reproduces, and the target kinds it spells out. :data:`PRESETS` maps every registered name
to its function, so ``PRESETS[name]()`` is the paper's scenario; a config names one with
``preset:`` and overrides its fields (:mod:`phd_swarm.sim.scenario_dict`). The papers'
modules are imported by :mod:`phd_swarm.sim.presets`; read the registry through it.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass
from types import MappingProxyType
from typing import TypeVar

from phd_swarm.sim.scenario import Scenario

__all__ = ["PRESETS", "Preset", "preset", "preset_of_kind", "register", "registered"]


@dataclass(frozen=True)
class Preset:
    """One paper's scenario.

    Attributes
    ----------
    name : str
        The name configs use (``preset:``), the build function's.
    paper : str
        The paper and section it reproduces, e.g. ``Dames (2020) Sec. IV-A``.
    build : callable
        ``build(**arguments) -> Scenario``; every argument has a default, so ``build()`` is
        the paper's setting.
    base_of : tuple of str
        Target kinds whose scenarios are written out over this preset
        (:func:`preset_of_kind`): a kind's fields left unset there come from it.
    """

    name: str
    paper: str
    build: Callable[..., Scenario]
    base_of: tuple[str, ...] = ()


_PRESETS: dict[str, Preset] = {}
_BUILDS: dict[str, Callable[..., Scenario]] = {}

#: Preset name -> its build function, by name; a read-only view of the registry, so
#: ``PRESETS[name]()`` builds the paper's scenario.
PRESETS: Mapping[str, Callable[..., Scenario]] = MappingProxyType(_BUILDS)


def register(entry: Preset) -> Preset:
    """Add ``entry`` under its name (once); returns it."""
    if entry.name in _PRESETS:
        raise ValueError(f"preset {entry.name!r} is already registered")
    _PRESETS[entry.name] = entry
    # Kept sorted by name, so the order does not depend on which module was imported first.
    builds = {name: _PRESETS[name].build for name in sorted(_PRESETS)}
    _BUILDS.clear()
    _BUILDS.update(builds)
    return entry


F = TypeVar("F", bound=Callable[..., Scenario])


def preset(paper: str, *, base_of: tuple[str, ...] = ()) -> Callable[[F], F]:
    """Register the decorated function as the preset of its name (:class:`Preset`).

    The function is returned unchanged, so its module still exports it to call with other
    arguments (``dames_static(robots=40)``).
    """
    def decorate(build: F) -> F:
        register(Preset(name=build.__name__, paper=paper, build=build, base_of=base_of))
        return build
    return decorate


def registered() -> tuple[Preset, ...]:
    """The registered presets, by name."""
    return tuple(_PRESETS[name] for name in sorted(_PRESETS))


def preset_of_kind() -> dict[str, str]:
    """Target kind -> the preset a scenario of that kind is written out over (``base_of``).

    :func:`phd_swarm.config.scenario_to_dict` names it as the scenario's ``preset``, so
    that fields a kind leaves unset (None or empty) come from a preset of the same kind.
    """
    return {kind: p.name for p in registered() for kind in p.base_of}
