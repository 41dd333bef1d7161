"""Dames' exchange (Alg. 1-2) as a registered part: ``voronoi_phd``.

Each robot's participant is a :class:`~.participant.Participant`: it hands bins over as the
Voronoi (or power) cells move, predicts with phantom bins and runs the distributed update
with eta partial sums; with a controller that requires ``cumulative`` its bins carry Chen's
cumulative state (alpha, n; Chen eq. 9-10). What it gives the controller is the robot's cell
and the PHD over its bins (:func:`view`).
"""

from __future__ import annotations

from typing import Any

from ... import registry
from ...controllers.base import CellDensity
from ...outputs import Output
from .context import TIMEOUT_TICKS, FilterContext
from .layers import map_layer
from .participant import Participant


def setup(scenario: Any, system: Any, timeout_ticks: int = TIMEOUT_TICKS,
          **runtime: Any) -> FilterContext:
    """The team's shared context.

    Grid, models, the cumulative layer if the controller needs it, the timeout and the
    contact margin (one step of the fastest robot).
    """
    cumulative = "cumulative" in system.parts()["controller"].requires
    return FilterContext(scenario.grid, scenario.models, cumulative=cumulative,
                         timeout_ticks=timeout_ticks,
                         max_step=scenario.robot_max_speed * scenario.dt)


def view(participant: Participant) -> CellDensity:
    """What the robot knows of its cell at the end of a step (for the controller)."""
    return CellDensity(participant.ctx.grid, participant.cell, participant.bins,
                       participant.weights, participant.alpha, participant.count)


#: The participant's counters (:attr:`.participant.Participant.stats`) that a sweep sums over
#: the team into results.csv: a missed neighbour and what it cost, peers declared dead by a
#: timeout and the bins lost with them (docs/protocol.md).
COUNTERS = ("cell_mismatch", "misrouted_bins", "unroutable_bins", "duplicate_bins",
            "orphan_bins", "timeouts", "lost_to_dead")

#: The robot's own cell of the step, for observers.
CELL = Output(
    "cell", "phd_swarm_msgs/msg/CellPolygon", "phd_swarm.nodes.faces.voronoi_phd:CELL",
    "The robot's own cell (Voronoi or power diagram clipped to E), its power weight and "
    "its neighbours' ids, for observers.")

registry.register(
    "exchange", "voronoi_phd", lambda ctx, rid: Participant(rid, ctx), setup=setup,
    description="Voronoi/power-cell hand-over, phantom prediction and eta partial sums "
                "(Dames 2020 Alg. 1-2), plus Chen's cumulative layer when asked.",
    provides=("cell", "cumulative"), requires=("grid_density",), outputs=(CELL,), view=view,
    wire="phd_swarm.nodes.faces.voronoi_phd:WIRE", map_layer=map_layer, counters=COUNTERS)
