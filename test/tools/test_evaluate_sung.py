"""scripts/evaluate.sh on a run of a system without a grid PHD: Sung & Tokekar's GM-PHD.

The session's recorded run (:func:`conftest.sung_run`: one robot, 400 steps, GP prediction,
20 % false positives) evaluated from its log alone: the robots' own estimates scored as the
monitor scores them, the estimator's figures from the logged components and tracks, equal
to the live monitor's and to the in-memory engine's; pictures; spoiled and partial logs.
"""

from __future__ import annotations

import csv
import json
from pathlib import Path

import numpy as np
import pytest
from rclpy.serialization import deserialize_message, serialize_message

from phd_swarm.core.estimators.sung.figures import FIGURES
from phd_swarm.core.scoring import score_estimates
from phd_swarm.nodes import topics as T
from phd_swarm.tools.evaluate import COLUMNS
from phd_swarm.tools.run_log import load_run
from phd_swarm_msgs.msg import GaussianMixture

from .conftest import SUNG_RECORDED
from .test_evaluate import _copy_rewriting, _copy_without, _evaluate, _is_png

pytestmark = [pytest.mark.ros, pytest.mark.slow]

COMPONENTS = T.robot_topic(0, "components")
#: Steps of the run checked against the in-memory engine.
ENGINE_STEPS = 100


@pytest.fixture(scope="module")
def evaluated(sung_run, tmp_path_factory):
    """The run evaluated through the CLI: (output directory, completed process)."""
    out = tmp_path_factory.mktemp("sung_eval")
    res = _evaluate(str(sung_run / "run.mcap"), "--out", str(out), "--snapshot", "100",
                    "--snapshot", str(SUNG_RECORDED["steps"] - 1))
    assert res.returncode == 0, res.stderr
    return out, res


def _rows(out: Path) -> list[dict[str, str]]:
    with open(out / "series.csv") as f:
        return list(csv.DictReader(f))


def test_evaluation_equals_the_monitor(sung_run, evaluated):
    out, res = evaluated
    assert "largest OSPA difference 0 m" in res.stdout
    assert "log: complete: " in res.stdout and "WARNING" not in res.stderr
    monitor = json.loads((sung_run / "summary.json").read_text())
    ev = json.loads((out / "evaluation.json").read_text())
    steps = SUNG_RECORDED["steps"]
    assert ev["steps"] == monitor["steps"] == steps
    # Same messages, same functions, same order of arithmetic: equal, not merely close.
    # Both files are written by json.dumps, whose floats are repr's shortest round-trip
    # digits, so equal floats stay equal through the files; no tolerance is needed.
    assert ev["ospa_series"] == monitor["ospa_series"]
    assert ev["monitor_agreement"] == {"steps_compared": steps, "max_abs_ospa_difference": 0.0,
                                       "steps_only_in_evaluation": 0}
    for key in ("ospa_final", "ospa_mean_last_half", "cardinality_true_final",
                "cardinality_est_final", "expected_cardinality_final"):
        assert ev[key] == monitor[key], key
    assert list(ev["figures"]) == list(FIGURES)
    assert ev["figures"] == monitor["figures"]
    assert ev["figures"]["tracks"] > 0 and ev["controller"] == "lawnmower"


def test_series_has_the_figures_and_the_pictures_are_drawn(evaluated):
    out, _ = evaluated
    rows = _rows(out)
    assert list(rows[0]) == [*COLUMNS, *FIGURES]
    assert [int(r["step"]) for r in rows] == list(range(SUNG_RECORDED["steps"]))
    assert all(int(r["windows"]) == 1 for r in rows)
    tracks = np.array([float(r["tracks"]) for r in rows])
    assert tracks.max() > 0 and np.all(tracks == np.round(tracks))
    for name in ("ospa.png", "figures.png", "snapshot_100s.png", "snapshot_399s.png"):
        assert _is_png(out / name), name


def _copy_spoiling(src: Path, dst: Path, topic: str, step: int, spoil) -> Path:
    """Rewrite ``src`` into ``dst`` with ``spoil(msg)`` applied to ``topic``'s step message."""
    def rewrite(name: str, k: int, data: bytes) -> bytes:
        if name != topic or k != step:
            return data
        msg = deserialize_message(data, GaussianMixture)
        spoil(msg)
        return serialize_message(msg)
    return _copy_rewriting(src, dst, rewrite)


def test_a_spoiled_components_message_is_a_clear_error(sung_run, tmp_path):
    def negate(msg: GaussianMixture) -> None:  # no longer positive definite
        msg.covariances = type(msg.covariances)("d", (-c for c in msg.covariances))

    bad = _copy_spoiling(sung_run / "run.mcap", tmp_path / "bad.mcap", COMPONENTS, 57, negate)
    res = _evaluate(str(bad), "--no-plots", "--out", str(tmp_path / "eval"))
    assert res.returncode == 1 and "Traceback" not in res.stderr
    assert f"{COMPONENTS} at step 57: covariances" in res.stderr


def test_missing_components_are_named(sung_run, tmp_path):
    gappy = _copy_without(sung_run / "run.mcap", tmp_path / "gappy.mcap",
                          lambda topic, k: topic == COMPONENTS and k in (5, 6))
    res = _evaluate(str(gappy), "--no-plots", "--out", str(tmp_path / "eval"))
    assert res.returncode == 0, res.stderr
    assert "WARNING: the log has gaps" in res.stderr
    assert f"{COMPONENTS} steps 5-6" in res.stderr
    ev = json.loads((tmp_path / "eval" / "evaluation.json").read_text())
    # A robot without all of its outputs has not reported the step (the monitor's rule).
    assert ev["steps"] == SUNG_RECORDED["steps"] - 2
    assert ev["monitor_agreement"]["max_abs_ospa_difference"] == 0.0

    none = _copy_without(sung_run / "run.mcap", tmp_path / "none.mcap",
                         lambda topic, k: topic == COMPONENTS)
    res = _evaluate(str(none), "--no-plots", "--out", str(tmp_path / "eval2"))
    assert res.returncode == 1
    assert "no step with the robots' estimates, components and tracks" in res.stderr


def test_evaluation_reproduces_the_in_memory_engine(sung_run, evaluated):
    """The figures and scores from the log are the engine's, bit for bit.

    The in-memory engine computes what the ROS robot computed (proven bit for bit in
    test/nodes/test_systems_inprocess.py), on the run's own scenario from the log's config.
    """
    from phd_swarm.engines.distributed import DistributedEngine

    out, _ = evaluated
    rows = _rows(out)[:ENGINE_STEPS]
    s = load_run(sung_run / "run.mcap").scenario
    engine = DistributedEngine(s)
    want: dict[str, list[float]] = {name: [] for name in (*FIGURES, "ospa")}
    for _ in range(ENGINE_STEPS):
        _, truth = engine.world.truth()
        engine.step()
        for name, value in engine.figures(truth).items():
            want[name].append(value)
        want["ospa"].append(score_estimates(*engine.team_estimates(), truth, s.ospa_c,
                                            s.ospa_p).ospa)
    assert sum(np.isfinite(want["mahal_closest"])) > ENGINE_STEPS // 2
    for name, values in want.items():
        # csv writes repr(float), which reads back to the same float (and nan to nan).
        got = np.array([float(r[name]) for r in rows])
        np.testing.assert_array_equal(got, np.array(values), err_msg=name)
