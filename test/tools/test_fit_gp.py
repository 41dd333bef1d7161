from __future__ import annotations

import re

import numpy as np

from phd_swarm.config import load_run_config
from phd_swarm.tools import fit_gp

ROOT = fit_gp.ROOT


def test_training_tracks_are_noisy_observations_of_the_configs_targets():
    sc = load_run_config(ROOT / "config" / "sung_moving.yaml").scenario
    tracks = fit_gp.training_tracks(sc, 12, 50, seed=1000)
    assert len(tracks) == 12
    steps, obs = tracks[0]
    assert np.array_equal(steps, np.arange(50.0)) and obs.shape == (50, 2)
    # 0.05 m/s targets observed with 1 m noise: steps between observations ~ sqrt(2) m.
    jumps = np.hypot(*np.diff(obs, axis=0).T)
    assert 0.8 < jumps.mean() < 2.2
    again = fit_gp.training_tracks(sc, 12, 50, seed=1000)
    assert all(np.array_equal(a[1], b[1]) for a, b in zip(tracks, again, strict=True))


def test_the_cli_prints_an_options_block(capsys):
    assert fit_gp.main(["--tracks", "6", "--steps", "120", "--window", "20"]) == 0
    out = capsys.readouterr().out
    values = dict(re.findall(r"^  (gp_\w+): (\S+)$", out, flags=re.M))
    assert set(values) == {"gp_signal_sd", "gp_length_scale", "gp_noise_sd", "gp_window"}
    assert values["gp_window"] == "20" and float(values["gp_noise_sd"]) > 0
