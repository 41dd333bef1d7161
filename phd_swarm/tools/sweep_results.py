"""A sweep's files: ``results.csv`` (one row per finished trial) and the per-step series.

:class:`ResultsFile` reads the finished rows of a ``results.csv`` (a row cut short by a
crash is dropped, its trial runs again) and appends new ones one by one, flushed and synced,
so a sweep stopped at any moment resumes where it was. :func:`save_series` writes a trial's
per-step series atomically (``series/<trial>.npz``), :func:`load_series` reads them.
"""

from __future__ import annotations

import csv
import io
import os
from pathlib import Path
from typing import Any

import numpy as np

from phd_swarm.config.sweep_spec import SpecError
from phd_swarm.core import registry


def declared_counters() -> tuple[str, ...]:
    """The protocol counters the built-in exchanges declare (their parts' ``counters``).

    In the order the exchanges (by name) declare them, each once: the columns a sweep sums
    over the team into results.csv (``voronoi_phd``'s: a missed neighbour and what it cost,
    peers declared dead by a timeout and the bins lost with them). A plugin's exchange keeps
    its counters in its robots' ``stats``; they are not columns.
    """
    out: list[str] = []
    for name in sorted(registry.BUILTIN_PARTS["exchange"]):
        out += [c for c in registry.lookup("exchange", name).counters if c not in out]
    return tuple(out)


#: Robot protocol counters summed over the team into results.csv (:func:`declared_counters`).
PROTOCOL_COLUMNS = declared_counters()

#: Columns of results.csv, in order.
COLUMNS = ("spec", "trial", "method", "controller", "engine", "robots", "targets",
           "resolution", "seed", "trial_index", "steps", "duration_s", "metric", "value",
           "ospa_final", "ospa_mean_window", "ospa_median_window", "window_start_s",
           "window_end_s", "cardinality_true_final", "cardinality_est_final",
           "expected_cardinality_final", "cardinality_true_mean_window", *PROTOCOL_COLUMNS,
           "wall_s", "cpu_s", "config_hash")

#: Columns that differ between two runs of the same trial (timings).
TIMING_COLUMNS = ("wall_s", "cpu_s")

#: Per-step series saved for each trial (``series/<trial>.npz``).
SERIES = ("t", "ospa", "ospa_localisation", "ospa_cardinality", "cardinality_true",
          "cardinality_est", "expected_cardinality")

_INT_COLUMNS = ("robots", "targets", "seed", "trial_index", "steps",
                "cardinality_true_final", "cardinality_est_final", *PROTOCOL_COLUMNS)
_FLOAT_COLUMNS = ("resolution", "duration_s", "value", "ospa_final", "ospa_mean_window",
                  "ospa_median_window", "window_start_s", "window_end_s",
                  "expected_cardinality_final", "cardinality_true_mean_window", "wall_s",
                  "cpu_s")



class ResultsFile:
    """results.csv: read the finished rows, append new ones one by one, flushed.

    Parameters
    ----------
    path : Path
        The CSV file (created with a header if missing).
    """

    def __init__(self, path: Path) -> None:
        self.path = path
        self.rows: dict[str, dict[str, Any]] = {}
        if path.exists():
            self._read()

    def _read(self) -> None:
        text = self.path.read_text()
        if text and not text.endswith("\n"):
            # A row cut short by a crash: drop it, its trial runs again.
            text = text[: text.rfind("\n") + 1]
            self.path.write_text(text)
        if not text:
            return
        reader = csv.DictReader(io.StringIO(text))
        if tuple(reader.fieldnames or ()) != COLUMNS:
            raise SpecError(f"{self.path}: columns {reader.fieldnames} are not those of "
                            f"this version of the sweep tool; use another --out")
        for line, raw in enumerate(reader, start=2):
            try:
                self.rows[raw["trial"]] = parse_row(raw)
            except (TypeError, ValueError) as exc:
                raise SpecError(f"{self.path}: line {line}: {exc}") from None

    def append(self, row: dict[str, Any]) -> None:
        """Append ``row`` and flush it to disk."""
        new = not self.path.exists() or self.path.stat().st_size == 0
        with open(self.path, "a", newline="") as f:
            w = csv.DictWriter(f, fieldnames=COLUMNS)
            if new:
                w.writeheader()
            w.writerow(row)
            f.flush()
            os.fsync(f.fileno())
        self.rows[row["trial"]] = row


def parse_row(raw: dict[str, str]) -> dict[str, Any]:
    """A results.csv row with its numbers parsed."""
    row: dict[str, Any] = dict(raw)
    for c in _INT_COLUMNS:
        row[c] = int(raw[c])
    for c in _FLOAT_COLUMNS:
        row[c] = float(raw[c])
    return row


def save_series(path: Path, series: dict[str, np.ndarray], config_hash: str) -> None:
    """Write ``series`` to ``path`` (.npz) atomically, in float32 but for ``t``.

    The series are for plots and per-run averages (the row of results.csv holds a trial's
    figures exactly); float32's 7 digits halve the files of long runs (a 7,278-step
    Sung & Tokekar trial saves 17 series). Series written before 2026-12-02 are float64.
    """
    compact = {k: (v if k == "t" or not np.issubdtype(np.asarray(v).dtype, np.floating)
                   else np.asarray(v, dtype=np.float32)) for k, v in series.items()}
    tmp = path.with_suffix(".tmp")
    with open(tmp, "wb") as f:
        np.savez_compressed(f, config_hash=np.array(config_hash), **compact)
    os.replace(tmp, path)


def load_series(path: Path) -> dict[str, np.ndarray]:
    """The per-step series of one trial (:data:`SERIES` and ``config_hash``)."""
    with np.load(path) as z:
        return {k: z[k] for k in z.files}


