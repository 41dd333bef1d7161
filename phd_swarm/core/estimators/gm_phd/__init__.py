"""The Gaussian-mixture PHD filter (Vo & Ma 2006), the base of Sung's and Shirsat's estimators.

- :mod:`.filter`: prediction and the (limited-FoV) update, vectorised (Vo & Ma Table I);
- :mod:`.births`: the birth rules;
- :mod:`.reduce`: pruning, merging and capping (Vo & Ma Table II);
- :mod:`.team`: many robots' mixtures at once, row by row;
- :mod:`.estimator`: one robot's mixture as an :class:`~phd_swarm.core.estimators.base.Estimator`;
- :mod:`.outputs`: what a robot with a mixture publishes.
"""
