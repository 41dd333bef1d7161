"""Sung & Tokekar's system through ``scripts/run_swarm.sh``: one robot, recorded, summarised.

The session's recorded run (:func:`conftest.sung_run`; its log's completeness is checked with
every system's in ``test_run_swarm_systems.py``): its tracks keep their ids, and the summary
has the paper's figures.
"""

from __future__ import annotations

import json

import numpy as np
import pytest

from phd_swarm.logs.mcap_log import read_messages
from phd_swarm.nodes import topics as T
from phd_swarm.nodes.faces import gaussian_mixture

pytestmark = [pytest.mark.ros, pytest.mark.slow]


def test_the_summary_has_the_papers_figures(sung_run):
    summary = json.loads((sung_run / "summary.json").read_text())
    for name in ("components", "tracks", "weights_components", "mahal_closest",
                 "largest_variance", "ospa_tracks"):
        assert np.isfinite(summary["figures"][name]), name
    assert summary["system"]["exchange"] == "none"
    assert summary["system"]["options"]["gp_prediction"] is True


def test_tracks_keep_their_ids_and_confirmed_tracks_their_targets(sung_run):
    positions: dict[int, list[tuple[int, np.ndarray]]] = {}
    confirmed_at: dict[int, int] = {}
    newest = -1
    for rec in read_messages(sung_run / "run.mcap", topics=[T.robot_topic(0, "tracks")]):
        tracks = gaussian_mixture.tracks_from_ros(rec.msg, 10_000)
        k = int(rec.msg.step)
        # Ids are given in creation order and never reused.
        fresh = tracks.track_ids[tracks.life == 1]
        assert np.all(fresh > newest), k
        newest = max(newest, int(tracks.track_ids.max(initial=-1)))
        for tid, life, ok, xy in zip(tracks.track_ids, tracks.life, tracks.confirmed,
                                     tracks.positions, strict=True):
            assert ok == (life >= 3)
            positions.setdefault(int(tid), []).append((k, xy))
            if ok:
                confirmed_at.setdefault(int(tid), k)
    assert len(confirmed_at) >= 3, "tracks were confirmed"
    # A confirmed track that holds a target at consecutive steps moves a little (its
    # target is static: the estimate moves with the updates, not by metres).
    for tid in confirmed_at:
        seq = positions[tid]
        jumps = [float(np.hypot(*(b - a)))
                 for (i, a), (j, b) in zip(seq[:-1], seq[1:], strict=True) if j == i + 1]
        assert not jumps or np.median(jumps) < 2.0, (tid, jumps[:10])
