"""Names -> target kinds: the true target populations a scenario can ask for.

A kind (``targets.kind``) is registered with :func:`register` by the module that implements
it, as a :class:`TargetKind`: its name, the function that draws its initial population (its
keyword-only parameters name the fields of :class:`~phd_swarm.sim.scenario.TargetConfig` it
reads), a line for the docs, and a check of its fields against the run.

:mod:`phd_swarm.sim.targets` imports the built-in kinds' modules (it lists them) and draws a
scenario's targets (:func:`~phd_swarm.sim.targets.make_targets`); read the kinds through it
(or through :mod:`phd_swarm.sim.scenario`, which imports it), so that every built-in kind
is registered. This module imports no other module of the simulator: the kinds' modules
import it, and the scenario imports them, so imports point one way.
"""

from __future__ import annotations

import inspect
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any, Protocol

import numpy as np

from phd_swarm.core.geometry.grid import Environment
from phd_swarm.core.models import PhdModels

__all__ = ["TargetKind", "TargetOptions", "TargetPopulation", "TargetSetting", "lookup",
           "names", "register", "registered"]


class TargetPopulation(Protocol):
    """What every kind's population exposes to the world.

    ``positions`` (N, 2) [m] and ``ids`` (N,) int64 of the targets in the truth now (an id
    is never reused), and ``step(rng, dt)``, which advances the truth by ``dt`` seconds and
    draws only from ``rng``, in an order each model documents.
    """

    @property
    def positions(self) -> np.ndarray:
        """Positions of the targets in the truth now, shape (N, 2) [m], in id order."""

    @property
    def ids(self) -> np.ndarray:
        """Ids of the targets in the truth now, shape (N,) int64."""

    def step(self, rng: np.random.Generator, dt: float) -> None:
        """Advance the truth by ``dt`` [s], drawing from ``rng`` only."""


class TargetOptions(Protocol):
    """A target config: the kind's name, and the fields the kinds read as attributes."""

    @property
    def kind(self) -> str:
        """The name of the kind (``targets.kind``)."""


class TargetSetting(Protocol):
    """What a kind reads of the run; a :class:`~phd_swarm.sim.scenario.Scenario` is one.

    The map E [m], the step [s], the number of steps, the filter's models (Dames' walkers
    are born from its birth PHD, eq. 14) and the target config.
    """

    @property
    def env(self) -> Environment:
        """The map E [m]."""

    @property
    def dt(self) -> float:
        """The time step [s]."""

    @property
    def steps(self) -> int:
        """The number of steps of the run."""

    @property
    def models(self) -> PhdModels:
        """The filter's models."""

    @property
    def targets(self) -> TargetOptions:
        """The target config."""


def _keywords(fn: Callable[..., Any] | None) -> tuple[str, ...]:
    """The keyword-only parameters of ``fn`` (none for None), in order."""
    if fn is None:
        return ()
    return tuple(p.name for p in inspect.signature(fn).parameters.values()
                 if p.kind is inspect.Parameter.KEYWORD_ONLY)


@dataclass(frozen=True)
class TargetKind:
    """One kind of true target population.

    Attributes
    ----------
    name : str
        The ``targets.kind`` that selects it.
    make : callable
        ``make(rng, scenario, *, <fields>) -> TargetPopulation``: the initial population of
        a run drawn from ``rng`` (the world's target stream); ``scenario`` is a
        :class:`TargetSetting` and the keyword-only parameters are the fields of the target
        config it reads, by name.
    description : str
        One line for the docs: the paper and section, and what the targets do.
    check : callable or None
        ``check(scenario, *, <fields>)``: raises ValueError naming the ``targets.<field>``
        if the fields it reads do not fit together or the run (:meth:`validate`); None:
        nothing to check.
    fields : tuple of str
        The fields of the target config (``scenario.targets.<field>``) the kind reads: the
        keyword-only parameters of ``make``, then those only ``check`` reads. Derived from
        the two signatures, so it cannot fall behind them; the docs show a preset's value
        of a field only where its kind reads it.
    """

    name: str
    make: Callable[..., TargetPopulation]
    description: str
    check: Callable[..., None] | None = None
    fields: tuple[str, ...] = field(init=False)

    def __post_init__(self) -> None:
        made = _keywords(self.make)
        checked = tuple(f for f in _keywords(self.check) if f not in made)
        object.__setattr__(self, "fields", made + checked)

    def populate(self, rng: np.random.Generator, scenario: TargetSetting) -> TargetPopulation:
        """The initial population of ``scenario``'s targets, drawn from ``rng`` by ``make``."""
        return self.make(rng, scenario, **_options(self.make, scenario.targets))

    def validate(self, scenario: TargetSetting) -> None:
        """Run ``check`` on ``scenario`` (its target config and the run), if there is one."""
        if self.check is not None:
            self.check(scenario, **_options(self.check, scenario.targets))


def _options(fn: Callable[..., Any], config: TargetOptions) -> dict[str, Any]:
    """The fields of ``config`` that ``fn`` takes, by name."""
    return {name: getattr(config, name) for name in _keywords(fn)}


_KINDS: dict[str, TargetKind] = {}


def register(kind: TargetKind) -> TargetKind:
    """Add ``kind`` under its name; returns it. A name is registered once."""
    if kind.name in _KINDS:
        raise ValueError(f"target kind {kind.name!r} is already registered")
    _KINDS[kind.name] = kind
    return kind


def names() -> tuple[str, ...]:
    """The registered kinds' names, sorted (the same order whatever imported them first)."""
    return tuple(sorted(_KINDS))


def registered() -> tuple[TargetKind, ...]:
    """The registered kinds, by name."""
    return tuple(_KINDS[name] for name in names())


def lookup(name: str) -> TargetKind:
    """The kind registered as ``name``; ValueError listing the kinds if there is none."""
    try:
        return _KINDS[name]
    except KeyError:
        raise ValueError(f"unknown target kind {name!r}; expected one of "
                         f"{', '.join(names())}") from None
