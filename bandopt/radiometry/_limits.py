"""Detection limit and saturation per band from a stated rule, and the SNR and
noise-equivalent radiance at any radiance level (thesis sections 2.5.2-2.5.3,
4.2.1).

**The rule** (`LimitRule`, defaults in brackets). Per band b:

1. *Scene requirement* `L_req`: every lamp on the surface and through the
   atmosphere darkest in band b, lit to the dimmest lighting class of the
   set, moonless; `L_req` is the `dim_percentile` [5 %] percentile of these
   lamp radiances (0 % = the very dimmest lamp).
2. *Background floor* `L_bg`: the band-averaged natural night-sky radiance
   (`night_sky_radiance` x `background_scale` [1]). Codes below it are never
   used, so the detection limit never goes below it.
3. *SNR requirement*: the sensor must reach `snr_target` [10] at `L_min`
   with the photon model. `L_min = max(L_req, L_bg)` is the specification;
   `snr_at_limit` is what `SensorParams` achieve there, and `exposure_factor`
   how many times more signal electrons (aperture, integration time, TDI
   stages, pixel size; σ0 held fixed) they need to reach the target (<= 1:
   met).
   `L_snr`, the radiance at which the given sensor reaches the target, is
   reported beside; with `sensor_limited` [False] the limit is raised to it,
   `L_min = max(L_req, L_bg, L_snr)` (what this sensor can honour).
   `limited_by` names the largest term.

4. *Saturation* `L_max = headroom [2] x P_sat`, `P_sat` the
   `saturation_percentile` [100 %] of the lamp scenes (reflected lamp light
   and moonlight) plus, when `include_uplight` [True], direct uplight of the
   luminaire in the same pixel. Fires are reported apart (the share of fire
   scenes above `L_max`), never used for `L_max`.

**Photon model.** Signal electrons of a band-averaged radiance `L` are
`N = L · R_b` with the flat-spectrum responsivity `R_b`
(`bandopt.sensor.responsivity`); noise `σ = sqrt(N + σ0²)` with
`σ0² = D t_eff + σ_read²` (`bandopt.sensor.noise_electrons`), so
`SNR = N / σ` and `NER = σ / R_b = L / SNR`. Solving `N = k sqrt(N + σ0²)`
gives the electrons for SNR k: `N_k = (k² + sqrt(k⁴ + 4 k² σ0²)) / 2`.
"""

import dataclasses

import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike, Float

from ..sensor import SensorParams, noise_electrons, responsivity, snr
from ._background import background_band_radiance
from ._distributions import RadianceGroups


@dataclasses.dataclass(frozen=True)
class LimitRule:
    """The stated rule for detection limit and saturation (module docstring).

    - `snr_target`: SNR the sensor must reach at the detection limit. [1]
    - `dim_percentile`: percentile over lamps of the dim scenes. [%]
    - `saturation_percentile`: percentile of the bright scenes. [%]
    - `headroom`: saturation margin above that percentile. [1]
    - `include_uplight`: add direct uplight to the bright scenes.
    - `background_scale`: multiplies the natural background floor. [1]
    - `sensor_limited`: raise the limit to where the given sensor reaches
      `snr_target`.
    """

    snr_target: float = 10.0
    dim_percentile: float = 5.0
    saturation_percentile: float = 100.0
    headroom: float = 2.0
    include_uplight: bool = True
    background_scale: float = 1.0
    sensor_limited: bool = False

    def __post_init__(self):
        if not self.snr_target > 0:
            raise ValueError(f"snr_target must be > 0, got {self.snr_target!r}.")
        for name in ("dim_percentile", "saturation_percentile"):
            v = getattr(self, name)
            if not 0.0 <= v <= 100.0:
                raise ValueError(f"{name} must lie in [0, 100], got {v!r}.")
        if not self.headroom >= 1.0:
            raise ValueError(f"headroom must be >= 1, got {self.headroom!r}.")
        if not self.background_scale > 0:
            raise ValueError(
                f"background_scale must be > 0, got {self.background_scale!r}."
            )

    def as_dict(self) -> dict:
        return dataclasses.asdict(self)


def electrons_for_snr(
    snr_target: Float[ArrayLike, "*batch"], params: SensorParams
) -> Float[Array, "*batch"]:
    """Signal electrons at which `snr` reaches `snr_target`:
    `(k² + sqrt(k⁴ + 4k²σ0²))/2`, `σ0² = D t_eff + σ_read²`. [e-]"""
    k = jnp.asarray(snr_target, dtype=float)
    s0 = (
        params.dark_current_e_s * params.effective_integration_time_s
        + params.read_noise_e**2
    )
    return 0.5 * (k**2 + jnp.sqrt(k**4 + 4.0 * k**2 * s0))


def radiance_for_snr(
    snr_target: float,
    responsivity_e: Float[ArrayLike, " b"],
    params: SensorParams,
) -> Float[Array, " b"]:
    """Band-averaged radiance at which the sensor reaches `snr_target`
    (`electrons_for_snr / responsivity`). [W m⁻² sr⁻¹ nm⁻¹]"""
    return electrons_for_snr(snr_target, params) / jnp.asarray(responsivity_e)


def snr_ner(
    radiance_w_m2_sr_nm: Float[ArrayLike, "*batch b"],
    responsivity_e: Float[ArrayLike, " b"],
    params: SensorParams,
    *,
    electrons_per_dn: ArrayLike = 0.0,
) -> dict[str, Array]:
    """Signal and noise electrons, SNR and noise-equivalent radiance of
    band-averaged radiances (flat-spectrum responsivity, module docstring).

    Returns `signal_e` [e-], `noise_e` [e-], `snr` [1], `ner_w_m2_sr_nm`
    [W m⁻² sr⁻¹ nm⁻¹]; `electrons_per_dn` adds uniform quantisation noise.
    """
    L = jnp.asarray(radiance_w_m2_sr_nm, dtype=float)
    r = jnp.broadcast_to(jnp.asarray(responsivity_e), L.shape)
    n_s = L * r
    n_n = noise_electrons(n_s, params, electrons_per_dn=electrons_per_dn)
    return {
        "signal_e": n_s,
        "noise_e": n_n,
        "snr": snr(n_s, params, electrons_per_dn=electrons_per_dn),
        "ner_w_m2_sr_nm": n_n / r,
    }


@dataclasses.dataclass(frozen=True)
class Limits:
    """Recommended limits per band (module docstring). Radiances in
    [W m⁻² sr⁻¹ nm⁻¹]; `snr_at_limit` and `exposure_factor` [1]."""

    band_names: tuple[str, ...]
    detection_limit: np.ndarray
    saturation: np.ndarray
    scene_requirement: np.ndarray
    background: np.ndarray
    sensor_floor: np.ndarray
    limited_by: tuple[str, ...]
    snr_at_limit: np.ndarray
    snr_at_requirement: np.ndarray
    exposure_factor: np.ndarray
    saturation_lamp_only: np.ndarray
    fire_fraction_saturated: np.ndarray | None
    responsivity_e: np.ndarray
    rule: LimitRule

    @property
    def dynamic_range(self) -> np.ndarray:
        """`L_max / L_min`. [1]"""
        return self.saturation / self.detection_limit

    @property
    def meets_snr_target(self) -> np.ndarray:
        """The given sensor reaches `rule.snr_target` at the detection limit."""
        return self.snr_at_limit >= self.rule.snr_target * (1 - 1e-9)

    @property
    def meets_scene_requirement(self) -> np.ndarray:
        return self.detection_limit <= self.scene_requirement * (1 + 1e-12)

    def rows(self, *, band_set: str) -> list[dict]:
        out = []
        for j, name in enumerate(self.band_names):
            out.append(
                {
                    "band_set": band_set,
                    "band": name,
                    "detection_limit_w_m2_sr_nm": float(self.detection_limit[j]),
                    "saturation_w_m2_sr_nm": float(self.saturation[j]),
                    "dynamic_range": float(self.dynamic_range[j]),
                    "scene_requirement_w_m2_sr_nm": float(self.scene_requirement[j]),
                    "background_w_m2_sr_nm": float(self.background[j]),
                    "sensor_floor_w_m2_sr_nm": float(self.sensor_floor[j]),
                    "limited_by": self.limited_by[j],
                    "meets_scene_requirement": bool(self.meets_scene_requirement[j]),
                    "snr_at_limit": float(self.snr_at_limit[j]),
                    "snr_at_requirement": float(self.snr_at_requirement[j]),
                    "meets_snr_target": bool(self.meets_snr_target[j]),
                    "exposure_factor_for_snr_target": float(self.exposure_factor[j]),
                    "saturation_lamp_only_w_m2_sr_nm": float(
                        self.saturation_lamp_only[j]
                    ),
                    "fire_fraction_saturated": (
                        None
                        if self.fire_fraction_saturated is None
                        else float(self.fire_fraction_saturated[j])
                    ),
                    "responsivity_e_per_w_m2_sr_nm": float(self.responsivity_e[j]),
                }
            )
        return out


def _percentile(x: np.ndarray, q: float) -> np.ndarray:
    """Percentile over axis 0 (the maximum, without a partition, for 100)."""
    return x.max(axis=0) if q == 100.0 else np.percentile(x, q, axis=0)


def bright_scenes(groups: RadianceGroups, include_uplight: bool) -> np.ndarray:
    """Lamp scenes (scenes, band), with the luminaire's direct uplight added
    when asked and the set has it."""
    lamp = groups.lamp  # (l, s, a, m, c, b)
    if include_uplight and groups.uplight is not None:
        up = groups.uplight  # (l, a, c, b)
        lamp = lamp + up[:, None, :, None, :, :]
    return lamp.reshape(-1, lamp.shape[-1])


def recommend_limits(
    groups: RadianceGroups,
    response: Float[ArrayLike, "b w"],
    wavelength_nm: Float[ArrayLike, " w"],
    params: SensorParams | None = None,
    rule: LimitRule | None = None,
) -> Limits:
    """Apply `rule` (module docstring) to the scene groups of a band set.

    `response` and `wavelength_nm` (the bands on the scenario grid, e.g. from
    `bandopt.forward.cropped`) give the responsivity and the band-averaged
    background.
    """
    params = SensorParams() if params is None else params
    rule = LimitRule() if rule is None else rule
    resp_e = np.asarray(responsivity(response, wavelength_nm, params))
    if np.any(resp_e <= 0):
        raise ValueError("A band has no response on the grid (responsivity 0).")
    dim = groups.dim_scenes()
    req = np.percentile(dim, rule.dim_percentile, axis=0)
    bg = np.asarray(
        background_band_radiance(response, wavelength_nm, scale=rule.background_scale)
    )
    floor = np.asarray(radiance_for_snr(rule.snr_target, resp_e, params))
    stack = np.stack([req, bg, floor] if rule.sensor_limited else [req, bg])
    names = ("scenes", "background", "sensor_snr")
    lmin = stack.max(axis=0)
    limited = tuple(names[i] for i in stack.argmax(axis=0))
    bright = bright_scenes(groups, rule.include_uplight)
    p_sat = _percentile(bright, rule.saturation_percentile)
    lmax = rule.headroom * p_sat
    lamp_only = rule.headroom * _percentile(
        groups.flat("lamp"), rule.saturation_percentile
    )
    if np.any(lmax <= lmin):
        bad = [groups.band_names[j] for j in np.flatnonzero(lmax <= lmin)]
        raise ValueError(
            f"Bands {bad}: saturation from the bright scenes does not exceed the "
            "detection limit; the band sees too little lamp light for this rule."
        )
    fire_sat = None
    if groups.fire is not None:
        fire_sat = (groups.flat("fire") > lmax[None, :]).mean(axis=0)
    at_limit = snr_ner(lmin, resp_e, params)["snr"]
    at_req = snr_ner(req, resp_e, params)["snr"]
    n_need = float(electrons_for_snr(rule.snr_target, params))
    n_req = lmin * resp_e
    exposure = np.where(n_req > 0, n_need / np.where(n_req > 0, n_req, 1.0), np.inf)
    return Limits(
        groups.band_names,
        lmin,
        lmax,
        req,
        bg,
        floor,
        limited,
        np.asarray(at_limit),
        np.asarray(at_req),
        exposure,
        lamp_only,
        fire_sat,
        resp_e,
        rule,
    )


def sensitivity_rows(
    groups: RadianceGroups,
    response,
    wavelength_nm,
    params: SensorParams | None = None,
    *,
    base: LimitRule | None = None,
    snr_targets=(1.0, 3.0, 5.0, 10.0, 20.0),
    dim_percentiles=(0.0, 1.0, 5.0, 10.0, 25.0, 50.0),
    background_scales=(0.5, 1.0, 2.0),
    saturation_percentiles=(99.0, 99.9, 100.0),
    band_set: str = "",
) -> list[dict]:
    """How the recommended limits move with the rule: one parameter varied at
    a time from `base`, one row per (parameter, value, band)."""
    base = LimitRule() if base is None else base
    variations = [("snr_target", v) for v in snr_targets]
    variations += [("dim_percentile", v) for v in dim_percentiles]
    variations += [("background_scale", v) for v in background_scales]
    variations += [("saturation_percentile", v) for v in saturation_percentiles]
    variations += [("include_uplight", v) for v in (False, True)]
    variations += [("sensor_limited", v) for v in (False, True)]
    rows = []
    for field, value in variations:
        rule = dataclasses.replace(base, **{field: value})
        lim = recommend_limits(groups, response, wavelength_nm, params, rule)
        for j, name in enumerate(lim.band_names):
            rows.append(
                {
                    "band_set": band_set,
                    "parameter": field,
                    "value": value,
                    "band": name,
                    "detection_limit_w_m2_sr_nm": float(lim.detection_limit[j]),
                    "saturation_w_m2_sr_nm": float(lim.saturation[j]),
                    "limited_by": lim.limited_by[j],
                    "snr_at_limit": float(lim.snr_at_limit[j]),
                    "exposure_factor_for_snr_target": float(lim.exposure_factor[j]),
                    "bits_linear_step_le_ner": int(bits_for_linear(lim, params)[j]),
                }
            )
    return rows


def bits_for_linear(
    limits: Limits, params: SensorParams | None = None, *, step_over_noise: float = 1.0
) -> np.ndarray:
    """Bits a linear quantiser between the limits needs for its step to be at
    most `step_over_noise` times the noise-equivalent radiance at the
    detection limit: `ceil(log2((L_max - L_min)/(c · NER(L_min)) + 1))`. [bit]"""
    params = SensorParams() if params is None else params
    ner = np.asarray(
        snr_ner(limits.detection_limit, limits.responsivity_e, params)["ner_w_m2_sr_nm"]
    )
    codes = (limits.saturation - limits.detection_limit) / (step_over_noise * ner)
    return np.ceil(np.log2(codes + 1.0)).astype(int)
