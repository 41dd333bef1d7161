"""Papaioannou et al.'s SAT density (``papaioannou_sat``): a particle PHD and a search map.

- :mod:`.estimator`: the registered part, the particle PHD of the true targets (Sec. IV);
- :mod:`.search_map`: the search density on virtual targets (eq. 7, 9, 10);
- :mod:`.figures`: the per-step figures of the evaluation (searched area, tracking).
"""
