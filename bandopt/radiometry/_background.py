"""The natural night-sky background: a floor under every detection limit.

Seen from orbit on a moonless night, a pixel without lamps still sends up
airglow (emitted at 85-100 km, above most of the extinction, isotropic, so its
radiance seen from above is about the zenith value seen from the ground) and
the night-sky light (airglow, integrated starlight, zodiacal light) reflected
by the ground. We take the order of magnitude of both from the dark-time
zenith sky brightness measured at ESO Paranal during sunspot maximum
(`Patat2003`: B 22.6, V 21.6, R 20.9, I 19.7 mag arcsec⁻²), converted with the
Bessell et al. (`Bessell1998`, Table A2) zero points, and interpolate
log-linearly in radiance between the band effective wavelengths (constant
beyond the end points). This gives about 2.5e-9 W m⁻² sr⁻¹ nm⁻¹ in the blue,
3.5e-9 at 545 nm and 6.3e-9 at 800 nm, where the OH Meinel bands dominate.

**Uncertainty.** A factor of 2 either way (`BACKGROUND_UNCERTAINTY_FACTOR`):
airglow varies by about 0.5 mag with the solar cycle and from night to night
(`Leinert1998`, section 9; `Patat2003`), zodiacal light and starlight in the
ground-based values are absent from the view from above while the reflected
part adds ρ·E_sky/π (at most ~0.3 of the sky radiance for ρ ≤ 0.3). It is a
broad-band continuum: a narrow band (FWHM ≲ 20 nm) on an airglow line (O I
557.7 nm, Na 589 nm, O I 630 nm, the OH bands) sees more.
"""

import math

import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike, Float

from ..spectra import trapezoid_weights


ARCSEC2_SR: float = (math.pi / 180.0 / 3600.0) ** 2
"""One square arcsecond. [sr]"""

NIGHT_SKY_MAG_ARCSEC2: dict[str, tuple[float, float]] = {
    "B": (438.0, 22.6),
    "V": (545.0, 21.6),
    "R": (641.0, 20.9),
    "I": (798.0, 19.7),
}
"""Dark-time zenith night-sky brightness at ESO Paranal, sunspot maximum
(`Patat2003`, abstract): band -> (effective wavelength [nm], surface brightness
[mag arcsec⁻²]). Effective wavelengths from `Bessell1998`."""

ZERO_POINT_W_M2_NM: dict[str, float] = {
    "B": 6.32e-11,
    "V": 3.631e-11,
    "R": 2.177e-11,
    "I": 1.126e-11,
}
"""Flux density of magnitude 0 (`Bessell1998`, Table A2: 632, 363.1, 217.7,
112.6 x 1e-11 erg cm⁻² s⁻¹ Å⁻¹). [W m⁻² nm⁻¹]"""

BACKGROUND_UNCERTAINTY_FACTOR: float = 2.0
"""Multiplicative uncertainty of the background floor (see module docstring). [1]"""


def surface_brightness_to_radiance(
    mag_arcsec2: Float[ArrayLike, "*batch"],
    zero_point_w_m2_nm: Float[ArrayLike, "*batch"],
) -> Float[Array, "*batch"]:
    """`F0 · 10^(-0.4 m) / Ω(1 arcsec²)`. [W m⁻² sr⁻¹ nm⁻¹]"""
    m = jnp.asarray(mag_arcsec2, dtype=float)
    return jnp.asarray(zero_point_w_m2_nm) * 10.0 ** (-0.4 * m) / ARCSEC2_SR


def night_sky_radiance(
    wavelength_nm: Float[ArrayLike, " w"], *, scale: float = 1.0
) -> Float[Array, " w"]:
    """Natural background spectral radiance at the top of the atmosphere on a
    moonless night (see module docstring), times `scale`. [W m⁻² sr⁻¹ nm⁻¹]

    Log-linear interpolation between the B, V, R, I points; constant below
    438 nm and above 798 nm.
    """
    if not scale > 0:
        raise ValueError(f"scale must be > 0, got {scale!r}.")
    keys = list(NIGHT_SKY_MAG_ARCSEC2)
    lam = np.array([NIGHT_SKY_MAG_ARCSEC2[k][0] for k in keys])
    rad = np.asarray(
        surface_brightness_to_radiance(
            np.array([NIGHT_SKY_MAG_ARCSEC2[k][1] for k in keys]),
            np.array([ZERO_POINT_W_M2_NM[k] for k in keys]),
        )
    )
    w = jnp.asarray(wavelength_nm, dtype=float)
    return scale * jnp.exp(jnp.interp(w, jnp.asarray(lam), jnp.log(jnp.asarray(rad))))


def background_band_radiance(
    response: Float[ArrayLike, "b w"],
    wavelength_nm: Float[ArrayLike, " w"],
    *,
    scale: float = 1.0,
) -> Float[Array, " b"]:
    """Band-averaged natural background `∫ L_bg R dλ / ∫ R dλ` per band.
    [W m⁻² sr⁻¹ nm⁻¹]"""
    w = jnp.asarray(wavelength_nm, dtype=float)
    r = jnp.asarray(response) * trapezoid_weights(w)[None, :]
    area = jnp.sum(r, axis=-1)
    ok = area > 0
    num = r @ night_sky_radiance(w, scale=scale)
    return jnp.where(ok, num / jnp.where(ok, area, 1.0), 0.0)
