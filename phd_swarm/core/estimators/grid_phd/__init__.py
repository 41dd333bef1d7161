"""The grid ("bin") PHD filter of Dames (2020), the estimator of Dames' and Chen's systems.

- :mod:`.filter`: the filter as functions on (flat indices, weights), eq. 3-6;
- :mod:`.estimator`: the registered part ``grid_phd``, one robot's cell of bins;
- :mod:`.central`: one filter holding every bin of the map (the central engine's reference).
"""
