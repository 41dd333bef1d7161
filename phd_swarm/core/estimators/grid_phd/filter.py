"""The grid ("bin") PHD filter of Dames (2020) as functions on (flat indices, weights).

Every function works on an arbitrary subset of bins given as flat indices (``iy * nx + ix``,
see :mod:`phd_swarm.core.geometry.grid`) and the matching weights, so that the centralised filter
(all bins, :mod:`phd_swarm.core.estimators.grid_phd.central`) and the distributed filter (each
robot holds the bins of its Voronoi cell, Dames Sec. III) share one implementation.

Units. A weight ``w_j`` is a *mass*: the expected number of targets in bin ``j``
(dimensionless), i.e. ``v(x_j) * bin_area`` under the bin-centre rule. Likelihoods, the clutter
PHD and psi are densities per m^2 *in measurement space*. Multiplying the PHD update (eq. 4)
by the bin area turns it into the same equation on masses, and the integral of eq. 5 becomes
a sum over bins, ``int psi_z(x) v(x) dx = sum_j psi_z(x_j) w_j`` [1/m^2].

Update (eq. 4-6), for one sensor at ``q`` with measurement set ``Z`` (M measurements)::

    psi_z(x_j) = g(z | x_j, q) p_d(x_j | q)                        (eq. 6)  [1/m^2]
    eta_z      = c(z | q) + sum_j psi_z(x_j) w_j                    (eq. 5)  [1/m^2]
    w_j       <- (1 - p_d(x_j | q)) w_j + sum_z psi_z(x_j) w_j / eta_z   (eq. 4)  [mass]

Only bins with ``p_d > 0`` (the field-of-view disk, :meth:`Grid.disk_bins`) take part, so
the cost of one update is proportional to the field of view, not to the map.

Prediction (eq. 3) is a convolution of the survival-weighted masses with the discrete motion
kernel, plus the birth mass. Mass that moves outside E is lost (zero padding): eq. 3 only
defines the predicted PHD on E, so targets leave through the boundary.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from scipy import ndimage

from ...geometry.grid import Grid
from ...models import PhdModels
from ...scan import Scan

#: Largest kernel (number of taps, zeros included) convolved directly; larger kernels go
#: through the FFT. Measured on the 2-core reference machine: a 7x7 kernel is as fast
#: directly as by FFT on a 100x100 image, a 9x9 one on a 1000x1000 image, and from 11x11 up
#: the FFT wins on every image size (41x41 on 1000x1000: 32 ms by FFT, ~0.3 s directly).
#: The presets give 5x5 at 1 m (direct, exact to rounding) and 29x29 / 41x41 at 0.1 m (FFT).
DIRECT_MAX_TAPS = 49

#: Outputs of an FFT convolution below this fraction of its largest output are set to 0.
#: The FFT's round-off is ~3e-15 of the largest output wherever the output is (measured
#: against the direct convolution with Chen's 29 x 29 kernel at 0.1 m, on 150 x 150 and
#: 1000 x 1000 images holding 1e-3 next to 1e-8 .. 1e-25), so a smaller output is round-off,
#: not mass; above the floor the relative error is below ~1e-5. Without the floor the
#: masses of searched-out bins are round-off, and the centroid of a cell holding only such
#: bins follows it (docs/decisions.md).
FFT_REL_FLOOR = 1e-9

_METHODS = ("auto", "direct", "fft")


def psi(models: PhdModels, centres: np.ndarray, z: np.ndarray,
        sensor: np.ndarray) -> np.ndarray:
    """Detection-weighted likelihood psi_{z,q}(x) = g(z | x, q) p_d(x | q) (Dames eq. 6).

    Parameters
    ----------
    models : PhdModels
        Supplies g (``models.measurement``) and p_d (``models.detection``).
    centres : np.ndarray, shape (K, 2)
        Bin centres x_j [m].
    z : np.ndarray, shape (M, 2)
        Measurements [m]; M may be 0.
    sensor : np.ndarray, shape (2,)
        Sensor position q [m].

    Returns
    -------
    np.ndarray, shape (M, K)
        ``psi[m, j] = psi_{z_m, q}(x_j)``, a density per m^2 in z; zero for bins outside the
        field of view.
    """
    return _psi_pd(models, centres, z, sensor)[0]


def psi_pd(models: PhdModels, centres: np.ndarray, z: np.ndarray,
           sensor: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """:func:`psi` (M, K) and the p_d (K,) it is built on, computing p_d once (eq. 6).

    The parameters are those of :func:`psi`; ``psi_pd(...)[0] == psi(...)`` exactly and
    ``psi_pd(...)[1] == models.detection.probability(centres, sensor)``.
    """
    return _psi_pd(models, centres, z, sensor)


def eta_partial(psi_zx: np.ndarray, w: np.ndarray) -> np.ndarray:
    """Partial normaliser sum_j psi_z(x_j) w_j over the given bins (Dames eq. 5, Alg. 2 l. 13).

    This is the integral of eq. 5 restricted to the bins one robot holds.

    Summed with numpy's pairwise summation rather than a BLAS product, so that the result
    is the same whatever the BLAS build or thread count (the distributed filter is checked
    against the centralised one).

    Parameters
    ----------
    psi_zx : np.ndarray, shape (M, K)
        psi from :func:`psi` for the K bins [1/m^2].
    w : np.ndarray, shape (K,)
        Masses of those bins (expected target counts).

    Returns
    -------
    np.ndarray, shape (M,)
        One partial integral per measurement [1/m^2].
    """
    psi_zx = np.asarray(psi_zx, dtype=float)
    w = np.asarray(w, dtype=float)
    if psi_zx.ndim != 2 or w.shape != (psi_zx.shape[1],):
        raise ValueError(f"eta_partial: psi must be (M, K) and w (K,), got {psi_zx.shape} "
                         f"and {w.shape}")
    return np.sum(psi_zx * w, axis=1)


def eta_total(partials: Sequence[np.ndarray], clutter: np.ndarray) -> np.ndarray:
    """Normaliser eta_z = c(z | q) + sum of partial integrals (Dames eq. 5, Alg. 2 line 17).

    The partials are added in the order given, left to right, and the clutter last:
    ``c + ((p_0 + p_1) + p_2 ...)``. Callers pass them in increasing robot id so that every
    robot obtains the same floating-point value.

    Parameters
    ----------
    partials : sequence of np.ndarray, each shape (M,)
        :func:`eta_partial` of each holder of bins in the field of view [1/m^2].
    clutter : np.ndarray, shape (M,)
        Clutter PHD c(z | q) at each measurement [1/m^2].

    Returns
    -------
    np.ndarray, shape (M,)
        eta_z [1/m^2].
    """
    clutter = np.asarray(clutter, dtype=float)
    acc = np.zeros_like(clutter)
    for part in partials:
        part = np.asarray(part, dtype=float)
        if part.shape != clutter.shape:
            raise ValueError(f"eta_total: partial of shape {part.shape} does not match "
                             f"clutter of shape {clutter.shape}")
        acc = acc + part
    return clutter + acc


def update_weights(w: np.ndarray, pd: np.ndarray, psi_zx: np.ndarray,
                   eta: np.ndarray) -> np.ndarray:
    """PHD update of bin masses, (1 - p_d) w + sum_z psi_z w / eta_z (Dames eq. 4).

    A measurement with ``eta_z == 0`` (no clutter and no mass that could have produced it)
    contributes nothing: then ``psi_z(x_j) w_j = 0`` for every bin, and 0/0 is taken as 0.
    With no measurements the result is exactly ``(1 - p_d) * w``.

    Parameters
    ----------
    w : np.ndarray, shape (K,)
        Predicted masses.
    pd : np.ndarray, shape (K,)
        Detection probability p_d(x_j | q) of each bin.
    psi_zx : np.ndarray, shape (M, K)
        psi for these bins [1/m^2].
    eta : np.ndarray, shape (M,)
        Full normalisers from :func:`eta_total` [1/m^2].

    Returns
    -------
    np.ndarray, shape (K,)
        Updated masses.
    """
    w = np.asarray(w, dtype=float)
    pd = np.asarray(pd, dtype=float)
    psi_zx = np.asarray(psi_zx, dtype=float)
    eta = np.asarray(eta, dtype=float)
    k = w.shape[0]
    if pd.shape != (k,) or psi_zx.shape != (eta.shape[0], k) or eta.ndim != 1:
        raise ValueError(f"update_weights: expected w (K,), pd (K,), psi (M, K), eta (M,), "
                         f"got {w.shape}, {pd.shape}, {psi_zx.shape}, {eta.shape}")
    inv_eta = np.divide(1.0, eta, out=np.zeros_like(eta), where=eta > 0)
    gain = np.sum(psi_zx * inv_eta[:, None], axis=0)
    return (1.0 - pd) * w + gain * w


def update_bins(grid: Grid, models: PhdModels, bins: np.ndarray, w: np.ndarray,
                scan: Scan) -> np.ndarray:
    """Apply one measurement set (eq. 4-6) to bins that include the whole field of view.

    eta (eq. 5) is summed over ``bins`` alone, so they must include every bin with
    p_d > 0 that holds mass, e.g. ``grid.disk_bins(scan.sensor, models.detection.radius)``.

    Parameters
    ----------
    grid : Grid
    models : PhdModels
    bins : np.ndarray, shape (K,)
        Flat indices of the bins.
    w : np.ndarray, shape (K,)
        Their predicted masses.
    scan : Scan
        Sensor position and measurements.

    Returns
    -------
    np.ndarray, shape (K,)
        Updated masses (a new array).
    """
    psi_zx, pd = _psi_pd(models, grid.centres_of(bins), scan.z, scan.sensor)
    eta = eta_total([eta_partial(psi_zx, w)], models.clutter.intensity(scan.z))
    return update_weights(w, pd, psi_zx, eta)


def convolve_mass(mass: np.ndarray, kernel: np.ndarray, method: str = "auto") -> np.ndarray:
    """Move bin masses with a motion kernel: ``out[y, x] = sum_o kernel[K + o] mass[(y, x) - o]``.

    A true convolution (the kernel is not assumed symmetric): ``kernel[K + ky, K + kx]`` is
    the probability of moving by (kx, ky) bins, as :meth:`RandomWalkMotion.kernel` defines
    it. Outside the image the mass is zero and mass moved outside is dropped (the integral
    over E in Dames eq. 3).

    Parameters
    ----------
    mass : np.ndarray, shape (H, W)
        Masses (expected target counts) per bin.
    kernel : np.ndarray, shape (2K+1, 2L+1)
        Motion kernel; both sides odd, centre = no motion.
    method : {"auto", "direct", "fft"}
        ``"direct"`` is ``scipy.ndimage.convolve`` (exact to rounding); ``"fft"`` is
        ``scipy.signal.fftconvolve`` with every output below :data:`FFT_REL_FLOOR` of the
        largest output (its round-off, negative values included) set to 0;
        ``"auto"`` takes direct for kernels of up to :data:`DIRECT_MAX_TAPS` taps. A 1x1
        kernel is always a plain multiplication, so the identity model is exact.

    Returns
    -------
    np.ndarray, shape (H, W)
        Moved masses (a new array).
    """
    mass = np.asarray(mass, dtype=float)
    kernel = _check_kernel(kernel)
    if method not in _METHODS:
        raise ValueError(f"convolve_mass: method must be one of {_METHODS}, got {method!r}")
    if mass.ndim != 2:
        raise ValueError(f"convolve_mass: mass must be 2-D, got shape {mass.shape}")
    if kernel.shape == (1, 1):
        return mass * kernel[0, 0]
    if mass.size == 0:
        return mass.copy()
    if method == "direct" or (method == "auto" and kernel.size <= DIRECT_MAX_TAPS):
        return ndimage.convolve(mass, kernel, mode="constant", cval=0.0)
    # Imported here: scipy.signal (and scipy.stats, which it imports) take ~0.5 s to import,
    # a cost every robot process would pay at start-up for a path few scenarios take.
    from scipy.signal import fftconvolve

    out = fftconvolve(mass, kernel, mode="same")
    out[out < FFT_REL_FLOOR * max(float(out.max()), 0.0)] = 0.0
    return out


def predict_image(w_img: np.ndarray, kernel: np.ndarray, ps_img: np.ndarray,
                  birth_img: np.ndarray, method: str = "auto") -> np.ndarray:
    """PHD prediction on the whole grid, b + f * (p_s w) (Dames eq. 3).

    Survival multiplies the mass *before* it moves (p_s(xi) in eq. 3); birth is added after.

    Parameters
    ----------
    w_img : np.ndarray, shape (ny, nx)
        Masses after the previous update.
    kernel : np.ndarray, shape (2K+1, 2K+1)
        Motion kernel (:meth:`RandomWalkMotion.kernel`).
    ps_img : np.ndarray, shape (ny, nx) or broadcastable
        Survival probability p_s at each bin centre.
    birth_img : np.ndarray, shape (ny, nx) or broadcastable
        Birth mass per bin, b(x_j) * bin_area (expected new targets).
    method : {"auto", "direct", "fft"}
        See :func:`convolve_mass`.

    Returns
    -------
    np.ndarray, shape (ny, nx)
        Predicted masses (a new array).
    """
    w_img = np.asarray(w_img, dtype=float)
    moved = convolve_mass(np.asarray(ps_img, dtype=float) * w_img, kernel, method)
    return np.asarray(birth_img, dtype=float) + moved


def spread(grid: Grid, flat: np.ndarray, w: np.ndarray, kernel: np.ndarray,
           method: str = "auto") -> tuple[np.ndarray, np.ndarray]:
    """Move the masses of a subset of bins with the motion kernel (sparse eq. 3, no birth).

    This is the prediction over a robot's *expanded* cell with phantom particles (Dames
    Sec. III-B, Fig. 1b): the given bins' masses are convolved inside their bounding box grown
    by the kernel half-width (clipped to E, so mass leaving E is lost as in
    :func:`convolve_mass`). Convolution is linear, so summing ``spread`` over a partition of
    the bins gives the full-image convolution to rounding (~1e-15 relative).

    Parameters
    ----------
    grid : Grid
    flat : np.ndarray, shape (K,)
        Flat indices of the bins whose mass moves; duplicates add.
    w : np.ndarray, shape (K,)
        Their masses, already multiplied by p_s.
    kernel : np.ndarray, shape (2K'+1, 2L'+1)
        Motion kernel.
    method : {"auto", "direct", "fft"}
        See :func:`convolve_mass`.

    Returns
    -------
    flat_out : np.ndarray of int64, shape (K_out,)
        Ascending flat indices of every bin of E that the kernel can reach from ``flat``
        (the given bins dilated by the kernel's non-zero support), whatever the weights.
    w_out : np.ndarray, shape (K_out,)
        Mass arriving in each of those bins.
    """
    flat = np.asarray(flat, dtype=np.int64).reshape(-1)
    w = np.asarray(w, dtype=float).reshape(-1)
    kernel = _check_kernel(kernel)
    if w.shape != flat.shape:
        raise ValueError(f"spread: flat {flat.shape} and w {w.shape} differ in shape")
    if flat.size == 0:
        return np.empty(0, dtype=np.int64), np.empty(0)
    if flat.min() < 0 or flat.max() >= grid.size:
        raise ValueError(f"spread: flat indices must be in [0, {grid.size})")
    iy, ix = grid.unravel(flat)
    hy, hx = kernel.shape[0] // 2, kernel.shape[1] // 2
    y0, y1 = max(int(iy.min()) - hy, 0), min(int(iy.max()) + hy, grid.ny - 1)
    x0, x1 = max(int(ix.min()) - hx, 0), min(int(ix.max()) + hx, grid.nx - 1)
    box_shape = (y1 - y0 + 1, x1 - x0 + 1)
    local = (iy - y0) * box_shape[1] + (ix - x0)
    n_box = box_shape[0] * box_shape[1]
    box = np.bincount(local, weights=w, minlength=n_box).reshape(box_shape)
    held = np.bincount(local, minlength=n_box).reshape(box_shape) > 0
    moved = convolve_mass(box, kernel, method)
    # The receiving set is structural (the dilation of the held bins by the kernel's
    # support), so it does not depend on which weights happen to be zero or on FFT noise.
    reach = convolve_mass(held.astype(float), (kernel != 0).astype(float), method) > 0.5
    ry, rx = np.nonzero(reach)
    return (ry + y0) * grid.nx + (rx + x0), moved[ry, rx]


def _check_kernel(kernel: np.ndarray) -> np.ndarray:
    kernel = np.asarray(kernel, dtype=float)
    if kernel.ndim != 2 or kernel.shape[0] % 2 != 1 or kernel.shape[1] % 2 != 1:
        raise ValueError(f"motion kernel must be 2-D with odd sides, got shape {kernel.shape}")
    return kernel


def _psi_pd(models: PhdModels, centres: np.ndarray, z: np.ndarray,
            sensor: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Return psi (M, K) and p_d (K,) at ``centres`` (eq. 6), computing p_d once."""
    centres = np.asarray(centres, dtype=float).reshape(-1, 2)
    pd = models.detection.probability(centres, sensor)
    return models.measurement.likelihood(z, centres) * pd, pd
