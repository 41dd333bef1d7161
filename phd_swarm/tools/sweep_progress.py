"""A sweep's progress on stderr: done/total, elapsed time and the ETA, trial by trial.

:class:`Progress` is shared by the local process pool (:func:`phd_swarm.tools.sweep.run_trials`)
and the Dask cluster (:mod:`phd_swarm.tools.sweep_cluster`): a bar redrawn in place on a
terminal, one line per finished trial otherwise (logs, ``nohup``).
"""

from __future__ import annotations

import math
import time
from typing import IO

from phd_swarm.config.sweep_spec import Trial


def _hms(seconds: float) -> str:
    """``seconds`` as ``12s``, ``3m05s`` or ``2h07m`` (``?`` if not finite)."""
    if not math.isfinite(seconds):
        return "?"
    s = int(round(seconds))
    if s >= 3600:
        return f"{s // 3600}h{s % 3600 // 60:02d}m"
    if s >= 60:
        return f"{s // 60}m{s % 60:02d}s"
    return f"{s}s"


class Progress:
    """Progress on a stream: a bar redrawn in place on a TTY, else one line per trial.

    The ETA scales the time spent so far by the estimated cost still to run
    (:meth:`Trial.cost`), so big trials count for more than small ones.
    """

    def __init__(self, name: str, todo: list[Trial], skipped: int, stream: IO[str],
                 tty: bool | None = None) -> None:
        self.name = name
        self.total = len(todo) + skipped
        self.done = skipped
        self.failed = 0
        self.stream = stream
        self.tty = stream.isatty() if tty is None else tty
        self.cost_left = sum(t.cost() for t in todo)
        self.cost_done = 0.0
        self.t0 = time.monotonic()
        self._drawn = False

    def eta(self) -> float:
        """Estimated seconds to the end (inf before the first trial ends)."""
        if self.cost_done <= 0:
            return math.inf
        return (time.monotonic() - self.t0) * self.cost_left / self.cost_done

    def _status(self) -> str:
        el = time.monotonic() - self.t0
        fail = f", {self.failed} failed" if self.failed else ""
        return (f"{self.done}/{self.total}{fail}  elapsed {_hms(el)}  "
                f"ETA {_hms(self.eta()) if self.cost_left > 0 else '0s'}")

    def tick(self) -> None:
        """Redraw the bar (TTY only)."""
        if not self.tty:
            return
        width = 28
        filled = int(width * self.done / self.total) if self.total else width
        bar = "#" * filled + "-" * (width - filled)
        self.stream.write(f"\r\x1b[Ksweep {self.name} [{bar}] {self._status()}")
        self.stream.flush()
        self._drawn = True

    def finished(self, trial: Trial, row: dict | None, error: str | None) -> None:
        """Count a trial as done (or failed) and report it."""
        self.cost_left -= trial.cost()
        self.cost_done += trial.cost()
        self.done += 1
        if error is not None:
            self.failed += 1
            self.message(f"trial {trial.key} failed: {error}")
        elif not self.tty:
            assert row is not None
            final = ("" if row["metric"] == "final"
                     else f" (final {row['ospa_final']:.3f} m)")
            self.stream.write(f"sweep {self.name}: {trial.key}: {row['metric']} OSPA "
                              f"{row['value']:.3f} m{final}, {row['wall_s']:.1f} s | "
                              f"{self._status()}\n")
            self.stream.flush()
        self.tick()

    def message(self, text: str) -> None:
        """Print a line above the bar."""
        if self.tty and self._drawn:
            self.stream.write("\r\x1b[K")
        self.stream.write(text + "\n")
        self.stream.flush()
        self.tick()

    def close(self) -> None:
        """End the bar's line."""
        if self.tty and self._drawn:
            self.stream.write("\n")
            self.stream.flush()
