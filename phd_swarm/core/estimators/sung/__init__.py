"""Sung & Tokekar's estimator (``sung_gmphd``): GM-PHD with a limited FoV, targets and tracks.

- :mod:`.estimator`: the registered part (Sec. IV-V);
- :mod:`.gp_motion`: Gaussian-process prediction of confirmed tracks (eq. 8);
- :mod:`.gp_detections`: what the GP regresses on, a track's estimates or its detections;
- :mod:`.figures`: the per-step figures of the evaluation.
"""
