"""The particle (SMC) PHD filter of Vo, Singh & Doucet (2005).

- :mod:`.filter`: prediction, update and resampling, vectorised;
- :mod:`.models`: its motion, measurement and birth models;
- :mod:`.estimator`: one robot's particles as an
  :class:`~phd_swarm.core.estimators.base.Estimator`.
"""
