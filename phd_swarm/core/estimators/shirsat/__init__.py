"""Shirsat & Berman's estimator (``shirsat_gmphd``): a GM-PHD per robot and its reward set.

- :mod:`.estimator`: the registered part (Sec. IV, eq. 19-40, Alg. 1-3);
- :mod:`.reward_sets`: the union of estimated target sets (eq. 6);
- :mod:`.labels`: the labelled reading of components and estimates;
- :mod:`.figures`: the per-step figures of the evaluation.
"""
