"""Estimators: the role's base, then one module or package per system's part.

Each module registers its parts on import; the registry imports a built-in one when its
name is first looked up (:data:`phd_swarm.core.registry.BUILTIN_PARTS`).
"""
