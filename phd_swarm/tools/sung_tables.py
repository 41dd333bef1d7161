"""Sung & Tokekar (2022) Tables I-V and Figs. 8-10 from the Sung sweeps' results.

Usage::

    python -m phd_swarm.tools.sung_tables DIR [DIR ...] [--out OUT]

``DIR`` is a sweep directory of :mod:`phd_swarm.tools.sweep` (``results.csv`` and
``series/<trial>.npz``, e.g. ``results/sweeps/sung_false_positives``). The outputs go into
``DIR``, or into ``OUT`` (``OUT/<name of DIR>`` when several directories are given):

- ``sung_tables.md``: per method (columns, as in the paper) the paper's table quantities,
  each as "mean ± sd over seeds" of the per-run value, the paper's number in parentheses
  where it has one (:data:`PAPER`);
- ``sung_counts_vs_time.png``: confirmed tracks and GM components over time (Fig. 8a-b);
- ``sung_mahalanobis_vs_time.png``: Mahalanobis distance of the true targets to the closest
  and second-closest confirmed track (Fig. 8c-d);
- ``sung_ospa_vs_time.png``: OSPA (p = 2, c = 100 m) of the estimate and of the confirmed
  tracks (Fig. 8e);
- ``sung_largest_variance_vs_time.png``: largest variance among the confirmed tracks
  (Fig. 10);
- ``sung_boxplots.png``: box plots over seeds per method of the per-run mean tracks,
  components, sum of weights, Mahalanobis distance to the closest track and OSPA.

The time plots show, per method, the mean over seeds (line) and the 10-90 % band over seeds
(shaded), every k-th step so that at most :data:`MAX_POINTS` points are drawn.

Per-run values (the paper's "computed by averaging the values of elements" is read as an
average over the steps of a run; the per-step figures are those of
:mod:`phd_swarm.core.estimators.sung.figures`):

- Tables I and III: mean and standard deviation over the steps of ``components``,
  ``tracks``, ``weights_components`` and ``weights_tracks`` (population sd, ``ddof=0``);
- Tables II and IV: "mean to closest" is the NaN-aware mean over steps of
  ``mahal_closest`` (itself the mean over the true targets at a step); "STD to closest" is
  the standard deviation pooled over targets and steps,
  ``sqrt(mean(mahal_closest_sq) - mean(mahal_closest)**2)`` with NaN-aware means over the
  steps where both are defined. With the same number of true targets at every step this is
  exactly the (``ddof=0``) sd of all (target, step) distances; "mean to second closest" is
  the NaN-aware mean of ``mahal_second``;
- Table V: ``tracks`` and ``weights_components`` (and ``weights_tracks``) at the last step;
- for every method: the mean over the run of ``ospa``, of ``ospa_tracks`` and of
  ``largest_variance``.

Over the seeds of a method each per-run value is summarised as mean ± sample sd
(``ddof=1``); runs where the value is undefined (NaN: e.g. never two confirmed tracks) are
left out and counted ("[k of n runs]"), and a quantity undefined in every run is "n/a".

Methods are matched to the paper by their label: ``fp0``/``fp10``/``fp20`` are Tables I-II
(0/10/20 % false positives), ``under``/``exact``/``over`` Tables III-IV, ``lawn_*`` and
``largest_*`` Table V; ``gp`` has the paper's "mean to closest" of the moving-target case
(Sec. VI-A.4 text); the other methods (``rule``/``no_rule``, ``linear``, ``nearest_*``) have
no paper numbers.

Exit codes: 0 done, 2 a directory without ``results.csv`` (or with no finished trial, or a
row whose series file is missing).
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from phd_swarm.tools.sung_plots import plot_boxes, plot_time
from phd_swarm.tools.sung_sweep import MethodRuns, Sweep
from phd_swarm.tools.sweep_results import load_series
from phd_swarm.tools.tables import TablesError, over_seeds, read_results

#: At most this many points per time series in the plots (every k-th step).
MAX_POINTS = 750

#: Per-run quantities: key -> label in the tables.
QUANTITIES: dict[str, str] = {
    "components_mean": "Mean from components",
    "components_sd": "STD from components",
    "tracks_mean": "Mean from tracks",
    "tracks_sd": "STD from tracks",
    "weights_components_mean": "Sum of weights: mean from components",
    "weights_components_sd": "Sum of weights: STD from components",
    "weights_tracks_mean": "Sum of weights: mean from tracks",
    "weights_tracks_sd": "Sum of weights: STD from tracks",
    "mahal_closest_mean": "Mean to closest",
    "mahal_closest_sd": "STD to closest (pooled over targets and steps)",
    "mahal_second_mean": "Mean to second closest",
    "tracks_final": "Number of tracks (final)",
    "weights_components_final": "Sum of weights of components (final)",
    "weights_tracks_final": "Sum of weights of tracks (final)",
    "ospa_mean": "Mean OSPA of the estimate [m]",
    "ospa_tracks_mean": "Mean OSPA of the confirmed tracks [m]",
    "largest_variance_mean": "Mean largest variance of a confirmed track [m^2]",
}

#: The paper's numbers, per method label and quantity (Sung & Tokekar 2022, Sec. VI-A).
PAPER: dict[str, dict[str, float]] = {
    # Table I (components/tracks and sums of weights; false positives 0 / 10 / 20 %) and
    # Table II (Mahalanobis distances), lawn-mower, exact initial belief.
    "fp0": {"components_mean": 9.2995, "components_sd": 1.4761, "tracks_mean": 6.6800,
            "tracks_sd": 1.1048, "weights_components_mean": 16.4074,
            "weights_components_sd": 4.9371, "weights_tracks_mean": 14.9232,
            "weights_tracks_sd": 4.9926,
            "mahal_closest_mean": 3.0311, "mahal_closest_sd": 2.6494,
            "mahal_second_mean": 8.2450},
    "fp10": {"components_mean": 17.8844, "components_sd": 3.3565, "tracks_mean": 8.1645,
             "tracks_sd": 1.1685, "weights_components_mean": 18.6284,
             "weights_components_sd": 3.9135, "weights_tracks_mean": 15.6775,
             "weights_tracks_sd": 3.5912,
             "mahal_closest_mean": 2.3603, "mahal_closest_sd": 1.9604,
             "mahal_second_mean": 7.0569},
    "fp20": {"components_mean": 22.5303, "components_sd": 4.9181, "tracks_mean": 8.8030,
             "tracks_sd": 2.7396, "weights_components_mean": 19.4675,
             "weights_components_sd": 5.2100, "weights_tracks_mean": 15.4238,
             "weights_tracks_sd": 4.6435,
             "mahal_closest_mean": 2.5529, "mahal_closest_sd": 2.6242,
             "mahal_second_mean": 7.0451},
    # Table III (components/tracks and sums of weights; under- / exact / over-estimated
    # initial belief) and Table IV (Mahalanobis distances), lawn-mower, 10 % false positives.
    "under": {"components_mean": 18.4820, "components_sd": 5.2331, "tracks_mean": 9.5336,
              "tracks_sd": 2.3428, "weights_components_mean": 19.4229,
              "weights_components_sd": 5.7117, "weights_tracks_mean": 16.3315,
              "weights_tracks_sd": 5.1293,
              "mahal_closest_mean": 3.0930, "mahal_closest_sd": 2.5537,
              "mahal_second_mean": 7.3006},
    "exact": {"components_mean": 17.8844, "components_sd": 3.3565, "tracks_mean": 8.1645,
              "tracks_sd": 1.1685, "weights_components_mean": 18.6284,
              "weights_components_sd": 3.9135, "weights_tracks_mean": 15.6775,
              "weights_tracks_sd": 3.5912,
              "mahal_closest_mean": 2.3603, "mahal_closest_sd": 1.9604,
              "mahal_second_mean": 7.0569},
    "over": {"components_mean": 17.8883, "components_sd": 3.2361, "tracks_mean": 8.5219,
             "tracks_sd": 1.7715, "weights_components_mean": 18.3695,
             "weights_components_sd": 3.5348, "weights_tracks_mean": 15.4196,
             "weights_tracks_sd": 3.8297,
             "mahal_closest_mean": 3.3152, "mahal_closest_sd": 2.2353,
             "mahal_second_mean": 7.5527},
    # Table V (final number of tracks and sum of weights; lawn-mower and largest-Gaussian,
    # under / exact / over initial belief, 10 % false positives).
    "lawn_under": {"tracks_final": 10, "weights_components_final": 13.3769},
    "lawn_exact": {"tracks_final": 7, "weights_components_final": 18.8052},
    "lawn_over": {"tracks_final": 8, "weights_components_final": 19.6354},
    "largest_under": {"tracks_final": 3, "weights_components_final": 11.3125},
    "largest_exact": {"tracks_final": 7, "weights_components_final": 14.1745},
    "largest_over": {"tracks_final": 5, "weights_components_final": 13.0396},
    # Sec. VI-A.4 text (moving targets, GP prediction): "2.3603 vs. 3.1570 in case of the
    # closest confirmed track".
    "gp": {"mahal_closest_mean": 3.1570},
}

#: The tables of ``sung_tables.md``: title, the paper's tables by method group, quantities.
TABLES: tuple[tuple[str, dict[str, str], tuple[str, ...]], ...] = (
    ("Number of components/tracks and sums of weights",
     {"fp": "Table I", "belief": "Table III"},
     ("components_mean", "components_sd", "tracks_mean", "tracks_sd",
      "weights_components_mean", "weights_components_sd", "weights_tracks_mean",
      "weights_tracks_sd")),
    ("Mahalanobis distance of the true targets to the confirmed tracks",
     {"fp": "Table II", "belief": "Table IV", "gp": "Sec. VI-A.4"},
     ("mahal_closest_mean", "mahal_closest_sd", "mahal_second_mean")),
    ("Final number of tracks and sums of weights",
     {"planner": "Table V"},
     ("tracks_final", "weights_components_final", "weights_tracks_final")),
    ("OSPA (p = 2, c = 100 m) and largest variance over the run",
     {}, ("ospa_mean", "ospa_tracks_mean", "largest_variance_mean")),
)

#: Series kept (downsampled) for the plots.
PLOTTED = ("t", "cardinality_true", "tracks", "components", "mahal_closest", "mahal_second",
           "ospa", "ospa_tracks", "largest_variance")

#: A sweep directory the tables cannot be made from (:class:`tables.TablesError`).
SungTablesError = TablesError


def paper_group(method: str) -> str | None:
    """The paper's experiment a method label belongs to.

    Parameters
    ----------
    method : str
        Method label of a sweep.

    Returns
    -------
    str or None
        ``"fp"`` (Tables I-II), ``"belief"`` (Tables III-IV), ``"planner"`` (Table V),
        ``"gp"`` (Sec. VI-A.4) or None.
    """
    if method in ("fp0", "fp10", "fp20"):
        return "fp"
    if method in ("under", "exact", "over"):
        return "belief"
    if method.startswith(("lawn_", "largest_")):
        return "planner"
    if method == "gp":
        return "gp"
    return None


# ------------------------------------------------------------------------ per-run values
def _nanmean(x: np.ndarray) -> float:
    x = np.asarray(x, dtype=float)
    ok = np.isfinite(x)
    return float(x[ok].mean()) if ok.any() else math.nan


def _nanstd(x: np.ndarray) -> float:
    x = np.asarray(x, dtype=float)
    ok = np.isfinite(x)
    return float(x[ok].std()) if ok.any() else math.nan


def _last(x: np.ndarray) -> float:
    x = np.asarray(x, dtype=float)
    return float(x[-1]) if len(x) else math.nan


def run_values(series: dict[str, np.ndarray]) -> dict[str, float]:
    """The per-run values (:data:`QUANTITIES`) of one trial's series.

    Parameters
    ----------
    series : dict of str to np.ndarray
        Per-step arrays of one trial (:func:`phd_swarm.tools.sweep_results.load_series`), with the
        figures of :mod:`phd_swarm.core.estimators.sung.figures`.

    Returns
    -------
    dict of str to float
        Means and population sds (``ddof=0``) over the steps, NaN-aware; the pooled sd of
        the distance to the closest track ``sqrt(mean(d^2) - mean(d)^2)`` over the steps
        where both are defined; the values at the last step; NaN where undefined.
    """
    out: dict[str, float] = {}
    for k in ("components", "tracks", "weights_components", "weights_tracks"):
        out[f"{k}_mean"] = _nanmean(series[k])
        out[f"{k}_sd"] = _nanstd(series[k])
    d = np.asarray(series["mahal_closest"], dtype=float)
    d2 = np.asarray(series["mahal_closest_sq"], dtype=float)
    both = np.isfinite(d) & np.isfinite(d2)
    out["mahal_closest_mean"] = _nanmean(d)
    if both.any():
        var = float(d2[both].mean() - d[both].mean() ** 2)
        out["mahal_closest_sd"] = math.sqrt(max(var, 0.0))  # rounding can give -1e-16
    else:
        out["mahal_closest_sd"] = math.nan
    out["mahal_second_mean"] = _nanmean(series["mahal_second"])
    for k in ("tracks", "weights_components", "weights_tracks"):
        out[f"{k}_final"] = _last(series[k])
    out["ospa_mean"] = _nanmean(series["ospa"])
    out["ospa_tracks_mean"] = _nanmean(series["ospa_tracks"])
    out["largest_variance_mean"] = _nanmean(series["largest_variance"])
    return out


# ---------------------------------------------------------------------------- reading
def _method_order(path: Path, rows: Sequence[dict[str, str]]) -> list[str]:
    order: list[str] = []
    spec = path / "spec.json"
    if spec.is_file():
        try:
            order = list(json.loads(spec.read_text()).get("methods", {}))
        except (ValueError, AttributeError):
            order = []
    for r in rows:
        if r["method"] not in order:
            order.append(r["method"])
    present = {r["method"] for r in rows}
    return [m for m in order if m in present]


def load_sweep(path: Path | str) -> Sweep:
    """Read a sweep directory: per method the per-run values and the plotted series.

    Parameters
    ----------
    path : Path or str
        Sweep directory (``results.csv``, ``series/<trial>.npz``, optionally
        ``spec.json`` for the methods' order and the figure's title).

    Returns
    -------
    Sweep

    Raises
    ------
    SungTablesError
        See :func:`read_results`; or the series file of a row is missing or lacks a figure.
    """
    path = Path(path)
    rows = read_results(path)
    name, figure = path.name, ""
    if (path / "spec.json").is_file():
        try:
            spec = json.loads((path / "spec.json").read_text())
            name, figure = spec.get("name", name), spec.get("figure", "")
        except ValueError:
            pass
    methods = {m: MethodRuns() for m in _method_order(path, rows)}
    for r in sorted(rows, key=lambda r: int(r["seed"])):
        f = path / "series" / f"{r['trial']}.npz"
        if not f.is_file():
            raise SungTablesError(f"{f}: series file of trial {r['trial']} (results.csv) "
                                  f"missing")
        try:
            s = load_series(f)
            values = run_values(s)
            n = len(s["t"])
            stride = max(1, math.ceil(n / MAX_POINTS))
            kept = {k: np.asarray(s[k], dtype=float)[::stride] for k in PLOTTED}
        except KeyError as exc:
            raise SungTablesError(f"{f}: series {exc} missing (not a Sung sweep?)") from None
        runs = methods[r["method"]]
        runs.trials.append(r["trial"])
        runs.seeds.append(int(r["seed"]))
        runs.values.append(values)
        runs.series.append(kept)
        runs.steps.append(n)
    return Sweep(path, name, figure, methods)


# ---------------------------------------------------------------------------- summary
def summarise(sweep: Sweep) -> dict[str, Any]:
    """The numbers of a sweep read by :func:`load_sweep` (see :func:`summary`)."""
    out: dict[str, Any] = {"dir": str(sweep.path), "name": sweep.name,
                           "figure": sweep.figure, "methods": {}}
    for m, runs in sweep.methods.items():
        stats = {q: over_seeds([v[q] for v in runs.values]) for q in QUANTITIES}
        out["methods"][m] = {
            "trials": list(runs.trials), "seeds": list(runs.seeds), "n": len(runs.trials),
            "steps": list(runs.steps),
            "runs": {q: [v[q] for v in runs.values] for q in QUANTITIES},
            "mean": {q: s["mean"] for q, s in stats.items()},
            "sd": {q: s["sd"] for q, s in stats.items()},
            "n_valid": {q: s["n_valid"] for q, s in stats.items()},
            "paper": dict(PAPER.get(m, {})),
            "group": paper_group(m),
        }
    return out


def summary(path: Path | str) -> dict[str, Any]:
    """The table numbers of one sweep directory.

    Parameters
    ----------
    path : Path or str
        Sweep directory.

    Returns
    -------
    dict
        ``dir``, ``name``, ``figure`` and ``methods``: per method (in the spec's order)
        ``trials``, ``seeds``, ``n``, ``steps`` (per run), ``runs`` (per quantity of
        :data:`QUANTITIES` the per-run values, by seed), ``mean`` and ``sd`` (over seeds,
        NaN-aware, ``ddof=1``), ``n_valid`` (runs where defined), ``paper`` (the paper's
        numbers, :data:`PAPER`) and ``group`` (:func:`paper_group`).

    Raises
    ------
    SungTablesError
        See :func:`load_sweep`.
    """
    return summarise(load_sweep(path))


def _num(x: float) -> str:
    return f"{x:.2f}"


def cell(stats: dict[str, Any], q: str) -> str:
    """One table cell: "mean ± sd" over seeds, the paper's number in parentheses.

    Parameters
    ----------
    stats : dict
        The method's entry of :func:`summary`'s ``methods``.
    q : str
        Quantity (:data:`QUANTITIES`).

    Returns
    -------
    str
        ``"m ± s (p)"``, ``"m"`` with one defined run, ``"n/a"`` with none; "[k of n runs]"
        when some runs are undefined.
    """
    n, k = stats["n"], stats["n_valid"][q]
    if k == 0:
        text = "n/a"
    elif k == 1:
        text = _num(stats["mean"][q])
    else:
        text = f"{_num(stats['mean'][q])} ± {_num(stats['sd'][q])}"
    if 0 < k < n:
        text += f" [{k} of {n} runs]"
    paper = stats["paper"].get(q)
    if paper is not None:
        text += f" ({paper:g})"
    return text


def markdown(summ: dict[str, Any]) -> str:
    """``sung_tables.md`` of a :func:`summary`.

    Parameters
    ----------
    summ : dict
        :func:`summary` of a sweep.

    Returns
    -------
    str
        Markdown text: a header, then one table per paper table, methods as columns.
    """
    methods = summ["methods"]
    names = list(methods)
    title = summ["figure"] or "Sung & Tokekar (2022) tables"
    lines = [f"# {title}: {summ['name']}", "",
             f"Made by `python -m phd_swarm.tools.sung_tables` from `{summ['dir']}`.", ""]
    for m, s in methods.items():
        steps = sorted(set(s["steps"]))
        step_text = "-".join(str(x) for x in (steps[0], steps[-1])) if len(steps) > 1 \
            else str(steps[0])
        seeds = ", ".join(str(x) for x in s["seeds"])
        plural = "s" if s["n"] > 1 else ""
        lines.append(f"- `{m}`: {s['n']} run{plural} (seed{plural} {seeds}), {step_text} steps")
    lines += [
        "",
        "Cells: mean ± sd over seeds (sample sd) of the per-run value; the paper's number "
        "(one run) in parentheses where it has one; \"[k of n runs]\" when the value is "
        "undefined in some runs, \"n/a\" when in all.",
        "Per-run values are taken over the steps of a run: mean and (population) STD over the "
        "steps; the Mahalanobis \"STD to closest\" is pooled over targets and steps, "
        "sqrt(mean(d^2) - mean(d)^2) with NaN-aware means over the steps; \"final\" is the "
        "last step.",
    ]
    if "rule" in methods:
        lines.append("`rule` is the configuration of the 10 % column of Table I (exact "
                     "belief, lawn-mower, 10 % false positives); the paper shows it only in "
                     "Fig. 8.")
    for heading, refs, quantities in TABLES:
        groups = {methods[m]["group"] for m in names}
        cited = [ref for g, ref in refs.items() if g in groups]
        lines += ["", f"## {heading}" + (f" (paper {', '.join(cited)})" if cited else ""), "",
                  "| | " + " | ".join(f"`{m}`" for m in names) + " |",
                  "|---|" + "---:|" * len(names)]
        for q in quantities:
            lines.append(f"| {QUANTITIES[q]} | "
                         + " | ".join(cell(methods[m], q) for m in names) + " |")
    return "\n".join(lines) + "\n"


def write_outputs(sweep: Sweep, out: Path) -> list[Path]:
    """Write ``sung_tables.md`` and the plots of a sweep into ``out``.

    Parameters
    ----------
    sweep : Sweep
        The sweep (:func:`load_sweep`).
    out : Path
        Output directory (created if missing).

    Returns
    -------
    list of Path
        The files written.
    """
    out.mkdir(parents=True, exist_ok=True)
    summ = summarise(sweep)
    md = out / "sung_tables.md"
    md.write_text(markdown(summ))
    return [
        md,
        plot_time(sweep, (("tracks", "confirmed tracks"), ("components", "GM components")),
                  out / "sung_counts_vs_time.png", "number of tracks and components",
                  truth=True),
        plot_time(sweep, (("mahal_closest", "Mahalanobis to closest track"),
                          ("mahal_second", "Mahalanobis to second closest")),
                  out / "sung_mahalanobis_vs_time.png", "Mahalanobis distances"),
        plot_time(sweep, (("ospa", "OSPA of the estimate [m]"),
                          ("ospa_tracks", "OSPA of the confirmed tracks [m]")),
                  out / "sung_ospa_vs_time.png", "OSPA (p = 2, c = 100 m)"),
        plot_time(sweep, (("largest_variance", "largest variance [m$^2$]"),),
                  out / "sung_largest_variance_vs_time.png",
                  "largest variance of the confirmed tracks"),
        plot_boxes(sweep, summ, out / "sung_boxplots.png"),
    ]


# -------------------------------------------------------------------------------- CLI
def parse_args(argv: Sequence[str]) -> argparse.Namespace:
    """Command-line options (see the module docstring).

    Parameters
    ----------
    argv : sequence of str
        The arguments, without the program name.

    Returns
    -------
    argparse.Namespace
        ``dirs`` (list of Path) and ``out`` (Path or None).
    """
    p = argparse.ArgumentParser(
        prog="python -m phd_swarm.tools.sung_tables",
        description="Sung & Tokekar (2022) tables (sung_tables.md) and figures "
                    "(sung_*.png) of Sung sweep directories.")
    p.add_argument("dirs", nargs="+", type=Path, metavar="DIR",
                   help="sweep directory (results.csv and series/)")
    p.add_argument("--out", type=Path, default=None,
                   help="write here instead of into DIR (OUT/<name of DIR> when several "
                        "directories are given)")
    return p.parse_args(list(argv))


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point; returns the exit code (0, or 2 for a directory that cannot be read).

    Parameters
    ----------
    argv : sequence of str, optional
        Arguments without the program name (default ``sys.argv[1:]``).

    Returns
    -------
    int
        Exit code.
    """
    opts = parse_args(sys.argv[1:] if argv is None else argv)
    status = 0
    for d in opts.dirs:
        if opts.out is None:
            out = d
        else:
            out = opts.out if len(opts.dirs) == 1 else opts.out / d.resolve().name
        try:
            sweep = load_sweep(d)
        except SungTablesError as exc:
            print(f"error: {exc}", file=sys.stderr)
            status = 2
            continue
        for f in write_outputs(sweep, out):
            print(f)
    return status


if __name__ == "__main__":
    sys.exit(main())
