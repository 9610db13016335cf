"""From a fine radiance image to what a sensor of a given GSD records.

1. **PSF**: a Gaussian of standard deviation σ, either from its FWHM as a
   multiple of the GSD (`fwhm_gsd`, σ = fwhm / (2 sqrt(2 ln 2))) or from the
   value of its MTF at the Nyquist frequency `f_N = 1 / (2 GSD)`:
   `MTF(f) = exp(-2 π² σ² f²)` gives `σ = GSD sqrt(-2 ln MTF_N) / π`
   (thesis section 2.5.4: the GRD follows the PSF, not the GSD). Default:
   FWHM = 1 GSD (MTF at Nyquist 0.41).
2. **Pixel integration**: the box average over each GSD x GSD pixel.
3. **Noise and quantisation** (`bandopt.sensor`, thesis Eqs. 2.16-2.21):
   band radiance to electrons with the flat-spectrum responsivity (exact for a
   spectrum flat within the band), photon noise drawn from a seeded key, back
   to radiance, then optional quantisation and de-quantisation.

The blur is applied on the fine grid after a first box average to an
intermediate step no larger than a quarter of σ (that box's variance,
step²/12, is subtracted from σ², so the total response is still the stated
Gaussian convolved with the GSD box). Edges are padded with zeros (dark
surroundings beyond the scene). The scene extent should be a multiple of the
GSD; a remainder is cropped.
"""

import math

import jax
import jax.numpy as jnp
import numpy as np
from scipy import ndimage

from ..sensor import (
    SensorParams,
    add_photon_noise,
    dequantise,
    noise_electrons,
    quantise,
    radiance_step,
    responsivity,
)
from ..spectra import GRID_1NM
from ._render import Grid


GSDS_M = (1.0, 2.0, 5.0, 10.0, 20.0, 50.0, 100.0)
"""The ground sample distances studied (thesis section 4.3). [m]"""


def psf_sigma_m(
    gsd_m: float, *, fwhm_gsd: float | None = 1.0, mtf_nyquist: float | None = None
) -> float:
    """Standard deviation of the Gaussian PSF on the ground. [m]

    Give either `fwhm_gsd` (FWHM in units of the GSD) or `mtf_nyquist` (MTF at
    the Nyquist frequency, in (0, 1)); `mtf_nyquist` wins when both are given.
    """
    if not gsd_m > 0:
        raise ValueError(f"gsd_m must be > 0, got {gsd_m!r}.")
    if mtf_nyquist is not None:
        if not 0.0 < mtf_nyquist < 1.0:
            raise ValueError(f"mtf_nyquist must lie in (0, 1), got {mtf_nyquist!r}.")
        return gsd_m * math.sqrt(-2.0 * math.log(mtf_nyquist)) / math.pi
    if fwhm_gsd is None or not fwhm_gsd >= 0:
        raise ValueError(f"fwhm_gsd must be >= 0, got {fwhm_gsd!r}.")
    return fwhm_gsd * gsd_m / (2.0 * math.sqrt(2.0 * math.log(2.0)))


def mtf_at_nyquist(sigma_m: float, gsd_m: float) -> float:
    """MTF of the Gaussian PSF at `1 / (2 GSD)`. [1]"""
    return math.exp(-(math.pi**2) * sigma_m**2 / (2.0 * gsd_m**2))


def block_mean(image: np.ndarray, factor: int) -> np.ndarray:
    """Box average over `factor` x `factor` blocks of the last two axes
    (a remainder is cropped)."""
    if factor == 1:
        return image
    *lead, ny, nx = image.shape
    my, mx = ny // factor, nx // factor
    if my == 0 or mx == 0:
        raise ValueError(
            f"Image {ny}x{nx} is smaller than one {factor}x{factor} block."
        )
    cut = image[..., : my * factor, : mx * factor]
    return cut.reshape(*lead, my, factor, mx, factor).mean(axis=(-3, -1))


def _factor(gsd_m: float, dx_m: float) -> int:
    f = gsd_m / dx_m
    if abs(f - round(f)) > 1e-6 or round(f) < 1:
        raise ValueError(
            f"gsd_m={gsd_m!r} must be a whole multiple of the fine grid step {dx_m!r}."
        )
    return round(f)


def resample_to_gsd(
    image: np.ndarray,
    dx_m: float,
    gsd_m: float,
    *,
    sigma_m: float | None = None,
) -> np.ndarray:
    """Blur with the Gaussian PSF (`sigma_m`, default `psf_sigma_m(gsd_m)`) and
    box-average to `gsd_m`. The last two axes are (y, x). [unit of image]"""
    image = np.asarray(image, float)
    factor = _factor(gsd_m, dx_m)
    sigma = psf_sigma_m(gsd_m) if sigma_m is None else float(sigma_m)
    if sigma < 0:
        raise ValueError(f"sigma_m must be >= 0, got {sigma_m!r}.")
    # largest divisor of factor whose step is at most sigma / 4
    step = 1
    for d in range(1, factor + 1):
        if factor % d == 0 and d * dx_m <= sigma / 4.0:
            step = d
    mid = block_mean(image, step)
    var = sigma**2 - (step * dx_m) ** 2 / 12.0 * (step > 1)
    s_px = math.sqrt(max(var, 0.0)) / (step * dx_m)
    if s_px > 0:
        axes = (mid.ndim - 2, mid.ndim - 1)
        sig = [0.0] * mid.ndim
        for a in axes:
            sig[a] = s_px
        mid = ndimage.gaussian_filter(mid, sig, mode="constant", cval=0.0, truncate=4.0)
    return block_mean(mid, factor // step)


def gsd_grid(grid, gsd_m: float):
    """The coarse grid of `resample_to_gsd` (same origin, cropped)."""
    f = _factor(gsd_m, grid.dx_m)
    return Grid(grid.x0_m, grid.y0_m, grid.nx // f, grid.ny // f, float(gsd_m))


def sensor_image(
    radiance: np.ndarray,
    bands,
    gsd_m: float,
    *,
    seed: int,
    wavelength_nm: np.ndarray | None = None,
    params=None,
    bit_depth: int | None = 14,
    detection_limit_w_m2_sr_nm=0.0,
    saturation_w_m2_sr_nm=1e-3,
    noise: bool = True,
) -> np.ndarray:
    """Add photon noise and quantisation to a (b, ny, nx) band radiance image
    at `gsd_m`. Returns calibrated radiance. [W m⁻² sr⁻¹ nm⁻¹]

    `params` defaults to `bandopt.sensor.SensorParams.for_gsd(gsd_m)` (thesis
    Table 2.3 with the integration time of a pixel at this GSD from 600 km).
    Electrons = radiance x flat-spectrum responsivity per band; Gaussian
    photon noise from `jax.random.PRNGKey(seed)`; quantisation with
    `bit_depth` bits between the detection limit and saturation (scalars or
    one per band; None: off).
    """
    wl = np.asarray(GRID_1NM if wavelength_nm is None else wavelength_nm, float)
    params = params or SensorParams.for_gsd(gsd_m)
    resp = np.asarray(
        responsivity(bands.response(jnp.asarray(wl)), jnp.asarray(wl), params)
    )
    rad = np.asarray(radiance, float)
    out = rad
    if noise:
        e = rad * resp[:, None, None]
        noisy = add_photon_noise(jax.random.PRNGKey(seed), jnp.asarray(e), params)
        out = np.asarray(noisy) / resp[:, None, None]
    if bit_depth is not None:
        lo = _band_column(detection_limit_w_m2_sr_nm, out.shape[0])
        hi = _band_column(saturation_w_m2_sr_nm, out.shape[0])
        dn = quantise(jnp.asarray(out), lo, hi, bit_depth)
        out = np.asarray(dequantise(dn, lo, hi, bit_depth))
    return out


def _band_column(value, n: int) -> np.ndarray:
    """A scalar or per-band value as an (n, 1, 1) column."""
    v = np.broadcast_to(np.asarray(value, float), (n,))
    return v[:, None, None]


def noise_variance(
    image: np.ndarray,
    bands,
    gsd_m: float,
    *,
    wavelength_nm: np.ndarray | None = None,
    params=None,
    bit_depth: int | None = 14,
    detection_limit_w_m2_sr_nm=0.0,
    saturation_w_m2_sr_nm=1e-3,
) -> np.ndarray:
    """Per-pixel noise variance of a (b, ny, nx) band radiance image as
    `sensor_image` records it: the photon model at the radiance the pixel
    holds (`bandopt.sensor.noise_electrons`: shot noise, dark current, read
    noise and the quantisation step), in radiance². What a detector that
    knows its sensor can compute from its own image.
    [(W m⁻² sr⁻¹ nm⁻¹)²]"""
    wl = np.asarray(GRID_1NM if wavelength_nm is None else wavelength_nm, float)
    params = params or SensorParams.for_gsd(gsd_m)
    resp = np.asarray(
        responsivity(bands.response(jnp.asarray(wl)), jnp.asarray(wl), params)
    )[:, None, None]
    n = resp.shape[0]
    step = (
        0.0
        if bit_depth is None
        else np.asarray(
            radiance_step(
                _band_column(detection_limit_w_m2_sr_nm, n),
                _band_column(saturation_w_m2_sr_nm, n),
                bit_depth,
            )
        )
    )
    e = np.asarray(noise_electrons(np.asarray(image, float) * resp, params,
                                   electrons_per_dn=step * resp))  # fmt: skip
    return (e / resp) ** 2
