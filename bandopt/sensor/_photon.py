"""Photon noise model (thesis Eqs. 2.16-2.19, Table 2.3).

Signal electrons are the full spectral integral

    N_s = A_det Ω τ t_eff / (h c) · ∫ L(λ) R(λ) η(λ) λ dλ,
    A_det = pitch² · fill factor,  Ω = π / (4 (f/#)² + 1),  t_eff = t_int · TDI stages,

which is thesis Eq. 2.18 before its rectangle approximation
`∫ L R η λ dλ ≈ L̄ η Δλ λc` (band average x FWHM x centre). Noise adds photon
shot noise, dark current shot noise, read noise and quantisation noise in
quadrature: `σ² = N_s + D t_eff + σ_read² + (e/DN)²/12` (Eq. 2.17 keeps only
the first term).

**Table 2.3.** 2.5e-6 W m-2 sr-1 nm-1 (250 nW cm-2 sr-1 µm-1) in a 100 nm
rectangular band at 560 nm gives 152 signal electrons and 12.3 e- shot noise
with the defaults here. The thesis prints 160 e- and 12.6 e-: its product
uses the pixel area (4.9e-11 m²) instead of the effective area it lists
(4.66e-11 m², fill factor 0.95); 152 / 0.95 = 160.
"""

import math

import equinox as eqx
import jax
import jax.lax as lax
import jax.numpy as jnp
from jaxtyping import Array, ArrayLike, Float, PRNGKeyArray

from ..spectra import PLANCK_J_S, SPEED_OF_LIGHT_M_S, trapezoid_weights


_GM_EARTH_M3_S2 = 3.986004418e14  # IERS geocentric gravitational constant
_R_EARTH_M = 6371.0e3  # mean Earth radius


def ground_track_speed_m_s(
    altitude_m: ArrayLike,
) -> Float[Array, ""]:
    """Speed of the sub-satellite point for a circular orbit. [m s-1]

    `v = sqrt(GM / (R + h)) · R / (R + h)`, spherical Earth (R = 6371 km), Earth
    rotation ignored (it changes the result by up to ~7 %, depending on
    inclination and latitude). About 6.9 km/s at 600 km.
    """
    r = _R_EARTH_M + jnp.asarray(altitude_m, dtype=float)
    return jnp.sqrt(_GM_EARTH_M3_S2 / r) * _R_EARTH_M / r


class SensorParams(eqx.Module):
    """Radiometric sensor parameters; defaults are the thesis's Table 2.3.

    Table 2.3 is "based on Elvidge et al. [Nightsat] and IMEC's CCD-in-CMOS
    multispectral sensor". Read noise and dark current default to 0 because
    the table keeps shot noise only; set them for a real detector.

    **Attributes:**

    - `pixel_pitch_m`: detector pixel pitch. [m]
    - `fill_factor`: light-sensitive fraction of the pixel area. [1]
    - `transmittance`: optical transmittance τ. [1]
    - `quantum_efficiency`: η, used where no spectral QE curve is passed. [e-/photon]
    - `integration_time_s`: time per TDI stage (= GSD / ground speed). [s]
    - `f_number`: f/#. [1]
    - `read_noise_e`: read noise per read-out, counted once (charge-domain
      TDI as in CCD-in-CMOS; for digital TDI use `σ_read · sqrt(stages)`). [e-]
    - `dark_current_e_s`: dark current, accumulated over `t_eff`. [e- s-1]
    - `tdi_stages`: number of time-delay-integration stages (static). [1]
    """

    pixel_pitch_m: Float[Array, ""] = eqx.field(default=7e-6, converter=jnp.asarray)
    fill_factor: Float[Array, ""] = eqx.field(default=0.95, converter=jnp.asarray)
    transmittance: Float[Array, ""] = eqx.field(default=0.8, converter=jnp.asarray)
    quantum_efficiency: Float[Array, ""] = eqx.field(
        default=0.85, converter=jnp.asarray
    )
    integration_time_s: Float[Array, ""] = eqx.field(
        default=2.2e-4, converter=jnp.asarray
    )
    f_number: Float[Array, ""] = eqx.field(default=2.5, converter=jnp.asarray)
    read_noise_e: Float[Array, ""] = eqx.field(default=0.0, converter=jnp.asarray)
    dark_current_e_s: Float[Array, ""] = eqx.field(default=0.0, converter=jnp.asarray)
    tdi_stages: int = eqx.field(static=True, default=256)

    def __check_init__(self):
        if not isinstance(self.tdi_stages, int) or self.tdi_stages < 1:
            raise ValueError(
                f"tdi_stages must be a positive int, got {self.tdi_stages!r}."
            )

    @classmethod
    def for_gsd(
        cls,
        gsd_m: float,
        *,
        ground_speed_m_s: float | None = None,
        altitude_m: float = 600e3,
        **kwargs,
    ) -> "SensorParams":
        """Parameters with `integration_time_s = gsd_m / ground_speed_m_s`.

        The ground speed defaults to `ground_track_speed_m_s(altitude_m)`
        (600 km: about 6.9 km/s). Other fields as keyword arguments.
        """
        if gsd_m <= 0:
            raise ValueError(f"gsd_m must be positive, got {gsd_m!r}.")
        v = (
            ground_speed_m_s
            if ground_speed_m_s is not None
            else float(ground_track_speed_m_s(altitude_m))
        )
        if v <= 0:
            raise ValueError(f"ground_speed_m_s must be positive, got {v!r}.")
        return cls(integration_time_s=gsd_m / v, **kwargs)

    @property
    def detector_area_m2(self) -> Float[Array, ""]:
        """Effective detector area `pitch² · fill factor`. [m²]"""
        return self.pixel_pitch_m**2 * self.fill_factor

    @property
    def projected_solid_angle_sr(self) -> Float[Array, ""]:
        """`π / (4 (f/#)² + 1)`. [sr]"""
        return math.pi / (4.0 * self.f_number**2 + 1.0)

    @property
    def effective_integration_time_s(self) -> Float[Array, ""]:
        """`t_int · TDI stages`. [s]"""
        return self.integration_time_s * self.tdi_stages

    @property
    def etendue_time_m2_sr_s(self) -> Float[Array, ""]:
        """`A_det · Ω · τ · t_eff`: radiance [W m-2 sr-1] to energy [J]. [m² sr s]"""
        return (
            self.detector_area_m2
            * self.projected_solid_angle_sr
            * self.transmittance
            * self.effective_integration_time_s
        )


def _photon_weights(response, wavelength_nm, params, quantum_efficiency):
    """`(b, w)` weights: electrons per (W m-2 sr-1 nm-1) at each sample."""
    wavelength_nm = jnp.asarray(wavelength_nm)
    qe = (
        params.quantum_efficiency
        if quantum_efficiency is None
        else jnp.asarray(quantum_efficiency)
    )
    # photons per joule at λ, times quadrature weights [nm] and QE
    per_joule = wavelength_nm * (1e-9 / (PLANCK_J_S * SPEED_OF_LIGHT_M_S))  # [J-1]
    spectral = per_joule * trapezoid_weights(wavelength_nm) * qe  # [nm J-1]
    scale = params.etendue_time_m2_sr_s  # [m² sr s]
    return jnp.asarray(response) * (spectral * scale)[None, :]


photon_weights = _photon_weights
"""Public name of the `(b, w)` photon weights: electrons per (W m-2 sr-1 nm-1)
at each sample, so `spectra @ photon_weights(...).T` gives signal electrons."""


def signal_electrons(
    radiance_w_m2_sr_nm: Float[ArrayLike, "*batch w"],
    response: Float[ArrayLike, "b w"],
    wavelength_nm: Float[ArrayLike, " w"],
    params: SensorParams,
    *,
    quantum_efficiency: Float[ArrayLike, " w"] | None = None,
) -> Float[Array, "*batch b"]:
    """Signal electrons `A Ω τ t_eff/(hc) ∫ L R η λ dλ` per band (Eq. 2.18, exact
    integral). One dense matmul. [e-]

    **Arguments:**

    - `radiance_w_m2_sr_nm`: at-sensor spectral radiance. [W m-2 sr-1 nm-1]
    - `response`: relative spectral response (peak 1), e.g. `bands.response(wl)`. [1]
    - `wavelength_nm`: grid. [nm]
    - `params`: `SensorParams`.
    - `quantum_efficiency`: spectral QE on the grid; default the constant
      `params.quantum_efficiency`. [e-/photon]
    """
    weights = _photon_weights(response, wavelength_nm, params, quantum_efficiency)
    return jnp.matmul(
        jnp.asarray(radiance_w_m2_sr_nm), weights.T, precision=lax.Precision.HIGHEST
    )


def responsivity(
    response: Float[ArrayLike, "b w"],
    wavelength_nm: Float[ArrayLike, " w"],
    params: SensorParams,
    *,
    quantum_efficiency: Float[ArrayLike, " w"] | None = None,
) -> Float[Array, " b"]:
    """Electrons per unit band-averaged radiance for a spectrally flat scene.
    [e- per W m-2 sr-1 nm-1]

    `signal_electrons` of a flat unit spectrum, normalised by the band's
    on-grid area: `N_flat / L̄_flat` with `L̄_flat = 1`. The calibration a
    sensor would derive from a flat source; its inverse turns electrons into
    band-averaged radiance.
    """
    weights = _photon_weights(response, wavelength_nm, params, quantum_efficiency)
    return jnp.sum(weights, axis=-1)


def noise_electrons(
    signal_e: Float[ArrayLike, "*batch"],
    params: SensorParams,
    *,
    electrons_per_dn: ArrayLike = 0.0,
) -> Float[Array, "*batch"]:
    """Total noise `sqrt(N_s + D t_eff + σ_read² + (e/DN)²/12)`. [e-]

    Shot noise of the signal (Eq. 2.17, Poisson), shot noise of the dark
    current, read noise and uniform quantisation noise of a step of
    `electrons_per_dn` (0: none). Negative signal (from noisy inputs) counts
    as 0 in the shot noise. Gradient-safe at zero variance (double-where).
    """
    s = jnp.maximum(jnp.asarray(signal_e), 0.0)
    q = jnp.asarray(electrons_per_dn)
    var = (
        s
        + params.dark_current_e_s * params.effective_integration_time_s
        + params.read_noise_e**2
        + q**2 / 12.0
    )
    pos = var > 0
    return jnp.where(pos, jnp.sqrt(jnp.where(pos, var, 1.0)), 0.0)


def snr(
    signal_e: Float[ArrayLike, "*batch"],
    params: SensorParams,
    *,
    electrons_per_dn: ArrayLike = 0.0,
) -> Float[Array, "*batch"]:
    """Signal-to-noise ratio `N_s / N_n` (Eq. 2.16); 0 where there is no noise
    and no signal. [1]"""
    n = noise_electrons(signal_e, params, electrons_per_dn=electrons_per_dn)
    pos = n > 0
    return jnp.where(pos, jnp.asarray(signal_e) / jnp.where(pos, n, 1.0), 0.0)


def noise_equivalent_radiance(
    signal_e: Float[ArrayLike, "*batch b"],
    responsivity_e: Float[ArrayLike, " b"],
    params: SensorParams,
    *,
    electrons_per_dn: ArrayLike = 0.0,
) -> Float[Array, "*batch b"]:
    """Noise-equivalent radiance `N_n / responsivity` (Eq. 2.19 with the exact
    integral in place of `Δλ λc`). [W m-2 sr-1 nm-1]"""
    n = noise_electrons(signal_e, params, electrons_per_dn=electrons_per_dn)
    return n / jnp.broadcast_to(jnp.asarray(responsivity_e), n.shape)


def radiance_from_electrons(
    electrons: Float[ArrayLike, "*batch b"], responsivity_e: Float[ArrayLike, " b"]
) -> Float[Array, "*batch b"]:
    """Calibrated band-averaged radiance `electrons / responsivity`. Exact for a
    spectrum flat within the band; otherwise it carries the λ·η weighting of a
    photon-counting detector. [W m-2 sr-1 nm-1]"""
    e = jnp.asarray(electrons)
    return e / jnp.broadcast_to(jnp.asarray(responsivity_e), e.shape)


def add_photon_noise(
    key: PRNGKeyArray,
    signal_e: Float[ArrayLike, "*batch"],
    params: SensorParams,
    *,
    method: str = "gaussian",
    electrons_per_dn: ArrayLike = 0.0,
) -> Float[Array, "*batch"]:
    """Draw noisy electron counts, reproducibly from `key`. [e-]

    `method="gaussian"`: `N_s + σ z`, z ~ N(0, 1), with `σ` from
    `noise_electrons` (differentiable: reparameterised). `"poisson"`: signal
    and dark electrons are Poisson draws (the dark mean is subtracted, as by
    dark-frame correction), read noise is Gaussian, quantisation is left to
    `quantise`; no gradient flows through the Poisson draw. Convert to
    radiance with `radiance_from_electrons`.
    """
    s = jnp.asarray(signal_e)
    if method == "gaussian":
        sigma = noise_electrons(s, params, electrons_per_dn=electrons_per_dn)
        return s + sigma * jax.random.normal(key, s.shape, s.dtype)
    if method == "poisson":
        k_shot, k_read = jax.random.split(key)
        dark = params.dark_current_e_s * params.effective_integration_time_s
        lam = jnp.maximum(s, 0.0) + dark
        shot = jax.random.poisson(k_shot, lax.stop_gradient(lam), s.shape).astype(
            s.dtype
        )
        read = params.read_noise_e * jax.random.normal(k_read, s.shape, s.dtype)
        return shot - dark + read
    raise ValueError(
        f"Unknown method={method!r}; expected one of ['gaussian', 'poisson']."
    )
