"""Shards of a sweep, for job arrays without Dask: ``--shard K/N`` and ``--merge DIR...``.

Shard K of N (K = 1..N) holds the trials at the positions p of the spec's full trial list
(:meth:`SweepSpec.trials_list`, a fixed order) with ``p mod N = K - 1``. The key depends
on the spec alone, never on what is done already, so the N shards are disjoint, cover the
sweep, and are the same on every machine. Neighbouring positions are the methods and team
sizes of one seed, so every shard gets a like mix of big and small trials.

A shard writes to ``<out>/shard-K-of-N/`` (``results.csv``, ``series/``, ``logs/``,
``sweep.json``), resumable as any sweep folder. :func:`merge` then appends the rows of the
shard folders to ``<out>/results.csv`` in the order a one-worker run writes them
(:func:`phd_swarm.tools.sweep.run_order`), copies their series and logs, and refuses a
row that is no trial of the spec, that two folders both hold, or that disagrees with a
row already there; rows already there and equal are skipped, so merging again after a
shard has run further adds only its new rows.
"""

from __future__ import annotations

import json
import re
import shutil
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from phd_swarm.config.sweep_spec import SpecError, SweepSpec, Trial
from phd_swarm.tools.sweep import _log_session, run_order
from phd_swarm.tools.sweep_results import COLUMNS, TIMING_COLUMNS, ResultsFile

_SHARD = re.compile(r"^\s*(\d+)\s*/\s*(\d+)\s*$")


@dataclass(frozen=True)
class Shard:
    """Shard ``k`` of ``n`` (1 <= k <= n) of a sweep's trials."""

    k: int
    n: int

    @classmethod
    def parse(cls, text: str) -> Shard:
        """``"K/N"`` as a shard; ValueError naming what is wrong."""
        m = _SHARD.match(text)
        if m is None:
            raise ValueError(f"expected K/N (shard K of N, e.g. 2/8), got {text!r}")
        k, n = int(m[1]), int(m[2])
        if not 1 <= k <= n:
            raise ValueError(f"expected 1 <= K <= N in K/N, got {text!r}")
        return cls(k, n)

    @property
    def label(self) -> str:
        """The shard's folder name, ``shard-K-of-N``."""
        return f"shard-{self.k}-of-{self.n}"

    def select(self, trials: Sequence[Trial]) -> list[Trial]:
        """The trials of this shard: positions p of ``trials`` with p mod n = k - 1.

        ``trials`` is the spec's full list (:meth:`SweepSpec.trials_list`), whatever is
        done already.
        """
        return [t for p, t in enumerate(trials) if p % self.n == self.k - 1]


def differing(a: dict[str, Any], b: dict[str, Any]) -> list[str]:
    """Columns of two results.csv rows (parsed) that differ, timings aside."""
    return [c for c in COLUMNS if c not in TIMING_COLUMNS and a[c] != b[c]]


def merge(spec: SweepSpec, sources: Sequence[Path], results: ResultsFile, out: Path) -> int:
    """Append the rows of the shard folders ``sources`` to ``results`` (in ``out``).

    Every row is checked before anything is written: it must be a trial of ``spec`` with
    its ``config_hash``, held by one source only, and, if ``results`` has it already,
    equal to that row but for the timings (then it is skipped). The new rows are appended
    in the order a sweep runs the trials (:func:`run_order`), each after its series (and
    log) is copied. ``out/spec.json`` is written, and the sources' sessions (their
    ``sweep.json``) not yet in ``out/sweep.json`` are added to it, each with
    ``merged_from`` set to its folder's name.

    Parameters
    ----------
    spec : SweepSpec
        The sweep (the form and engine the shards ran).
    sources : sequence of Path
        Folders of shard runs, each with a ``results.csv``.
    results : ResultsFile
        ``out/results.csv``.
    out : Path
        The merged sweep's folder.

    Returns
    -------
    int
        Rows appended.

    Raises
    ------
    SpecError
        A source without results.csv, a row of another spec, a trial in two sources, a
        row that disagrees with the stored one, or a row whose series is missing.
    """
    trials = run_order(spec.trials_list())
    by_key = {t.key: t for t in trials}
    seen: dict[str, Path] = {}
    new: dict[str, tuple[dict[str, Any], Path]] = {}
    for src in sources:
        path = src / "results.csv"
        if not path.is_file():
            raise SpecError(f"{src}: no results.csv; expected the folder of a shard "
                            f"(<out>/shard-K-of-N)")
        for key, row in ResultsFile(path).rows.items():
            trial = by_key.get(key)
            if trial is None or row["config_hash"] != trial.config_hash:
                what = "not a trial" if trial is None else "a trial run with other settings"
                raise SpecError(f"{path}: row {key} is {what} of this spec; were the shards "
                                f"run with the same spec, --quick and --engine?")
            if key in seen:
                raise SpecError(f"trial {key} is in both {seen[key]} and {src}: shards "
                                f"overlap (were they all made with the same N?)")
            seen[key] = src
            stored = results.rows.get(key)
            if stored is not None:
                diff = differing(stored, row)
                if diff:
                    raise SpecError(f"{path}: row {key} disagrees with {results.path} in "
                                    f"{', '.join(diff)}")
                continue
            if not (src / "series" / f"{key}.npz").is_file():
                raise SpecError(f"{src / 'series' / f'{key}.npz'}: missing; the series of "
                                f"row {key} of {path}")
            new[key] = (row, src)
    (out / "series").mkdir(parents=True, exist_ok=True)
    (out / "spec.json").write_text(json.dumps(spec.to_dict(), indent=2) + "\n")
    for t in trials:
        if t.key not in new:
            continue
        row, src = new[t.key]
        shutil.copyfile(src / "series" / f"{t.key}.npz", out / "series" / f"{t.key}.npz")
        log = src / "logs" / f"{t.key}.log"
        if log.is_file():
            (out / "logs").mkdir(exist_ok=True)
            shutil.copyfile(log, out / "logs" / log.name)
        results.append(row)
    for session in _new_sessions(sources, out):
        _log_session(out, session)
    return len(new)


def _sessions(path: Path) -> list[dict[str, Any]]:
    try:
        return list(json.loads(path.read_text()).get("sessions", []))
    except (OSError, json.JSONDecodeError, AttributeError):
        return []


def _new_sessions(sources: Sequence[Path], out: Path) -> list[dict[str, Any]]:
    """The sources' sessions not yet logged in ``out/sweep.json``, tagged ``merged_from``."""
    known = {(s.get("merged_from"), s.get("started")) for s in _sessions(out / "sweep.json")}
    fresh = []
    for src in sources:
        for s in _sessions(src / "sweep.json"):
            if (src.name, s.get("started")) not in known:
                fresh.append({**s, "merged_from": src.name})
    return fresh
