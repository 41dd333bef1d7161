"""What the papers' table tools share: reading sweeps, summing over seeds, figures, the CLI.

The per-paper tools (:mod:`.sung_tables`, :mod:`.shirsat_tables`,
:mod:`.papaioannou_tables`) turn sweep directories of :mod:`phd_swarm.tools.sweep` into the
papers' tables and figures. They share:

- :func:`read_results`: a ``results.csv`` read only (a row being appended is skipped),
  :class:`TablesError` naming what is wrong;
- :func:`over_seeds`: mean, sample sd and counts of per-run values, NaNs left out;
- :func:`figure_grid` and :func:`save_png`: one plotting style, a
  :class:`matplotlib.figure.Figure` on the Agg canvas (no pyplot state, no display), saved
  at :data:`DPI` and lowered while the file is above :data:`MAX_BYTES`;
- :func:`run`: the command line ``python -m phd_swarm.tools.<paper>_tables DIR [DIR ...]
  [--out OUT]``, which reads each sweep directory with the tool's ``build``, writes what
  its ``write`` makes into ``OUT`` (default: the first ``DIR``) and prints its Markdown; a
  directory that cannot be read is an error naming it (exit code 2).
"""

from __future__ import annotations

import argparse
import csv
import io
import math
import sys
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

#: Resolution of the PNG files [dots per inch]; lowered for a file above :data:`MAX_BYTES`.
DPI = 90

#: Largest PNG file wanted [bytes].
MAX_BYTES = 200_000


class TablesError(Exception):
    """A sweep directory the tables cannot be made from (missing, empty, inconsistent)."""


def over_seeds(values: Sequence[float]) -> dict[str, float]:
    """Mean, sample sd (``ddof=1``) and counts of per-run values, NaNs left out.

    Parameters
    ----------
    values : sequence of float
        One value per run (seed).

    Returns
    -------
    dict
        ``mean`` and ``sd`` (NaN if no or only one defined value for ``sd``), ``n_valid``
        (defined values) and ``n`` (runs).
    """
    v = np.asarray(values, dtype=float)
    ok = v[np.isfinite(v)]
    mean = float(ok.mean()) if len(ok) else math.nan
    sd = float(ok.std(ddof=1)) if len(ok) > 1 else math.nan
    return {"mean": mean, "sd": sd, "n_valid": int(len(ok)), "n": int(len(v))}


def read_results(path: Path) -> list[dict[str, str]]:
    """The rows of a ``results.csv``, read only (a last line being written is skipped).

    Parameters
    ----------
    path : Path
        The sweep directory.

    Returns
    -------
    list of dict
        One row per trial (the last row of a trial key that occurs twice).

    Raises
    ------
    TablesError
        No ``results.csv``, columns missing, or no finished trial.
    """
    csv_path = path / "results.csv"
    if not path.is_dir():
        raise TablesError(f"{path}: no such directory")
    if not csv_path.is_file():
        raise TablesError(f"{path}: no results.csv (not a sweep directory?)")
    text = csv_path.read_text()
    if text and not text.endswith("\n"):
        text = text[: text.rfind("\n") + 1]  # a row being appended: not finished
    reader = csv.DictReader(io.StringIO(text))
    missing = {"trial", "method", "seed"} - set(reader.fieldnames or ())
    if missing:
        raise TablesError(f"{csv_path}: columns {sorted(missing)} missing")
    rows = {r["trial"]: r for r in reader}
    if not rows:
        raise TablesError(f"{csv_path}: no finished trial")
    return list(rows.values())


def figure_grid(n: int, width: float, height: float, cols: int = 3
                ) -> tuple[Figure, list]:
    """A figure of ``n`` panels, ``cols`` to a row, each ``width`` x ``height`` inches.

    The figure is on the Agg canvas (no pyplot, no display); unused cells are hidden.
    """
    cols = max(1, min(n, cols))
    rows = -(-n // cols)
    fig = Figure(figsize=(width * cols, height * rows), layout="constrained")
    FigureCanvasAgg(fig)
    axes = fig.subplots(rows, cols, squeeze=False).ravel().tolist()
    for ax in axes[n:]:
        ax.set_visible(False)
    return fig, axes[:n]


def save_png(fig: Figure, path: Path, dpi: int = DPI, max_bytes: int = MAX_BYTES) -> Path:
    """Save ``fig`` at ``dpi``, then at lower resolutions while above ``max_bytes``."""
    fig.savefig(path, dpi=dpi)
    while path.stat().st_size > max_bytes and dpi > 50:
        dpi = int(dpi * 0.8)
        fig.savefig(path, dpi=dpi)
    return path



def run(argv: Sequence[str] | None, name: str, description: str,
        build: Callable[[Path], Any], write: Callable[[list[Any], Path], str]) -> int:
    """Parse ``argv``, build every directory's table, write them; the exit code.

    Parameters
    ----------
    argv : sequence of str or None
        Arguments without the program name (None: ``sys.argv[1:]``).
    name : str
        The tool's module name (``shirsat_tables``), for usage and errors.
    description : str
        The tool's one-line description.
    build : callable
        ``build(directory) -> table``; raises on a directory it cannot read.
    write : callable
        ``write(tables, out) -> markdown``: writes the tool's files into ``out``.
    """
    p = argparse.ArgumentParser(prog=f"python -m phd_swarm.tools.{name}",
                                description=description)
    p.add_argument("dirs", nargs="+", type=Path, help="sweep directories")
    p.add_argument("--out", type=Path, help="output directory (default: the first DIR)")
    args = p.parse_args(argv)
    try:
        tables = [build(d) for d in args.dirs]
    except (TablesError, OSError, KeyError, ValueError) as exc:
        print(f"{name}: {exc}", file=sys.stderr)
        return 2
    out = args.out or args.dirs[0]
    out.mkdir(parents=True, exist_ok=True)
    print(write(tables, out))
    print(f"wrote the {name} files into {out}")
    return 0
