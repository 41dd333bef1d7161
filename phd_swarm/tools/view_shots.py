"""Screenshots of the live view: a short run (or a replayed log) with ``--view``, in Chromium.

``python -m phd_swarm.tools.view_shots [--out docs/images] [SYSTEM ...]`` runs each
system's short demo with ``scripts/run_swarm.sh CONFIG --view --view-hold``, opens the
URL it prints in headless Chromium (:mod:`phd_swarm.tools.browser_shot`), waits until the
robots and the targets are drawn, saves ``view_<system>.png`` and stops the run by PID.
The pictures in README and docs/view.md are made with it; the tests of ``--view`` use
:func:`shoot_command` the same way.

What "drawn" means (:func:`map_drawn`): pixels of the world markers' robot blue and target
red (:data:`phd_swarm.nodes.markers.COLOURS`, as the browser draws them, within a
tolerance), so a blank page, a viewer without data or a map without robots fails.
"""

from __future__ import annotations

import argparse
import re
import subprocess
import sys
import time
from collections.abc import Callable, Sequence
from pathlib import Path

import numpy as np

from phd_swarm.tools.browser_shot import Browser, BrowserError, colours_check
from phd_swarm.tools.processes import stop_process_group

#: The short demo of each system: config and run_swarm options.
SYSTEMS: dict[str, tuple[str, tuple[str, ...]]] = {
    "dames": ("config/dames_static.yaml", ("--robots", "12", "--duration", "40")),
    "chen": ("config/chen_clustered.yaml", ("--robots", "12", "--duration", "40")),
    "sung": ("config/sung_moving.yaml", ("--duration", "300")),
    "shirsat": ("config/shirsat_small.yaml", ("--robots", "6", "--duration", "60")),
    "papaioannou": ("config/papaioannou_small.yaml", ("--duration", "60")),
}

#: The repository (scripts/ and config/).
ROOT = Path(__file__).resolve().parents[2]

#: RGB of the robots' spheres and the true targets, as the world's markers colour them.
ROBOT_BLUE = (31, 120, 181)
TARGET_RED = (214, 38, 41)

#: The line a command with ``--view`` prints with the view's URL.
_URL = re.compile(r"live view at (http://127\.0\.0\.1:\d+/\S+)")
_HOLDING = "the view stays at"


#: Colour tolerance of :func:`map_drawn` per channel: the browser anti-aliases and blends.
DRAWN_TOL = 40


def map_drawn(min_pixels: int = 40) -> Callable[[np.ndarray], str]:
    """A :meth:`Browser.shot_until` check: robots (blue) and targets (red) on the map."""
    return colours_check((ROBOT_BLUE, TARGET_RED), min_pixels, DRAWN_TOL)


def shoot_command(cmd: Sequence[str], out: Path, env: dict[str, str] | None = None,
                  log: Path | None = None, start_timeout: float = 300.0,
                  draw_timeout: float = 120.0, settle: float = 3.0) -> str:
    """Run ``cmd`` (a command with ``--view --view-hold``), screenshot its view, stop it.

    Waits for the command to print that it holds the view (the run is over and the view
    has all of it), opens the URL it printed, waits until :func:`map_drawn` passes, waits
    ``settle`` s more for the rest to be drawn, saves the PNG to ``out``, then stops the
    command with SIGINT (SIGKILL to its group after 30 s). Returns the command's output.

    Raises
    ------
    RuntimeError
        If the command ends or does not hold the view in time, or the view is not drawn.
    """
    log = log or out.with_suffix(".log")
    with open(log, "w") as sink:
        proc = subprocess.Popen(list(cmd), env=env, stdin=subprocess.DEVNULL, stdout=sink,
                                stderr=subprocess.STDOUT, start_new_session=True)
    try:
        url = _wait_holding(proc, log, start_timeout)
        with Browser() as browser:
            browser.open(url)
            browser.shot_until(map_drawn(), timeout=draw_timeout)
            time.sleep(settle)
            out.write_bytes(browser.screenshot())
    except BrowserError as exc:
        raise RuntimeError(f"{' '.join(cmd)}: {exc}") from None
    finally:
        stop_process_group(proc, 30.0)
    return log.read_text()


def _wait_holding(proc: subprocess.Popen, log: Path, timeout: float) -> str:
    deadline = time.monotonic() + timeout
    while True:
        text = log.read_text()
        match = _URL.search(text)
        if match and _HOLDING in text:
            return match.group(1)
        if proc.poll() is not None:
            raise RuntimeError(f"the command ended ({proc.returncode}) without holding its "
                               f"view; its output:\n{text[-3000:]}")
        if time.monotonic() > deadline:
            raise RuntimeError(f"the command did not hold its view within {timeout:.0f} s")
        time.sleep(0.5)


def view_contents(rrd: Path) -> dict[str, dict[str, object]]:
    """What a saved view holds, read with rerun-sdk's chunk reader.

    Per entity: its ``sim_time`` stamps [s] (sorted, unique) and the largest number of
    instances (points, strips) in one row. The tests compare it with the run: one stamp
    per step on every per-step entity, as many robot points as robots.
    """
    from rerun.chunk import RrdReader

    times: dict[str, set[float]] = {}
    sizes: dict[str, int] = {}
    for chunk in RrdReader(str(rrd)).store().stream():
        batch = chunk.to_record_batch()
        names = batch.schema.names
        entity = chunk.entity_path
        if "sim_time" in names:
            stamps = batch.column(names.index("sim_time")).cast("int64").to_numpy()
            times.setdefault(entity, set()).update((stamps * 1e-9).round(6).tolist())
        for name in names:
            if name.endswith((":positions", ":strips")):
                lengths = batch.column(names.index(name)).value_lengths().to_numpy(
                    zero_copy_only=False)
                sizes[entity] = max(sizes.get(entity, 0), int(lengths.max(initial=0)))
    return {e: {"times": sorted(times.get(e, ())), "instances": sizes.get(e, 0)}
            for e in sorted(set(times) | set(sizes))}


def run_swarm_command(config: str, options: Sequence[str], out_dir: Path, name: str
                      ) -> list[str]:
    """``scripts/run_swarm.sh CONFIG ... --view --view-hold``."""
    return [str(ROOT / "scripts" / "run_swarm.sh"), str(ROOT / config), *options, "--out",
            str(out_dir), "--name", name, "--quiet", "--view", "--view-hold"]


def main(argv: Sequence[str] | None = None) -> int:
    """Write ``view_<system>.png`` for the systems asked (all by default)."""
    parser = argparse.ArgumentParser(prog="view_shots", description=__doc__.split("\n")[0])
    parser.add_argument("systems", nargs="*", metavar="SYSTEM",
                        help=f"some of {', '.join(SYSTEMS)} (default all)")
    parser.add_argument("--out", type=Path, default=Path("docs/images"))
    parser.add_argument("--runs", type=Path, default=Path("runs/view_shots"))
    args = parser.parse_args(argv)
    unknown = sorted(set(args.systems) - set(SYSTEMS))
    if unknown:
        parser.error(f"unknown systems {unknown}; known: {', '.join(SYSTEMS)}")
    args.out.mkdir(parents=True, exist_ok=True)
    args.runs.mkdir(parents=True, exist_ok=True)
    for system in args.systems or list(SYSTEMS):
        config, options = SYSTEMS[system]
        png = args.out / f"view_{system}.png"
        cmd = run_swarm_command(config, options, args.runs, system)
        try:
            shoot_command(cmd, png, log=args.runs / f"{system}.log")
        except RuntimeError as exc:
            print(f"view_shots: {system}: {exc}", file=sys.stderr)
            return 1
        print(f"view_shots: wrote {png}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
