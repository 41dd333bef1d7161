"""Exchanges: the built-in ones register on import (:mod:`phd_swarm.core.registry`).

:mod:`.base` is the role (:class:`~.base.Exchange`, :class:`~.base.Envelope`); :mod:`.faults`
injects lossy links into any exchange's traffic; :mod:`.voronoi_phd` is Dames' exchange,
:mod:`.none` the exchange of a robot alone, :mod:`.meet_merge` Shirsat & Berman's exchange of
reward sets between robots that meet (who meets whom: :mod:`.radio`).
"""

from . import meet_merge, none, sat_share, voronoi_phd  # noqa: F401  (registration)
