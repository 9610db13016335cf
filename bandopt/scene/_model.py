"""The factorised radiance model on one wavelength grid: the factor arrays
(`Factors`), their contraction over wavelength with band weights into band
terms (`band_weights`, `band_terms`, `BandTerms`), the band radiance of lamp,
moonlit and fire scenes from those terms, and `full_toa_radiance`, the
term-by-term spectrum of one scenario the contraction is tested against.
Apart from `build_scenarios` because what uses a scenario set (search,
inversion, radiometry) works on its factors and band terms.
"""

import math

import equinox as eqx
import jax.lax as lax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Float

from ..spectra import trapezoid_weights


class Factors(eqx.Module):
    """The factor arrays of a scenario set on one wavelength grid.

    - `wavelength_nm`: grid. [nm]
    - `lamp`: spectral irradiance per lux, `S_l`. (l, w) [W m⁻² nm⁻¹ lx⁻¹]
    - `reflectance`: surface reflectance. (s, w) [1]
    - `t_up`: upward total transmittance. (a, w) [1]
    - `moon_ground`: `T_down E_moon cos θ` on the ground, or None.
      (a, m, w) [W m⁻² nm⁻¹]
    - `path`: moonlight path radiance, or None. (a, m, w) [W m⁻² sr⁻¹ nm⁻¹]
    - `illuminance_lx`: class illuminances. (c,) [lx]
    - `uplight`: `f_up = i(θv) / (d cos θv)` (or `u / (1 - u) / π`), or None.
      [sr⁻¹]
    - `fire`: `f_fire ε B(T)`, or None. (f, w) [W m⁻² sr⁻¹ nm⁻¹]
    - `t_dir`: upward direct transmittance, or None for a uniform
      neighbourhood (then `t_up` alone applies). (a, w) [1]
    - `neighbour_lamp`: `k`, the neighbourhood's lamp light relative to the
      pixel's (lit fraction x relative illuminance); used with `t_dir`. () [1]
    - `background`: reflectance of the neighbourhood's ground, or None for the
      pixel's own surface. (w,) [1]
    """

    wavelength_nm: Float[Array, " w"]
    lamp: Float[Array, "l w"]
    reflectance: Float[Array, "s w"]
    t_up: Float[Array, "a w"]
    moon_ground: Float[Array, "a m w"] | None
    path: Float[Array, "a m w"] | None
    illuminance_lx: Float[Array, " c"]
    uplight: float | None = eqx.field(static=True)
    fire: Float[Array, "f w"] | None
    t_dir: Float[Array, "a w"] | None = None
    neighbour_lamp: Float[Array, ""] | None = None
    background: Float[Array, " w"] | None = None

    def crop(self, lower_nm: float, upper_nm: float) -> "Factors":
        """The same factors on the grid samples inside [lower_nm, upper_nm] (a
        static slice: work outside the bands' support is skipped)."""
        w = np.asarray(self.wavelength_nm)
        i0 = int(np.searchsorted(w, lower_nm, side="left"))
        i1 = int(np.searchsorted(w, upper_nm, side="right"))
        i0, i1 = max(i0 - 1, 0), min(i1 + 1, w.size)  # keep one sample margin

        def cut(a):
            return None if a is None else a[..., i0:i1]

        return Factors(
            self.wavelength_nm[i0:i1],
            cut(self.lamp),
            cut(self.reflectance),
            cut(self.t_up),
            cut(self.moon_ground),
            cut(self.path),
            self.illuminance_lx,
            self.uplight,
            cut(self.fire),
            cut(self.t_dir),
            self.neighbour_lamp,
            cut(self.background),
        )

    def emission_transmittance(self) -> Float[Array, "a w"]:
        """Transmittance of light emitted in the pixel (uplight, fire; and lamp
        light reflected by a neighbourhood of the pixel's own surface):
        `t_up` for a uniform neighbourhood, else `t_dir + k (t_up - t_dir)`. [1]"""
        if self.t_dir is None:
            return self.t_up
        return self.t_dir + self.neighbour_lamp * (self.t_up - self.t_dir)


class BandTerms(eqx.Module):
    """Band radiance of each term, contracted over wavelength. [W m⁻² sr⁻¹ nm⁻¹]
    (band-averaged) or [W m⁻² sr⁻¹] (band-integrated)

    With a uniform neighbourhood `T = T_up`; otherwise `T_e = T_dir + k T_dif`
    (`Factors.emission_transmittance`) and, with a background surface ρ_n,
    the ground terms split into the pixel's direct and the neighbourhood's
    diffuse part (`bandopt.scene`).

    - `lamp_surface`: `T_e ρ/π S_l` (or `T_dir ρ/π S_l + k T_dif ρ_n/π S_l`)
      per lux. (l, s, a, b)
    - `uplight`: `T_e f_up S_l` per lux, or None. (l, a, b)
    - `moon`: `T_up ρ/π T_down E_moon cos θ` (or `(T_dir ρ + T_dif ρ_n)/π ...`),
      or None. (s, a, m, b)
    - `path`: moonlight path radiance, or None. (a, m, b)
    - `fire`: `T_e f ε B`, or None. (f, a, b)
    - `illuminance_lx`: (c,) [lx]
    """

    lamp_surface: Float[Array, "l s a b"]
    uplight: Float[Array, "l a b"] | None
    moon: Float[Array, "s a m b"] | None
    path: Float[Array, "a m b"] | None
    fire: Float[Array, "f a b"] | None
    illuminance_lx: Float[Array, " c"]


_HI = lax.Precision.HIGHEST


def band_weights(
    response: Float[Array, "b w"],
    wavelength_nm: Float[Array, " w"],
    *,
    average: bool = True,
) -> Float[Array, "b w"]:
    """Quadrature weights that turn a spectrum into band radiance.

    `average=True`: band-averaged radiance `∫LR dλ / ∫R dλ` (thesis Eq. 2.14);
    `False`: band-integrated `∫LR dλ` (Eq. 2.13). A band with no response on the
    grid gets zero weights (double-where: no NaN in gradients).
    """
    w = response * trapezoid_weights(wavelength_nm)[None, :]
    if not average:
        return w
    area = jnp.sum(w, axis=-1, keepdims=True)
    ok = area > 0
    return jnp.where(ok, w / jnp.where(ok, area, 1.0), 0.0)


def band_terms(factors: Factors, weights: Float[Array, "b w"]) -> BandTerms:
    """Contract every term over wavelength with band weights (from `band_weights`)."""
    f = factors
    tw = f.t_up[:, None, :] * weights[None, :, :]  # (a, b, w)
    # lamp-driven terms: T_e = T_up (uniform) or T_dir + k T_dif
    ew = (
        tw
        if f.t_dir is None
        else f.emission_transmittance()[:, None, :] * weights[None, :, :]
    )
    rho = f.reflectance / math.pi
    split = f.t_dir is not None and f.background is not None
    if split:  # own ground direct, the neighbourhood's ground diffuse
        dw = f.t_dir[:, None, :] * weights[None, :, :]
        fw = tw - dw  # T_dif
        rho_n = f.background / math.pi
        lamp_surface = (
            jnp.einsum("lw,sw,abw->lsab", f.lamp, rho, dw, precision=_HI)
            + f.neighbour_lamp
            * jnp.einsum("lw,w,abw->lab", f.lamp, rho_n, fw, precision=_HI)[:, None]
        )
    else:
        lamp_surface = jnp.einsum("lw,sw,abw->lsab", f.lamp, rho, ew, precision=_HI)
    uplight = (
        None
        if f.uplight is None
        else f.uplight * jnp.einsum("lw,abw->lab", f.lamp, ew, precision=_HI)
    )
    moon = None
    if f.moon_ground is not None:
        if split:
            moon = (
                jnp.einsum("sw,amw,abw->samb", rho, f.moon_ground, dw, precision=_HI)
                + jnp.einsum("w,amw,abw->amb", rho_n, f.moon_ground, fw, precision=_HI)[
                    None
                ]
            )
        else:  # the whole neighbourhood is moonlit: T_dir + T_dif = T_up
            moon = jnp.einsum("sw,amw,abw->samb", rho, f.moon_ground, tw, precision=_HI)
    path = (
        None
        if f.path is None
        else jnp.einsum("amw,bw->amb", f.path, weights, precision=_HI)
    )
    fire = (
        None if f.fire is None else jnp.einsum("fw,abw->fab", f.fire, ew, precision=_HI)
    )
    return BandTerms(lamp_surface, uplight, moon, path, fire, f.illuminance_lx)


def lamp_scenes(terms: BandTerms) -> Float[Array, "l s a m c b"]:
    """Band radiance of every lamp scene: (lamp, surface, atmosphere, moon, class,
    band); `m` has size 1 when the set has no Moon."""
    e = terms.illuminance_lx[None, None, None, None, :, None]
    lamp = terms.lamp_surface
    if terms.uplight is not None:
        lamp = lamp + terms.uplight[:, None, :, :]
    out = e * lamp[:, :, :, None, None, :]
    if terms.moon is not None:
        out = out + terms.moon[None, :, :, :, None, :]
    if terms.path is not None:
        out = out + terms.path[None, None, :, :, None, :]
    return out


def moon_scenes(terms: BandTerms) -> Float[Array, "s a m b"]:
    """Band radiance of moonlit surfaces without lamps (surface, atmosphere, moon,
    band). Raises if the set has no Moon."""
    if terms.moon is None:
        raise ValueError("This scenario set has no Moon states (moons=()).")
    out = terms.moon
    if terms.path is not None:
        out = out + terms.path[None]
    return out


def fire_scenes(terms: BandTerms) -> Float[Array, "f a b"]:
    """Band radiance of the fire scenes (temperature, atmosphere, band); no Moon."""
    if terms.fire is None:
        raise ValueError(
            "This scenario set has no fire scenes (fire_temperatures_k=())."
        )
    return terms.fire


def full_toa_radiance(
    factors: Factors, l: int, s: int, a: int, m: int | None, c: int
) -> Float[Array, " w"]:
    """Spectral TOA radiance of one scenario, evaluated term by term from the
    pixel's and the neighbourhood's radiance (`bandopt.scene`; the reference
    the contraction is tested against). [W m⁻² sr⁻¹ nm⁻¹]"""
    f = factors
    lamp_ground = f.illuminance_lx[c] * f.lamp[l]
    moon_ground = (
        f.moon_ground[a, m]
        if m is not None and f.moon_ground is not None
        else jnp.zeros_like(lamp_ground)
    )
    up = 0.0 if f.uplight is None else f.uplight * lamp_ground
    pixel = f.reflectance[s] / math.pi * (lamp_ground + moon_ground) + up
    if f.t_dir is None:  # uniform neighbourhood: it looks like the pixel
        out = f.t_up[a] * pixel
    else:
        k = f.neighbour_lamp
        rho_n = f.reflectance[s] if f.background is None else f.background
        hood = rho_n / math.pi * (k * lamp_ground + moon_ground) + k * up
        out = f.t_dir[a] * pixel + (f.t_up[a] - f.t_dir[a]) * hood
    if m is not None and f.path is not None:
        out = out + f.path[a, m]
    return out
