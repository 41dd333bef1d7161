"""Per-step figures that are arrays: stacked into one (steps, W) series of a trial.

A system's ``figures`` hook may return, besides scalars, a 1-D array per step whose length
changes from step to step (e.g. one entry per live target, Papaioannou et al.'s
``target_ids``, :mod:`phd_swarm.core.estimators.papaioannou.figures`). The sweep runner
keeps them as rows and stacks them at the end with :func:`pad_rows`: one (steps, W) array,
W the longest row, each row padded at its end with -1 (integers) or NaN (floats); a step
without a value is a row of padding. The arrays travel in the trial's ``.npz`` series as
they are (integers stay integers, :func:`phd_swarm.tools.sweep_results.save_series`).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

#: Padding of integer rows (ids and bit masks are >= 0).
INT_PAD = -1


def pad_rows(rows: Sequence[np.ndarray | None]) -> np.ndarray:
    """Stack 1-D rows of different lengths into one array, padded at the end.

    Parameters
    ----------
    rows : sequence of np.ndarray or None
        One row per step, shape (W_k,); None for a step without a value.

    Returns
    -------
    np.ndarray, shape (len(rows), max W_k)
        int64 with :data:`INT_PAD` padding if every row is integer, else float64 with NaN.
    """
    given = [np.asarray(r).reshape(-1) for r in rows if r is not None]
    width = max((len(r) for r in given), default=0)
    integer = all(np.issubdtype(r.dtype, np.integer) or r.size == 0 for r in given)
    out = (np.full((len(rows), width), INT_PAD, dtype=np.int64) if integer
           else np.full((len(rows), width), np.nan))
    for k, r in enumerate(rows):
        if r is not None:
            r = np.asarray(r).reshape(-1)
            out[k, :len(r)] = r
    return out
