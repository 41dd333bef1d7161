"""A Sung sweep read back for its tables and figures: per method, its finished runs.

Filled by :func:`phd_swarm.tools.sung_tables.load_sweep`, read by the tables
(:mod:`.sung_tables`) and the figures (:mod:`.sung_plots`).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np


@dataclass
class MethodRuns:
    """The finished runs of one method of a sweep.

    Attributes
    ----------
    trials, seeds : list
        Trial keys and seeds, sorted by seed.
    values : list of dict
        :func:`run_values` of each run.
    series : list of dict
        The :data:`PLOTTED` series of each run, every ``stride``-th step.
    steps : list of int
        Number of steps of each run.
    """

    trials: list[str] = field(default_factory=list)
    seeds: list[int] = field(default_factory=list)
    values: list[dict[str, float]] = field(default_factory=list)
    series: list[dict[str, np.ndarray]] = field(default_factory=list)
    steps: list[int] = field(default_factory=list)


@dataclass
class Sweep:
    """A sweep directory read by :func:`load_sweep`."""

    path: Path
    name: str
    figure: str
    methods: dict[str, MethodRuns]
