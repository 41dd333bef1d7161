"""Pictures of a run: a snapshot of one step, OSPA and cardinality over time, animations.

Drawn with matplotlib's object API on the non-interactive Agg backend, so they work on
machines without a display. The snapshot follows the papers' figures (Dames Fig. 3, Chen
Fig. 2): the map, the PHD as a heat map (and Chen's cumulative density wc next to it),
robots with their sensing disks, their cells, the goals they steer to, the true targets and
the team's estimates. A system without a grid PHD (Sung & Tokekar's GM-PHD) shows instead
its mixture's components as 2-sigma ellipses and the robots' paths so far; and
:func:`save_figures` draws its estimator's per-step figures over time.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.collections import (
    EllipseCollection,
    LineCollection,
    PatchCollection,
)
from matplotlib.colors import PowerNorm, to_rgba
from matplotlib.figure import Figure
from matplotlib.patches import Circle

#: Colours of the series and markers (colour-blind safe, Okabe-Ito).
TRUTH_COLOUR = "#009E73"
ESTIMATE_COLOUR = "#D55E00"
ROBOT_COLOUR = "#0072B2"
GOAL_COLOUR = "#56B4E9"
CELL_COLOUR = "0.35"
COMPONENT_COLOUR = "#CC79A7"

#: Panels of :func:`save_figures`: y label and (figure, legend label) pairs.
FIGURE_PANELS = (
    ("number", (("components", "GM components"), ("tracks", "confirmed tracks"))),
    ("sum of weights", (("weights_components", "all components"),
                        ("weights_tracks", "components of confirmed tracks"))),
    ("Mahalanobis distance", (("mahal_closest", "truth to closest track"),
                              ("mahal_second", "truth to second closest"))),
    ("largest variance [m$^2$]", (("largest_variance", "of a confirmed track"),)),
)



def new_figure(size: tuple[float, float]) -> Figure:
    """A figure of ``size`` inches on the Agg canvas (no pyplot state, no display)."""
    fig = Figure(figsize=size)
    FigureCanvasAgg(fig)
    return fig

@dataclass
class Frame:
    """Everything one snapshot shows (positions in metres).

    Attributes
    ----------
    t : float
        Time of the step [s].
    step : int
    extent : (xmin, ymin, xmax, ymax)
        The map.
    phd : np.ndarray (ny, nx) or None
        Team PHD, expected targets per bin; None for a system without a grid PHD.
    robots : dict of int to (2,) array
    alive : set of int
    fov_radius : float
        Sensing radius [m].
    cells : dict of int to (V, 2) array
    goals : dict of int to (2,) array
    truth : (N, 2) array
    estimates : (K, 2) array
    cumulative : np.ndarray (ny, nx) or None
        Chen's cumulative density wc, shown in a second panel when given.
    title : str
    paths : dict of int to (S, 2) array
        Each robot's path so far (drawn when given).
    component_means, component_covs, component_weights : np.ndarray
        A Gaussian mixture's components, (J, 2), (J, 2, 2) and (J,): drawn as 2-sigma
        ellipses, more opaque the larger the weight (none by default).
    """

    t: float
    step: int
    extent: tuple[float, float, float, float]
    phd: np.ndarray | None
    robots: dict[int, np.ndarray]
    alive: set[int]
    fov_radius: float
    cells: dict[int, np.ndarray] = field(default_factory=dict)
    goals: dict[int, np.ndarray] = field(default_factory=dict)
    truth: np.ndarray = field(default_factory=lambda: np.empty((0, 2)))
    estimates: np.ndarray = field(default_factory=lambda: np.empty((0, 2)))
    cumulative: np.ndarray | None = None
    title: str = ""
    paths: dict[int, np.ndarray] = field(default_factory=dict)
    component_means: np.ndarray = field(default_factory=lambda: np.empty((0, 2)))
    component_covs: np.ndarray = field(default_factory=lambda: np.empty((0, 2, 2)))
    component_weights: np.ndarray = field(default_factory=lambda: np.empty(0))


def ellipse_axes(covs: np.ndarray, sigmas: float = 2.0
                 ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Full widths, heights and angles [deg] of the ``sigmas`` ellipses of covs (J, 2, 2).

    The width lies along the major axis (the eigenvector of the largest eigenvalue).
    """
    values, vectors = np.linalg.eigh(covs)
    axes = 2.0 * sigmas * np.sqrt(np.maximum(values, 0.0))
    angles = np.degrees(np.arctan2(vectors[:, 1, 1], vectors[:, 0, 1]))
    return axes[:, 1], axes[:, 0], angles


def _draw_components(ax: Any, f: Frame) -> None:
    if len(f.component_means):
        widths, heights, angles = ellipse_axes(f.component_covs)
        colours = np.tile(to_rgba(COMPONENT_COLOUR), (len(widths), 1))
        colours[:, 3] = np.clip(f.component_weights, 0.15, 1.0)
        ax.add_collection(EllipseCollection(
            widths, heights, angles, units="xy", offsets=f.component_means,
            offset_transform=ax.transData, facecolors="none", edgecolors=colours,
            linewidths=1.0, zorder=4))
        ax.plot([], [], "-", color=COMPONENT_COLOUR, lw=1.0, label="component (2 sigma)")
    for i, (_, path) in enumerate(sorted(f.paths.items())):
        ax.plot(path[:, 0], path[:, 1], "-", color=ROBOT_COLOUR, lw=0.7, alpha=0.6, zorder=3,
                label="path" if i == 0 else None)


def _draw_team(ax: Any, f: Frame, legend: bool) -> None:
    _draw_components(ax, f)
    live = [r for r in sorted(f.robots) if r in f.alive]
    dead = [r for r in sorted(f.robots) if r not in f.alive]
    if f.cells:
        segs = [np.vstack([c, c[:1]]) for r, c in sorted(f.cells.items())
                if r in f.alive and len(c) >= 3]
        ax.add_collection(LineCollection(segs, colors=CELL_COLOUR, linewidths=0.6, zorder=2))
    if live:
        disks = [Circle(tuple(f.robots[r]), f.fov_radius) for r in live]
        ax.add_collection(PatchCollection(disks, facecolor="none", edgecolor=ROBOT_COLOUR,
                                          linewidth=0.6, alpha=0.8, zorder=3))
        pos = np.array([f.robots[r] for r in live])
        ax.plot(pos[:, 0], pos[:, 1], "o", ms=3.5, color=ROBOT_COLOUR, zorder=5,
                label="robot (sensing disk)")
        arrows = [(f.robots[r], f.goals[r]) for r in live if r in f.goals]
        if arrows:
            ax.add_collection(LineCollection([np.vstack(a) for a in arrows], colors=GOAL_COLOUR,
                                             linewidths=0.8, zorder=4))
            g = np.array([a[1] for a in arrows])
            ax.plot(g[:, 0], g[:, 1], "+", ms=5, color=GOAL_COLOUR, zorder=4, label="goal")
    if dead:
        pos = np.array([f.robots[r] for r in dead])
        ax.plot(pos[:, 0], pos[:, 1], "x", ms=5, color="k", zorder=5, label="dead robot")
    if len(f.truth):
        ax.plot(f.truth[:, 0], f.truth[:, 1], "^", ms=5, mfc="none", color=TRUTH_COLOUR,
                mew=1.2, zorder=6, label="true target")
    if len(f.estimates):
        ax.plot(f.estimates[:, 0], f.estimates[:, 1], "x", ms=5, color=ESTIMATE_COLOUR,
                mew=1.2, zorder=7, label="estimate")
    xmin, ymin, xmax, ymax = f.extent
    ax.set_xlim(xmin, xmax)
    ax.set_ylim(ymin, ymax)
    ax.set_aspect("equal")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    if legend:
        ax.legend(loc="upper left", fontsize=7, framealpha=0.85, markerscale=1.2)


def draw_snapshot(f: Frame, fig: Any | None = None) -> Any:
    """Draw ``f`` into ``fig`` (a new figure if None, cleared otherwise); returns the figure."""
    # The PHD concentrates in a few bins at the targets: a square-root colour scale keeps the
    # weak mass of unexplored areas visible next to the peaks.
    images: list[tuple | None] = [None if f.phd is None else (
        f.phd, "PHD [targets / bin] (square-root scale)", "viridis",
        PowerNorm(0.5, vmin=0.0, vmax=max(float(f.phd.max()), 1e-12)))]
    if f.cumulative is not None:
        images.append((f.cumulative, "cumulative density $w_c$", "magma", None))
    if fig is None:
        fig = new_figure((6.2 * len(images), 5.6))
    fig.clear()
    axes = fig.subplots(1, len(images), squeeze=False)[0]
    xmin, ymin, xmax, ymax = f.extent
    for i, (ax, spec) in enumerate(zip(axes, images, strict=True)):
        if spec is not None:
            img, label, cmap, norm = spec
            im = ax.imshow(img, origin="lower", extent=(xmin, xmax, ymin, ymax), cmap=cmap,
                           norm=norm, interpolation="nearest", zorder=1)
            fig.colorbar(im, ax=ax, shrink=0.82, label=label)
        _draw_team(ax, f, legend=(i == 0))
    fig.suptitle(f.title or f"t = {f.t:.1f} s (step {f.step})", fontsize=10, wrap=True)
    fig.tight_layout()
    return fig


def save_snapshot(f: Frame, path: str | Path, dpi: int = 120) -> Path:
    """Draw ``f`` and write it as a PNG; returns the path."""
    fig = draw_snapshot(f)
    fig.savefig(path, dpi=dpi)
    return Path(path)


def save_animation(frames: Sequence[Frame], path: str | Path, fps: float = 5.0,
                   dpi: int = 90) -> Path:
    """Write ``frames`` as an animated GIF (Pillow) or MP4 (needs ffmpeg on PATH).

    Raises
    ------
    ValueError
        If there are no frames, the suffix is neither ``.gif`` nor ``.mp4``, or ``.mp4`` was
        asked for without ffmpeg.
    """
    from matplotlib import animation

    path = Path(path)
    if not frames:
        raise ValueError("no frames to animate")
    suffix = path.suffix.lower()
    if suffix == ".gif":
        writer: Any = animation.PillowWriter(fps=fps)
    elif suffix == ".mp4":
        if not animation.FFMpegWriter.isAvailable():
            raise ValueError(f"{path}: MP4 needs ffmpeg on PATH; install it or write a .gif")
        writer = animation.FFMpegWriter(fps=fps)
    else:
        raise ValueError(f"{path}: animations are written as .gif or .mp4, not {suffix!r}")
    fig = draw_snapshot(frames[0])
    with writer.saving(fig, str(path), dpi):
        for f in frames:
            draw_snapshot(f, fig)
            writer.grab_frame()
    return path


def save_series(rows: Sequence[dict[str, Any]], path: str | Path, title: str = "",
                reference: Sequence[dict[str, Any]] | None = None) -> Path:
    """OSPA (with its localisation and cardinality parts) and cardinality over time.

    ``rows`` are per-step dicts with ``t``, ``ospa``, ``ospa_localisation``,
    ``ospa_cardinality``, ``cardinality_true``, ``cardinality_est`` and
    ``expected_cardinality``; ``reference`` (optional, same keys ``t`` and ``ospa``) is
    drawn dashed, e.g. the live monitor's series.
    """
    t = np.array([r["t"] for r in rows])
    fig = new_figure((7.5, 5.8))
    a1, a2 = fig.subplots(2, 1, sharex=True)
    a1.plot(t, [r["ospa"] for r in rows], color="k", lw=1.4, label="OSPA")
    a1.plot(t, [r["ospa_localisation"] for r in rows], color=ROBOT_COLOUR, lw=0.9,
            label="localisation part")
    a1.plot(t, [r["ospa_cardinality"] for r in rows], color=ESTIMATE_COLOUR, lw=0.9,
            label="cardinality part")
    if reference:
        a1.plot([r["t"] for r in reference], [r["ospa"] for r in reference], "--",
                color="0.55", lw=1.0, label="live monitor")
    a1.set_ylabel("OSPA [m]")
    a1.set_ylim(bottom=0)
    a1.legend(fontsize=8, loc="upper right")
    a1.grid(alpha=0.3)
    a2.step(t, [r["cardinality_true"] for r in rows], where="post", color=TRUTH_COLOUR,
            lw=1.4, label="true")
    a2.step(t, [r["cardinality_est"] for r in rows], where="post", color=ESTIMATE_COLOUR,
            lw=1.0, label="estimated")
    a2.plot(t, [r["expected_cardinality"] for r in rows], color="0.3", lw=0.9, ls=":",
            label="expected (PHD mass)")
    a2.set_ylabel("number of targets")
    a2.set_xlabel("time [s]")
    a2.set_ylim(bottom=0)
    a2.legend(fontsize=8, loc="lower right")
    a2.grid(alpha=0.3)
    return _save(fig, path, title)


def _save(fig: Any, path: str | Path, title: str) -> Path:
    """Title ``fig`` (if ``title``), lay it out and write it to ``path`` as a PNG."""
    if title:
        fig.suptitle(title, fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    return Path(path)


def figure_panels(names: Iterable[str]) -> list[tuple[str, list[tuple[str, str]]]]:
    """The panels of :data:`FIGURE_PANELS` with those of their figures in ``names``."""
    names = set(names)
    panels = [(label, [(n, lab) for n, lab in series if n in names])
              for label, series in FIGURE_PANELS]
    return [p for p in panels if p[1]]


def save_figures(rows: Sequence[dict[str, Any]], path: str | Path, title: str = "") -> Path:
    """An estimator's per-step figures over time (Sung & Tokekar Fig. 8-10), as a PNG.

    ``rows`` are per-step dicts with ``t`` and the figures of :data:`FIGURE_PANELS` (e.g.
    :mod:`phd_swarm.core.estimators.sung.figures`); a figure missing from a row, or NaN,
    leaves a gap, and a panel none of whose figures is in the rows is left out
    (:func:`figure_panels`); figures of no panel are not drawn. The true
    number of targets (``cardinality_true``) is drawn with the sums of weights.

    Raises
    ------
    ValueError
        If the rows hold none of the figures.
    """
    present = {k for r in rows for k in r}
    panels = figure_panels(present)
    if not panels:
        raise ValueError(f"{path}: no figures to draw (none of "
                         f"{[n for _, s in FIGURE_PANELS for n, _ in s]})")
    t = np.array([r["t"] for r in rows])
    fig = new_figure((7.5, 2.1 * len(panels) + 0.6))
    axes = fig.subplots(len(panels), 1, sharex=True, squeeze=False)
    colours = ("k", ESTIMATE_COLOUR)
    for ax, (label, series) in zip(axes[:, 0], panels, strict=True):
        for (name, legend), colour in zip(series, colours, strict=False):
            ax.plot(t, [r.get(name, np.nan) for r in rows], color=colour, lw=1.0,
                    label=legend)
        if label == "sum of weights" and "cardinality_true" in present:
            ax.step(t, [r.get("cardinality_true", np.nan) for r in rows], where="post",
                    color=TRUTH_COLOUR, lw=1.0, ls="--", label="true number of targets")
        ax.set_ylabel(label)
        ax.set_ylim(bottom=0)
        ax.legend(fontsize=7, loc="best")
        ax.grid(alpha=0.3)
    axes[-1, 0].set_xlabel("time [s]")
    return _save(fig, path, title)
