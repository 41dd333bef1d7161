"""One step of a robot in progress: its phase, what it announced, and each phase's state.

:class:`Step` replaces one bag of per-step scratch with the state objects of the phases
(:mod:`.cells`, :mod:`.membership`, :mod:`.handover`, :mod:`.phantoms`, :mod:`.eta`), each
created when its phase starts, and says which messages the current phase still waits for.
"""

from __future__ import annotations

import enum
from dataclasses import dataclass

import numpy as np

from .cells import LocalPartition, NeighbourCells
from .eta import EtaUpdate
from .handover import HandOver
from .mailbox import Mailbox
from .membership import KnownStates
from .messages import StateMsg
from .phantoms import PhantomExchange


class Phase(enum.Enum):
    """Where a robot is within a step."""

    IDLE = "idle"
    STATES = "states"
    CELLS = "cells"
    TRANSFERS = "transfers"
    PHANTOMS = "phantoms"
    UPDATE = "update"
    DONE = "done"


#: The mailbox kind each wait for one message per peer collects.
_KINDS = {Phase.STATES: "state", Phase.CELLS: "cell", Phase.TRANSFERS: "own",
          Phase.PHANTOMS: "phantom"}


@dataclass
class Step:
    """One step of a robot: what it announced, its measurements, and each phase's state.

    A phase's state is None until the phase starts.

    Attributes
    ----------
    state : StateMsg
        The own state of the step: step, position q [m], power weight rho [m] and the
        radius of the previous cell [m].
    z : np.ndarray, shape (M, 2)
        The own measurement set [m].
    view : LocalPartition or None
        The own cell and the partition of the contacts (from ``CELLS`` on).
    cells : NeighbourCells or None
        The contacts' cells (from ``TRANSFERS`` on).
    known : KnownStates or None
        The contacts and the contacts' contacts (from ``TRANSFERS`` on).
    handover, phantoms, update : or None
        The states of the hand-over, the prediction and the measurement update.
    """

    state: StateMsg
    z: np.ndarray
    view: LocalPartition | None = None
    cells: NeighbourCells | None = None
    known: KnownStates | None = None
    handover: HandOver | None = None
    phantoms: PhantomExchange | None = None
    update: EtaUpdate | None = None

    def drop(self, ids: set[int]) -> None:
        """Stop waiting for the robots ``ids`` (declared dead) in every phase."""
        for phase in (self.handover, self.phantoms, self.update):
            if phase is not None:
                phase.drop(ids)

    def update_progress(self) -> tuple[int, int]:
        """Active ids still pending and partial sums sent in the update (0, 0 before it)."""
        upd = self.update
        return (0, 0) if upd is None else (len(upd.pending), len(upd.partial_sent))

    def _peers(self, phase: Phase, contacts: tuple[int, ...]) -> set[int] | tuple[int, ...]:
        """The peers a wait of ``phase`` needs one message from."""
        if phase is Phase.TRANSFERS:
            assert self.handover is not None
            return self.handover.peers
        if phase is Phase.PHANTOMS:
            assert self.phantoms is not None
            return self.phantoms.peers
        return contacts

    def waiting(self, phase: Phase, contacts: tuple[int, ...], mail: Mailbox) -> bool:
        """Whether a ``STATES`` to ``PHANTOMS`` wait still needs a message (else False).

        ``bool(self.missing(...))``, but O(1) while fewer messages than peers have arrived,
        since it is asked on every message.
        """
        kind = _KINDS.get(phase)
        if kind is None:
            return False
        if mail.count((self.state.step, kind)) < len(self._peers(phase, contacts)):
            return True
        return bool(self.missing(phase, contacts, mail))

    def missing(self, phase: Phase, contacts: tuple[int, ...], mail: Mailbox) -> set[int]:
        """Peers the wait of ``phase`` still needs to hear from (empty if not waiting).

        Parameters
        ----------
        phase : Phase
            The robot's phase.
        contacts : tuple of int
            The robot's contacts (whose states and cells it waits for).
        mail : Mailbox
            The robot's mail.
        """
        kind = _KINDS.get(phase)
        if kind is not None:
            return set(self._peers(phase, contacts)) - set(mail.box((self.state.step, kind)))
        if phase is Phase.UPDATE:
            assert self.update is not None
            return self.update.missing(mail)
        return set()


__all__ = ["Phase", "Step"]
