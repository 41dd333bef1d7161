"""The papers' settings as scenario presets, one module per paper.

Each module registers its presets in :mod:`phd_swarm.sim.presets.registry` (a
:class:`~phd_swarm.sim.presets.registry.Preset`: name, paper, build function): Dames (2020)
Sec. IV (:mod:`~phd_swarm.sim.presets.dames`: :func:`dames_static`, :func:`dames_moving`),
Chen, Dames & Park (2021) Sec. 4 (:mod:`~phd_swarm.sim.presets.chen`:
:func:`chen_clustered`), Sung & Tokekar (2022) Sec. VI (:mod:`~phd_swarm.sim.presets.sung`:
:func:`sung_tokekar`), Shirsat & Berman (2021) Sec. VI (:mod:`~phd_swarm.sim.presets.shirsat`:
:func:`shirsat_berman`) and Papaioannou et al. Sec. VI
(:mod:`~phd_swarm.sim.presets.papaioannou`: :func:`papaioannou`). Importing this package
imports them all; :data:`PRESETS` names them for configs (``preset:``), and the node
parameters, the docs and the sweeps read it.
"""

from __future__ import annotations

from phd_swarm.sim.presets.chen import chen_clustered
from phd_swarm.sim.presets.dames import dames_moving, dames_static
from phd_swarm.sim.presets.papaioannou import papaioannou
from phd_swarm.sim.presets.registry import (
    PRESETS,
    Preset,
    preset_of_kind,
    registered,
)
from phd_swarm.sim.presets.shirsat import shirsat_berman
from phd_swarm.sim.presets.sung import MAP_150, sung_tokekar

__all__ = ["MAP_150", "PRESETS", "Preset", "chen_clustered", "dames_moving", "dames_static",
           "papaioannou", "preset_of_kind", "registered", "shirsat_berman", "sung_tokekar"]
