from __future__ import annotations

import numpy as np
import pytest

from phd_swarm.core.checks import check_spd


def _cholesky_ok(a: np.ndarray) -> bool:
    try:
        np.linalg.cholesky(a)
        return True
    except np.linalg.LinAlgError:
        return False


def test_the_2x2_fast_path_agrees_with_cholesky():
    rng = np.random.default_rng(0)
    for _ in range(2000):
        a = rng.normal(size=(2, 2))
        m = a @ a.T + rng.choice([-1.0, 0.0, 1e-9, 1.0]) * np.eye(2)
        ok = _cholesky_ok(m)
        if ok:
            check_spd("m", m)
        else:
            with pytest.raises(ValueError, match="positive definite"):
                check_spd("m", m)


def test_asymmetric_and_non_finite_2x2_are_refused():
    with pytest.raises(ValueError, match="symmetric"):
        check_spd("P", np.array([[[1.0, 0.1], [0.2, 1.0]]]))
    with pytest.raises(ValueError, match="finite"):
        check_spd("P", np.array([[1.0, np.nan], [np.nan, 1.0]]))
    check_spd("P", np.array([[1.0, 0.1], [0.1 + 1e-13, 1.0]]))   # within the tolerance
    with pytest.raises(ValueError, match="positive definite"):
        check_spd("P", np.array([[0.0, 0.0], [0.0, 1.0]]))
