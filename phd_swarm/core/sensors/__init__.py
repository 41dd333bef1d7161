"""The sensor role: its base class, one module per part, and the models they share.

- :mod:`.base`: :class:`~.base.Sensor`, what a sensor part's instance offers (p_D over the
  field of view, a simulated scan), and the registry hooks that call it;
- the parts, each registering itself on import (the registry imports a built-in one when
  its name is first looked up, :data:`phd_swarm.core.registry.BUILTIN_PARTS`): :mod:`.disk`,
  :mod:`.disk_false_positive`, :mod:`.disk_labelled`, :mod:`.square_range_bearing`;
- the sensor models the estimators filter with, beside the parts that simulate with them:
  :mod:`.fov_detection` (p_D of a Gaussian component in a disk or square field of view,
  Sung & Tokekar eq. 9-10), :mod:`.range_bearing_model` (Papaioannou et al.'s range-bearing
  measurement, Sec. VI-A).

Nothing here imports an estimator.
"""
