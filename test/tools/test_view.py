"""``--view``: a run and a replayed log watched in headless Chromium, through their scripts.

Each test runs the public command (``run_swarm`` / ``replay`` with ``--view --view-hold``),
opens the URL it prints in headless Chromium over the DevTools pipe, waits until the
robots and the targets are drawn (:func:`phd_swarm.tools.view_shots.map_drawn`), keeps the
screenshot, stops the command by PID, and then checks the data the view received, read
back from the ``.rrd`` the viewer wrote with the same recording stream: every step of
every per-step entity, and as many robots as the run has.

Marked ``full``: they need rerun-sdk and chromium, which ``scripts/test.sh --full`` (CI)
installs (``scripts/setup.sh --with-view``).
"""

from __future__ import annotations

import json
import re
from pathlib import Path

import pytest

from phd_swarm.testing import fresh_domain_id, loopback_env
from phd_swarm.tools.browser_shot import colour_count, png_pixels
from phd_swarm.tools.view_shots import (
    DRAWN_TOL,
    ROBOT_BLUE,
    ROOT,
    TARGET_RED,
    run_swarm_command,
    shoot_command,
    view_contents,
)

pytestmark = [pytest.mark.ros, pytest.mark.slow, pytest.mark.full]

ROBOTS, STEPS, DT = 4, 16, 0.5
OPTIONS = ("--robots", str(ROBOTS), "--targets", "10", "--duration", str(STEPS * DT),
           "--seed", "3")
URL = re.compile(r"live view at http://127\.0\.0\.1:\d+/\?url=rerun%2Bhttp%3A%2F%2F"
                 r"127\.0\.0\.1%3A\d+%2Fproxy\n")

#: Entities drawn once per step in a Dames run (the world's, the monitor's, the metrics).
PER_STEP = ("/view/map/world/markers/robots/points", "/view/map/world/markers/targets/points",
            "/view/map/world/markers/fov/lines", "/view/map/monitor/markers/cells/lines",
            "/view/map/monitor/markers/goals/points", "/view/map/monitor/density",
            "/metrics/ospa/total", "/metrics/cardinality/true", "/metrics/robots/alive")


def check_drawn(png: Path) -> None:
    pixels = png_pixels(png.read_bytes())
    assert colour_count(pixels, ROBOT_BLUE, DRAWN_TOL) >= 40
    assert colour_count(pixels, TARGET_RED, DRAWN_TOL) >= 40
    assert pixels.shape == (1000, 1600, 3)


def check_contents(rrd: Path, times: list[float]) -> None:
    contents = view_contents(rrd)
    for entity in PER_STEP:
        assert contents[entity]["times"] == times, entity
    assert contents["/view/map/world/markers/robots/points"]["instances"] == ROBOTS
    assert contents["/view/map/trails"]["instances"] == ROBOTS


@pytest.fixture(scope="module")
def viewed_run(tmp_path_factory):
    """A short Dames run with --view, screenshot taken while it holds the view."""
    out = tmp_path_factory.mktemp("view")
    cmd = run_swarm_command("config/dames_static.yaml", OPTIONS, out, "viewed")
    output = shoot_command(cmd, out / "live.png", env=loopback_env(fresh_domain_id()))
    return out, output


def test_a_run_with_view_is_drawn_live_in_the_browser(viewed_run):
    out, output = viewed_run
    assert URL.search(output), output       # on loopback, printed
    assert "the view stays at" in output
    check_drawn(out / "live.png")
    run = out / "viewed"
    summary = json.loads((run / "summary.json").read_text())
    assert summary["steps"] == STEPS and not summary["dead_robots"]
    assert "log complete" in output
    check_contents(run / "view.rrd", [k * DT for k in range(STEPS)])


def test_a_recorded_log_replayed_with_view_is_drawn_the_same(viewed_run, tmp_path):
    out, _ = viewed_run
    log = out / "viewed" / "run.mcap"
    cmd = [str(ROOT / "scripts" / "replay.sh"), str(log), "--fast", "--view", "--view-hold",
           "--view-save", str(tmp_path / "replay.rrd")]
    output = shoot_command(cmd, tmp_path / "replay.png", env=loopback_env(fresh_domain_id()))
    assert URL.search(output), output
    assert re.search(r"replaying .*run\.mcap: \d+ topics", output)
    check_drawn(tmp_path / "replay.png")
    viewer_log = (out / "viewed" / "logs" / "replay_viewer.log").read_text()
    assert f"{STEPS + 1} steps, {ROBOTS} robots" in viewer_log   # and the world's last
    check_contents(tmp_path / "replay.rrd", [k * DT for k in range(STEPS)])


def test_view_without_rerun_fails_before_starting_anything(tmp_path, children):
    """A machine without the view's extra: a clear error, exit 1, nothing started."""
    # a rerun_cli package without its binary, found first
    (tmp_path / "rerun_cli").mkdir()
    (tmp_path / "rerun_cli" / "__init__.py").write_text("")
    path = f"{tmp_path}:{loopback_env(0).get('PYTHONPATH', '')}"
    proc = children.start(run_swarm_command("config/dames_static.yaml", OPTIONS, tmp_path,
                                            "noview"), env={"PYTHONPATH": path})
    _, stderr = proc.communicate(timeout=120)
    assert proc.returncode == 1
    assert "the live view needs rerun-sdk: scripts/setup.sh --with-view" in stderr
    assert not (tmp_path / "noview" / "logs" / "world.log").exists()
