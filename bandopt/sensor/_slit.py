"""Slit functions and band radiance (thesis Eqs. 2.13-2.15).

Everything here is a pure JAX function on arrays: `w` wavelength samples, `b`
bands, `*batch` anything in front. Band radiance is a dense matmul with
`precision=HIGHEST` (on this CPU a dense matmul beats windowed gathers, see
ARCHITECTURE.md); work is skipped by cropping the grid with `crop_to_support`.
"""

import math

import jax.lax as lax
import jax.numpy as jnp
import numpy as np
from jax.scipy.special import gammaincc
from jaxtyping import Array, ArrayLike, Float

from ..spectra import trapezoid_weights


_LN2 = math.log(2.0)


def _log_power_cap(dtype) -> float:
    """Largest exponent `y` kept in `2^-y`: beyond it the response is below the
    smallest normal number of `dtype` (2^-126 in float32, 2^-1022 in float64)."""
    return 126.0 if jnp.finfo(dtype).bits <= 32 else 1022.0


def _abs_power(x: Float[Array, "*s"], k: Float[Array, "*s"], cap: float):
    """`min(|x|^k, cap)` with finite gradients everywhere.

    Written as `exp(min(k log|x|, log cap))` with a double-where at `x = 0`:
    the naive `|x|**k` has a NaN k-gradient at `x = 0` (`0 * log 0`) and its
    backward pass overflows in float32 for large `|x|` and `k >= 20`.
    """
    ax = jnp.abs(x)
    pos = ax > 0
    safe = jnp.where(pos, ax, 1.0)
    log_p = jnp.minimum(k * jnp.log(safe), math.log(cap))
    return jnp.where(pos, jnp.exp(log_p), 0.0)


def slit_super_gaussian(
    wavelength_nm: Float[ArrayLike, " w"],
    centre_nm: Float[ArrayLike, " b"],
    fwhm_nm: Float[ArrayLike, " b"],
    shape_k: Float[ArrayLike, " b"],
) -> Float[Array, "b w"]:
    """Super-Gaussian relative spectral response `R = 2^-|2(λ-λc)/Δλ|^k`. [1]

    Thesis Eq. 2.15 (its refs. [45, 46]): peak 1
    at `centre_nm`, exactly 1/2 at `centre_nm ± fwhm_nm/2` for every `k`;
    `k = 2` is a Gaussian, `k = 6` the thesis default, large `k` approaches a
    rectangle. Deviation: `|x|^k` is capped where `R` drops below the smallest
    normal float (`_abs_power`), so values there are that tiny number rather
    than a denormal, and gradients stay finite in float32 and float64,
    including a centre exactly on a grid wavelength.

    **Arguments:**

    - `wavelength_nm`: sample wavelengths. [nm]
    - `centre_nm`: band centres `λc`. [nm]
    - `fwhm_nm`: full widths at half maximum `Δλ`, > 0. [nm]
    - `shape_k`: shape exponents `k`, > 1. [1]
    """
    wavelength_nm = jnp.asarray(wavelength_nm)
    dtype = jnp.result_type(float, wavelength_nm.dtype)
    wavelength_nm = wavelength_nm.astype(dtype)
    centre_nm, fwhm_nm, shape_k = (
        jnp.asarray(a, dtype=dtype) for a in (centre_nm, fwhm_nm, shape_k)
    )
    x = 2.0 * (wavelength_nm[None, :] - centre_nm[:, None]) / fwhm_nm[:, None]
    cap = _log_power_cap(x.dtype)
    p = _abs_power(x, jnp.broadcast_to(shape_k[:, None], x.shape), cap)
    return jnp.exp2(-p)


def super_gaussian_area_nm(
    fwhm_nm: Float[ArrayLike, " b"], shape_k: Float[ArrayLike, " b"]
) -> Float[Array, " b"]:
    """Exact area `∫R dλ = Δλ Γ(1 + 1/k) / (ln 2)^(1/k)` over all λ. [nm]

    A Gaussian (`k = 2`) has 1.0645 Δλ, `k = 6` 0.9862 Δλ, a rectangle Δλ.
    """
    fwhm_nm, shape_k = jnp.asarray(fwhm_nm), jnp.asarray(shape_k)
    inv_k = 1.0 / shape_k
    return fwhm_nm * jnp.exp(lax.lgamma(1.0 + inv_k) - inv_k * jnp.log(_LN2))


def _one_sided_tail(a: Float[Array, " b"], shape_k: Float[Array, " b"]):
    """Fraction of a super-Gaussian's area beyond `x = a` on one side (x = 2Δ/FWHM).

    For `a >= 0` it is `Q(1/k, ln2 a^k) / 2` (regularised upper incomplete
    gamma); for `a < 0` it is `1 - Q(1/k, ln2 |a|^k) / 2`.
    """
    cap = _log_power_cap(a.dtype)
    y = _LN2 * _abs_power(a, shape_k, min(cap, 700.0))
    half_q = 0.5 * gammaincc(1.0 / shape_k, y)
    return jnp.where(a >= 0, half_q, 1.0 - half_q)


def super_gaussian_fraction_outside(
    centre_nm: Float[ArrayLike, " b"],
    fwhm_nm: Float[ArrayLike, " b"],
    shape_k: Float[ArrayLike, " b"],
    lower_nm: ArrayLike,
    upper_nm: ArrayLike,
) -> Float[Array, " b"]:
    """Fraction of each band's response area outside `[lower_nm, upper_nm]`. [1]

    Exact (incomplete gamma function), differentiable in every argument. Use
    it to report what a band loses when it runs off the data grid.
    """
    centre_nm, fwhm_nm, shape_k = (
        jnp.asarray(a) for a in (centre_nm, fwhm_nm, shape_k)
    )
    a_up = 2.0 * (upper_nm - centre_nm) / fwhm_nm
    a_lo = 2.0 * (centre_nm - lower_nm) / fwhm_nm
    return _one_sided_tail(a_up, shape_k) + _one_sided_tail(a_lo, shape_k)


def band_average(
    spectra: Float[ArrayLike, "*batch w"],
    response: Float[ArrayLike, "b w"],
    wavelength_nm: Float[ArrayLike, " w"],
) -> Float[Array, "*batch b"]:
    """Band-averaged spectral radiance `∫ L R dλ / ∫ R dλ` (thesis Eq. 2.14).

    Trapezoid rule on the given grid, one dense matmul (`precision=HIGHEST`).
    Both integrals run over the grid only: for a response that is partly off
    the grid this is the average over the on-grid part. Check
    `BandSet.fraction_outside` (or call `BandSet.band_average`, which raises
    or reports) before trusting such a band. A band with no response on the
    grid returns 0 with a zero gradient (double-where), not NaN.

    **Arguments:**

    - `spectra`: spectral radiance, last axis wavelength. [any, e.g. W m-2 sr-1 nm-1]
    - `response`: relative spectral response per band. [1]
    - `wavelength_nm`: the common grid. [nm]

    **Returns:** `(*batch, b)` band averages. [unit of `spectra`]
    """
    response = jnp.asarray(response)
    weighted = response * trapezoid_weights(wavelength_nm)[None, :]  # [nm]
    area = jnp.sum(weighted, axis=-1, keepdims=True)  # [nm]
    ok = area > 0
    safe_area = jnp.where(ok, area, 1.0)
    weights = jnp.where(ok, weighted / safe_area, 0.0)  # rows sum to 1
    return jnp.matmul(jnp.asarray(spectra), weights.T, precision=lax.Precision.HIGHEST)


def band_integrate(
    spectra: Float[ArrayLike, "*batch w"],
    response: Float[ArrayLike, "b w"],
    wavelength_nm: Float[ArrayLike, " w"],
) -> Float[Array, "*batch b"]:
    """Band-integrated radiance `∫ L R dλ` (thesis Eq. 2.13), peak-normalised `R`.

    Trapezoid rule on the grid, one dense matmul. [unit of `spectra` x nm,
    e.g. W m-2 sr-1]
    """
    weighted = jnp.asarray(response) * trapezoid_weights(wavelength_nm)[None, :]
    return jnp.matmul(jnp.asarray(spectra), weighted.T, precision=lax.Precision.HIGHEST)


def crop_to_support(
    wavelength_nm: Float[ArrayLike, " w"],
    response: Float[ArrayLike, "b w"],
    *,
    tail: float = 1e-6,
) -> slice:
    """Static index slice of `wavelength_nm` covering every band's support.

    The support of a band is where its response is at least `tail` times its
    own peak on the grid; the slice runs from one sample before the first such
    wavelength of any band to one sample after the last (so the trapezoid
    still sees the drop to the tail), clipped to the grid. Everything outside
    it carries less than `tail` of each band's peak: slicing `spectra[...,
    s]`, `response[:, s]`, `wavelength_nm[s]` changes band averages by about
    `tail` relative (the cut tails) and skips the work. Gaps between bands are
    kept (the slice is contiguous).

    Needs concrete (non-traced) values: call it outside `jit`, on the response
    of a fixed band set (e.g. the bounds of a search). A grid with no response
    at all returns an empty slice.
    """
    if not 0 <= tail < 1:
        raise ValueError(f"`tail` must lie in [0, 1), got {tail!r}.")
    try:
        r = np.asarray(response, dtype=float)
        wl = np.asarray(wavelength_nm, dtype=float)
    except Exception as err:  # jax raises a TracerArrayConversionError subclass
        raise ValueError(
            "crop_to_support needs concrete arrays (call it outside jit)."
        ) from err
    if r.ndim != 2 or r.shape[1] != wl.shape[0]:
        raise ValueError(
            f"`response` must have shape (b, {wl.shape[0]}), got {r.shape}."
        )
    peak = r.max(axis=1, keepdims=True)
    inside = np.any((r >= tail * peak) & (peak > 0), axis=0)
    if not inside.any():
        return slice(0, 0)
    idx = np.flatnonzero(inside)
    return slice(max(int(idx[0]) - 1, 0), min(int(idx[-1]) + 2, wl.shape[0]))
