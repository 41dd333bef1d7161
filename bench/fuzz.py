"""Fuzz benchmark: every decoder and loader, coverage-guided, for a time budget.

Run with ``scripts/bench.sh fuzz [--minutes 10] [--targets cdr/,wire/] [--quick]``.
Each target of :mod:`phd_swarm.tools.fuzz_targets` runs in its own process under atheris
(libFuzzer with Python coverage, ``bench/fuzz_child.py``) for its share of the minutes,
starting from its valid seeds. A target's run ends at its time, or at its first finding:
an input it does not survive (an exception other than its clear error, an error that does
not name its file, or an input taking longer than ``--hang-s``). For each target it prints
and writes (``bench/results/fuzz-<date>.json``):

- ``executions``, ``executions_per_s``: inputs tried, and how fast;
- ``corpus``: inputs kept for new coverage (libFuzzer's ``new_units_added``);
- ``finding``: None, or the kind (``crash``, ``hang``, ``memory``), the error's first line
  and the input's file (kept under ``--out``; ``bench/fuzz_child.py TARGET FILE`` replays it).

Exit code 1 if any target has a finding. ``--quick``: 5 s per target. Every process is
stopped by PID (its process group), whatever happens.
"""

from __future__ import annotations

import argparse
import os
import re
import signal
import subprocess
import sys
import tempfile
from pathlib import Path

from results_io import machine_meta, write_results

from phd_swarm.tools.fuzz_targets import targets

CHILD = Path(__file__).with_name("fuzz_child.py")
RESULTS = Path(__file__).with_name("results")
_STAT = re.compile(r"^stat::(\w+):\s+(\d+)", re.M)


def parse_args(argv: list[str]) -> argparse.Namespace:
    """The command line (see the module docstring)."""
    p = argparse.ArgumentParser(prog="scripts/bench.sh fuzz", description=__doc__.split("\n")[0])
    p.add_argument("--minutes", type=float, default=10.0,
                   help="time for all targets together [min] (default 10)")
    p.add_argument("--targets", default="",
                   help="comma-separated name prefixes (default: every target)")
    p.add_argument("--hang-s", type=int, default=10,
                   help="an input taking longer is a finding [s] (default 10)")
    p.add_argument("--quick", action="store_true", help="5 s per target")
    p.add_argument("--out", type=Path, default=RESULTS, help="where results and findings go")
    return p.parse_args(argv)


def chosen(prefixes: str) -> list[str]:
    """Target names starting with one of the comma-separated ``prefixes`` (all if empty)."""
    wanted = [p for p in prefixes.split(",") if p]
    found = [n for n in targets() if not wanted or any(n.startswith(p) for p in wanted)]
    if not found:
        raise SystemExit(f"fuzz: no target starts with {prefixes!r}; the targets are "
                         f"{', '.join(targets())}")
    return found


def run_target(name: str, seconds: int, hang_s: int, out: Path) -> dict[str, object]:
    """One target under atheris for ``seconds``; its figures and finding."""
    safe = name.replace("/", "_")
    with tempfile.TemporaryDirectory(prefix="phd_swarm_fuzz_corpus_") as corpus:
        for i, seed in enumerate(targets()[name].seeds()):
            Path(corpus, f"seed{i}").write_bytes(seed)
        prefix = out / "fuzz_findings" / f"{safe}-"
        prefix.parent.mkdir(parents=True, exist_ok=True)
        cmd = [sys.executable, str(CHILD), name, f"-max_total_time={seconds}",
               f"-timeout={hang_s}", "-rss_limit_mb=4096", "-print_final_stats=1",
               f"-artifact_prefix={prefix}", corpus]
        proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                                text=True, start_new_session=True)
        try:
            text, _ = proc.communicate(timeout=seconds + 120)
        finally:
            if proc.poll() is None:
                os.killpg(proc.pid, signal.SIGKILL)
                proc.wait()
    stats = {k: int(v) for k, v in _STAT.findall(text)}
    execs = stats.get("number_of_executed_units", 0)
    return {"target": name, "seconds": seconds, "executions": execs,
            "executions_per_s": stats.get("average_exec_per_sec", 0),
            "corpus": stats.get("new_units_added", 0), "exit_code": proc.returncode,
            "finding": finding(text, proc.returncode)}


def finding(text: str, code: int) -> dict[str, str] | None:
    """What a child's output says it found, or None for a clean run."""
    artifact = re.search(r"Test unit written to (\S+)", text)
    if code == 0 and artifact is None:
        return None
    kind = ("hang" if "ERROR: libFuzzer: timeout" in text else
            "memory" if "out-of-memory" in text else "crash")
    error = re.search(r"^(\S*(?:Finding|Error|Exception)\S*: .*)$", text, re.M)
    return {"kind": kind, "error": error.group(1)[:300] if error else text.strip()[-300:],
            "input": artifact.group(1) if artifact else ""}


def main(argv: list[str] | None = None) -> int:
    """Fuzz the chosen targets one after the other; 1 if any has a finding."""
    opts = parse_args(sys.argv[1:] if argv is None else argv)
    names = chosen(opts.targets)
    seconds = 5 if opts.quick else max(int(opts.minutes * 60 / len(names)), 2)
    print(f"fuzz: {len(names)} targets, {seconds} s each, inputs slower than "
          f"{opts.hang_s} s are hangs")
    rows = []
    print(f"{'target':<34}{'executions':>12}{'exec/s':>9}{'corpus':>8}  finding")
    for name in names:
        row = run_target(name, seconds, opts.hang_s, opts.out)
        rows.append(row)
        f = row["finding"]
        print(f"{name:<34}{row['executions']:>12}{row['executions_per_s']:>9}"
              f"{row['corpus']:>8}  {'-' if f is None else f['kind'] + ': ' + f['error']}",
              flush=True)
    total = sum(r["executions"] for r in rows)
    found = [r for r in rows if r["finding"]]
    print(f"fuzz: {total} executions, {len(found)} findings")
    write_results(opts.out, "fuzz", machine_meta(seconds_per_target=seconds), rows)
    return 1 if found else 0


if __name__ == "__main__":
    sys.exit(main())
