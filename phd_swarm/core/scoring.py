"""Scoring one step of a run: team PHD image + truth -> estimate, OSPA, cardinalities.

The one place where a step is scored, so that the live team monitor
(:mod:`phd_swarm.nodes.monitor`), the offline evaluation of a log
(:mod:`phd_swarm.tools.evaluate`) and the parameter sweeps on the in-memory engine
(:mod:`phd_swarm.tools.sweep`) report the same figures for the same PHD:

1. the team estimate is extracted from the image (:func:`extract_targets`, Dames Sec. IV);
2. the expected number of targets is the image's total mass (Dames eq. 2);
3. OSPA with cut-off c and order p (Dames eq. 12, Schuhmacher et al. 2008) compares the
   estimate with the true target positions.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from phd_swarm.core.extraction import ExtractionConfig, expected_cardinality, extract_targets
from phd_swarm.core.geometry.grid import Grid
from phd_swarm.core.ospa import ospa_components


@dataclass(frozen=True)
class StepScore:
    """The figures of one step.

    Attributes
    ----------
    estimates : np.ndarray, shape (K, 2)
        The team's target estimates [m].
    ospa, ospa_localisation, ospa_cardinality : float
        OSPA distance and its two parts [m].
    cardinality_true : int
        Number of true targets.
    cardinality_est : int
        Number of estimates K.
    expected_cardinality : float
        Total PHD mass.
    """

    estimates: np.ndarray
    ospa: float
    ospa_localisation: float
    ospa_cardinality: float
    cardinality_true: int
    cardinality_est: int
    expected_cardinality: float

    def row(self) -> dict[str, float | int]:
        """The scalar figures as a dict (the monitor's and the evaluation's column names)."""
        return {"ospa": self.ospa, "ospa_localisation": self.ospa_localisation,
                "ospa_cardinality": self.ospa_cardinality,
                "cardinality_true": self.cardinality_true,
                "cardinality_est": self.cardinality_est,
                "expected_cardinality": self.expected_cardinality}


def score_step(grid: Grid, image: np.ndarray, truth: np.ndarray,
               extraction: ExtractionConfig, c: float, p: float) -> StepScore:
    """Score the team PHD ``image`` (ny, nx) against the true positions ``truth`` (n, 2).

    Raises
    ------
    ValueError
        If the image does not fit the grid or holds non-finite values, or ``truth`` is not
        an (n, 2) array of finite positions.
    """
    estimates = extract_targets(grid, image, extraction)
    parts = ospa_components(truth, estimates, c, p)
    return StepScore(estimates=estimates, ospa=float(parts.distance),
                     ospa_localisation=float(parts.localisation),
                     ospa_cardinality=float(parts.cardinality),
                     cardinality_true=int(len(truth)), cardinality_est=int(len(estimates)),
                     expected_cardinality=float(expected_cardinality(image)))


def score_estimates(estimates: np.ndarray, expected: float, truth: np.ndarray, c: float,
                    p: float) -> StepScore:
    """Score a team's own target estimates (K, 2) [m] and expected count against ``truth``.

    For estimators that extract their own estimates (a Gaussian mixture's components
    above a weight, Vo & Ma Table III) instead of a grid image.
    """
    estimates = np.asarray(estimates, dtype=float).reshape(-1, 2)
    parts = ospa_components(truth, estimates, c, p)
    return StepScore(estimates=estimates, ospa=float(parts.distance),
                     ospa_localisation=float(parts.localisation),
                     ospa_cardinality=float(parts.cardinality),
                     cardinality_true=int(len(truth)), cardinality_est=int(len(estimates)),
                     expected_cardinality=float(expected))


def series_summary(rows: list[dict]) -> dict[str, object]:
    """Summary figures of a run's per-step rows (``t`` and the :meth:`StepScore.row` keys).

    The final OSPA, the mean OSPA over the second half of the steps, the OSPA series as
    ``[[t, ospa], ...]`` and the final true, estimated and expected cardinalities (None
    when there are no rows), as DESIGN.md's ``summary.json`` names them.
    """
    ospa = [r["ospa"] for r in rows]
    half = ospa[len(ospa) // 2:]
    last = rows[-1] if rows else {}
    return {"ospa_final": ospa[-1] if ospa else None,
            "ospa_mean_last_half": float(np.mean(half)) if half else None,
            "ospa_series": [[r["t"], r["ospa"]] for r in rows],
            "cardinality_true_final": last.get("cardinality_true"),
            "cardinality_est_final": last.get("cardinality_est"),
            "expected_cardinality_final": last.get("expected_cardinality")}
