"""Tools over phd_swarm runs: MCAP log I/O, replay, evaluation, plots, sweeps."""
