"""Checks of the arrays the estimators take, each refusing bad input with a clear error.

A value that came from a config, a message or a caller is checked once where it enters an
estimator; the ``ValueError`` names the value (and, for measurements, the offending row).
"""

from __future__ import annotations

import numpy as np


def check_finite(name: str, a: np.ndarray) -> None:
    """Raise unless every entry of ``a`` is finite."""
    if not np.all(np.isfinite(a)):
        raise ValueError(f"{name} must be finite (no NaN or inf)")


def check_probability(name: str, p: np.ndarray) -> None:
    """Raise unless every entry of ``p`` is a probability in [0, 1]."""
    check_finite(name, p)
    if np.any((p < 0.0) | (p > 1.0)):
        raise ValueError(f"{name} must lie in [0, 1]")


def check_spd(name: str, a: np.ndarray) -> None:
    """Raise unless every matrix of the stack ``a`` (..., n, n) is symmetric positive definite."""
    check_finite(name, a)
    if a.shape[-2:] == (2, 2):
        # Closed form for 2 x 2 (a hot path of the Gaussian-mixture filters): the same
        # tolerance as the allclose below, and a Cholesky factor exists iff a00 > 0 and
        # a11 - a10^2 / a00 > 0 (numpy's factor reads the lower triangle).
        a00, a10, a01, a11 = a[..., 0, 0], a[..., 1, 0], a[..., 0, 1], a[..., 1, 1]
        if np.any(np.abs(a01 - a10) > 1e-12 + 1e-9 * np.abs(a10)):
            raise ValueError(f"{name} must be symmetric")
        with np.errstate(divide="ignore", invalid="ignore"):
            if not np.all((a00 > 0.0) & (a11 - a10 * a10 / a00 > 0.0)):
                raise ValueError(f"{name} must be positive definite")
        return
    if not np.allclose(a, np.swapaxes(a, -1, -2), rtol=1e-9, atol=1e-12):
        raise ValueError(f"{name} must be symmetric")
    try:
        np.linalg.cholesky(a)
    except np.linalg.LinAlgError:
        raise ValueError(f"{name} must be positive definite") from None


def check_nonnegative(name: str, v: object) -> float:
    """``v`` as a float, refused unless it is finite and >= 0."""
    try:
        x = float(v)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be a number, got {v!r}") from None
    if not np.isfinite(x) or x < 0.0:
        raise ValueError(f"{name} must be finite and >= 0, got {v!r}")
    return x


def check_positive_int(name: str, v: object, minimum: int = 1) -> int:
    """``v`` as an int, refused unless it is an integer (not a bool) >= ``minimum``."""
    if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or v < minimum:
        raise ValueError(f"{name} must be an integer >= {minimum}, got {v!r}")
    return int(v)


def check_generator(rng: object) -> np.random.Generator:
    """``rng``, refused unless it is a :class:`numpy.random.Generator` (seeded by the caller)."""
    if not isinstance(rng, np.random.Generator):
        raise ValueError(f"rng must be a numpy.random.Generator, got {type(rng).__name__}")
    return rng


def check_measurements(z: np.ndarray, measurement_dim: int | None = None) -> np.ndarray:
    """``z`` as a float array (M, m), refused if malformed or not finite (the row named).

    With ``measurement_dim`` given, m must equal it; an empty ``z`` is reshaped to (0, m).
    """
    z = np.asarray(z, dtype=float)
    if z.size == 0:
        m = measurement_dim if measurement_dim is not None else (
            z.shape[-1] if z.ndim == 2 else 0)
        return z.reshape(0, m)
    if z.ndim != 2 or (measurement_dim is not None and z.shape[1] != measurement_dim):
        m = "m" if measurement_dim is None else measurement_dim
        raise ValueError(f"measurements z must have shape (M, {m}), got {z.shape}")
    if not np.isfinite(z).all():
        bad = ~np.isfinite(z).all(axis=1)
        i = int(np.flatnonzero(bad)[0])
        raise ValueError(f"measurements z must be finite: row {i} is {z[i].tolist()}")
    return z
