"""Real time: a robot's own verdict on a silent peer holds until the team's next epoch.

In lockstep the world waits for every robot, and a peer that a robot's protocol declared
dead on silence (:meth:`phd_swarm.core.exchange.voronoi_phd.participant.Participant.tick`)
is admitted again at the next step the world says it is alive: the world is the one judge
of membership, and every robot follows it at the same step, so both sides of a pair decide
on the same numbers. In real time the world does not wait, and it judges a silent robot only
after its ``step_timeout``. Until then its team states still say "alive", and a robot that
followed them would wait ``timeout_ticks`` rounds on the silent peer at every step (a robot
host cut off from the rest: the connected robots fall further behind the world at every
step and never catch up).

So in real time a robot admits the peers its own protocol declared dead again only at the
team's epochs, the steps k with k mod ``revive_every`` = 0, the same steps for every robot
(and from the same team state, so the pairs stay symmetric). Between epochs its verdict
holds although the world's team states say the peer is alive. The world's own word is
followed at once: a robot the world counts dead is dead, and one the world says is back (a
dead-to-alive change) is admitted at that step by every robot. ``run_swarm`` sets
``revive_every`` to the world's ``step_timeout`` in steps (the time the world needs for its
verdict); 1, the default, is lockstep's rule (every step is an epoch).
"""

from __future__ import annotations

import numpy as np


class SilenceHold:
    """Which dead peers not to admit again although the world says they are alive.

    Parameters
    ----------
    revive_every : int
        Steps between the team's epochs (>= 1; 1: every step).
    """

    def __init__(self, revive_every: int) -> None:
        self.revive_every = int(revive_every)
        self._world_dead: set[int] = set()

    def keep_dead(self, step: int, ids: np.ndarray, alive: np.ndarray,
                  dead_peers: frozenset[int]) -> frozenset[int]:
        """The peers to keep dead at ``step``, whose team state is ``ids`` (R,), ``alive`` (R,).

        ``dead_peers``: the robots the robot's exchange holds for dead now. Call it once per
        step, in step order (it remembers the world's dead of the last call).
        """
        alive = np.asarray(alive, dtype=bool)
        world_dead = set(np.asarray(ids)[~alive].tolist())
        back = self._world_dead - world_dead
        self._world_dead = world_dead
        if self.revive_every <= 1 or step % self.revive_every == 0:
            return frozenset()
        return frozenset(dead_peers - world_dead - back)
