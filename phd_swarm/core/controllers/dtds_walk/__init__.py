"""Shirsat & Berman's random walk on the spatial grid (``dtds_walk``) and its graph.

- :mod:`.controller`: the registered part, a step of the walk per time step;
- :mod:`.grid_graph`: the spatial grid graph of Sec. II-III and its random walk (eq. 1-4).
"""
