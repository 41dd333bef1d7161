"""Exchanges: the role's base, then one module or package per system's part.

Each module registers its parts on import; the registry imports a built-in one when its
name is first looked up (:data:`phd_swarm.core.registry.BUILTIN_PARTS`).

:mod:`.base` is the role (:class:`~.base.Exchange`, :class:`~.base.Envelope`); :mod:`.faults`
injects lossy links into any exchange's traffic; :mod:`.voronoi_phd` is Dames' exchange,
:mod:`.none` the exchange of a robot alone, :mod:`.meet_merge` Shirsat & Berman's exchange of
reward sets between robots that meet (who meets whom: :mod:`.radio`).
"""
