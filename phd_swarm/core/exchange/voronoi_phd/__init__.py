"""Dames' exchange (2020 Sec. III, Alg. 1-2): the distributed grid PHD as a protocol.

Registered as the ``voronoi_phd`` exchange by :mod:`.part`.

:mod:`.messages` mirrors the ``phd_swarm_msgs`` definitions as plain values;
:mod:`.participant` is one robot's state machine (messages in, addressed messages out), which
hands each job to a collaborator: :mod:`.membership` (contact sets, the dead, rejoining),
:mod:`.liveness` (keep-alives and timeouts), :mod:`.mailbox` (messages held and re-sent),
:mod:`.cells` (the step's cells), :mod:`.handover` (bins given and taken, Alg. 1),
:mod:`.phantoms` (prediction, Sec. III-B), :mod:`.eta` (the update, Alg. 2) and
:mod:`.layers` (per-bin state travelling with the bins: Chen's cumulative density).
:mod:`.context` holds what a team shares, :mod:`.step` the state of a step in progress.
"""

from . import part  # noqa: F401  (registration)
