"""Protocol messages as plain values, mirroring ``msg_defs/msg/*.msg`` field for field.

The ROS layer only converts these to and from ``phd_swarm_msgs``; the in-memory engine
passes them as they are. ``wire_size()`` estimates the CDR payload in bytes (4-byte
encapsulation, a header with stamp and a short frame id, 4-byte lengths for sequences, CDR
alignment ignored) for the communication benchmark.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from enum import IntEnum

import numpy as np

from ...scan import CDR_HEADER as _HEADER
from ...scan import CDR_POINT as _POINT
from ...scan import Scan


class TransferKind(IntEnum):
    """``ParticleTransfer.kind``: ownership hand-over, or phantom mass of the prediction."""

    OWNERSHIP = 0
    PHANTOM = 1


@dataclass(frozen=True, eq=False)
class StateMsg:
    """``RobotState``: Dames Alg. 1 line 1.

    ``cell_radius`` is the largest distance from the robot to a vertex of its previous cell
    [m]; with the position it decides who must be contacts (see :mod:`.participant`).
    """

    #: Its message type in ``msg_defs`` (traffic counts, :mod:`phd_swarm.engines`).
    WIRE_TYPE = "RobotState"

    robot_id: int
    step: int
    position: np.ndarray
    power_weight: float
    cell_radius: float = 0.0

    def wire_size(self) -> int:
        """Estimated CDR payload size [bytes]."""
        return _HEADER + 4 + 4 + _POINT + 8 + 8


@dataclass(frozen=True, eq=False)
class CellMsg:
    """``CellPolygon``: Dames Alg. 1 line 3.

    Besides the cell it carries the neighbour ids and the sender's contact table (the
    states it received this step), from which the receivers learn their contacts' contacts.
    """

    #: Its message type in ``msg_defs`` (traffic counts, :mod:`phd_swarm.engines`).
    WIRE_TYPE = "CellPolygon"

    robot_id: int
    step: int
    generator: np.ndarray
    power_weight: float
    vertices: np.ndarray
    neighbour_ids: tuple[int, ...]
    contact_ids: tuple[int, ...] = ()
    contact_positions: np.ndarray = field(default_factory=lambda: np.empty((0, 2)))
    contact_power_weights: np.ndarray = field(default_factory=lambda: np.empty(0))
    contact_cell_radii: np.ndarray = field(default_factory=lambda: np.empty(0))

    def wire_size(self) -> int:
        """Estimated CDR payload size [bytes]."""
        n = len(self.contact_ids)
        return (_HEADER + 4 + 4 + _POINT + 8 + 4 + _POINT * len(self.vertices)
                + 4 + 4 * len(self.neighbour_ids) + 16 + n * (4 + _POINT + 16))


@dataclass(frozen=True, eq=False)
class EtaPartialMsg:
    """``EtaPartial``: Dames Alg. 2 line 20."""

    #: Its message type in ``msg_defs`` (traffic counts, :mod:`phd_swarm.engines`).
    WIRE_TYPE = "EtaPartial"

    sender_id: int
    active_id: int
    step: int
    values: np.ndarray

    def wire_size(self) -> int:
        """Estimated CDR payload size [bytes]."""
        return _HEADER + 12 + 4 + 8 * len(self.values)


@dataclass(frozen=True, eq=False)
class EtaTotalMsg:
    """``EtaTotal``: Dames Alg. 2 line 18."""

    #: Its message type in ``msg_defs`` (traffic counts, :mod:`phd_swarm.engines`).
    WIRE_TYPE = "EtaTotal"

    active_id: int
    step: int
    values: np.ndarray

    def wire_size(self) -> int:
        """Estimated CDR payload size [bytes]."""
        return _HEADER + 8 + 4 + 8 * len(self.values)


@dataclass(frozen=True, eq=False)
class TransferMsg:
    """``ParticleTransfer``: Dames Alg. 1 lines 4-6 and the phantom particles of Sec. III-B.

    ``alpha`` and ``count`` (Chen's cumulative state, count = n = 1/beta) travel with the
    bins on an ownership hand-over when the cumulative density is on; else they are None.
    An ownership hand-over also relays the radii of this step's cells of the sender's
    contacts (``radius_ids``, ``cell_radii`` [m], computed from the cells it received), from
    which the receivers choose the next step's contacts with radii one step old, not two.
    """

    from_id: int
    to_id: int
    step: int
    kind: TransferKind
    bins: np.ndarray
    weights: np.ndarray
    alpha: np.ndarray | None = None
    count: np.ndarray | None = None
    radius_ids: tuple[int, ...] = ()
    cell_radii: np.ndarray = field(default_factory=lambda: np.empty(0))

    @property
    def WIRE_TYPE(self) -> str:  # noqa: N802 - the attribute every message type has
        """``ParticleTransfer``, or ``PhantomTransfer`` for phantom bins (counted apart)."""
        return "ParticleTransfer" if self.kind == TransferKind.OWNERSHIP else "PhantomTransfer"

    def wire_size(self) -> int:
        """Estimated CDR payload size [bytes]."""
        n = len(self.bins)
        extra = 0 if self.alpha is None else 16 * n
        return (_HEADER + 12 + 1 + 4 + 4 * n + 4 + 8 * n + 8 + extra + 8
                + 12 * len(self.radius_ids))


#: The protocol's messages; a measurement set travels as the core :class:`Scan` itself.
Message = StateMsg | CellMsg | Scan | EtaPartialMsg | EtaTotalMsg | TransferMsg


def stacked(parts: list, width: int = 0) -> np.ndarray:
    """Float fields of several messages (arrays or sequences) flattened one after another.

    Returns shape (N,), or (N, width) for ``width`` > 0 when every part holds whole rows
    (e.g. positions, (n, 2) or (2,) each); the values are the parts' own, in order.
    """
    flat = np.concatenate([np.empty(0), *parts], axis=None, dtype=float)
    return flat.reshape(-1, width) if width else flat


def sender_of(msg: Message) -> int:
    """Robot id that sent ``msg``."""
    if isinstance(msg, EtaPartialMsg):
        return msg.sender_id
    if isinstance(msg, EtaTotalMsg):
        return msg.active_id
    if isinstance(msg, TransferMsg):
        return msg.from_id
    return msg.robot_id
