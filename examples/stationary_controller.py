"""A system part from outside the package: a controller that keeps every robot where it is.

The smallest example of adding a part (docs/architecture.md, "Adding a system"): subclass
the role's base class, register a name, and list this file (or its module) under
``scenario.system.plugins``; nothing in the robot node, the engines or the sweep runner
changes. ``examples/stationary.yaml`` runs it with ``scripts/run_swarm.sh``, and
``examples/stationary_sweep.yaml`` with ``scripts/sweep.sh``.

A stationary team is also a baseline: what the filter learns from where the robots start.
"""

from __future__ import annotations

import numpy as np

from phd_swarm.core import registry
from phd_swarm.core.controllers.base import Controller, Decision, Knowledge


class StationaryController(Controller):
    """Goal: the robot's own position, every step (a team that only watches)."""

    def decide(self, knowledge: Knowledge, rng: np.random.Generator) -> Decision:
        """Stay: the goal is the current position; power weight 0 (Voronoi cells)."""
        return Decision(goal=np.array(knowledge.position, dtype=float), power_weight=0.0)


registry.register("controller", "stationary", lambda setup, rid: StationaryController(),
                  description="Every robot stays where it starts (example plugin, "
                              "examples/stationary_controller.py).")
