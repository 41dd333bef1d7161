"""In-memory engines: a whole team against the simulated world, in one process.

Both run one step at a time (``step()``, ``run(steps)``) and give the same observations
(``world``, ``team_weights()``, ``counters()``), so the sweeps, benchmarks and tests pick one
by name:

- ``distributed`` (:class:`~.distributed.DistributedEngine`): every robot's agent
  (:mod:`phd_swarm.core.agent`) message by message, bit-equal to the ROS stack in lockstep;
- ``central`` (:class:`~.central.CentralEngine`): the team's filter and partition as one,
  several times faster, for the systems that have a central form.
"""

from __future__ import annotations

from typing import Any

from .central import CentralEngine
from .distributed import DistributedEngine

#: Engine name -> class.
ENGINES: dict[str, type] = {"central": CentralEngine, "distributed": DistributedEngine}


def make_engine(name: str, scenario: Any, **options: Any) -> CentralEngine | DistributedEngine:
    """The engine ``name`` (:data:`ENGINES`) on ``scenario``; ``options`` go to its class.

    Raises
    ------
    ValueError
        For an unknown name (the message lists the names).
    """
    try:
        cls = ENGINES[name]
    except KeyError:
        raise ValueError(f"unknown engine {name!r}; expected one of {sorted(ENGINES)}") from None
    return cls(scenario, **options)


__all__ = ["ENGINES", "CentralEngine", "DistributedEngine", "make_engine"]
