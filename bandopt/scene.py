"""Scenario sets and the factorised top-of-atmosphere radiance model.

A scenario is one lamp x surface x atmosphere x Moon state x lighting class.
The top-of-atmosphere spectral radiance of a pixel [W m⁻² sr⁻¹ nm⁻¹] is

    L_toa = T_up · [ ρ/π · ( E_c · S_l + T_down · E_moon · cos θ_moon )
                     + f_up · L_direct + f_fire · ε · B(T_fire) ] + L_path,moon

with, per term:

- `T_up(λ)`: one-way *total* (direct + diffuse) upward transmittance from the
  surface to the sensor at the view zenith (6S tables,
  `bandopt.datasets.atmosphere`). Total rather than direct because the pixel is
  assumed to sit in a uniform neighbourhood, where light scattered into the
  view from neighbouring pixels compensates light scattered out of it;
  adjacency effects at lamp scale are neglected, as in the thesis (section 2.4).
- `ρ(λ)`: Lambertian surface reflectance (`bandopt.datasets.surfaces`).
- `E_c · S_l(λ)`: the lamp's spectral irradiance on the ground. `S_l` is the
  library spectrum per lumen [W nm⁻¹ lm⁻¹] and `E_c` the average horizontal
  illuminance [lx] of EN 13201-2 lighting class `c`; M classes (road luminance
  seen by a driver) become illuminance with the road's average luminance
  coefficient, `E = L / Q0`. So the lamp scale factor depends on lamp x class
  only and the same illuminance lights every surface of the scene.
- `T_down · E_moon · cos θ_moon`: moonlight on the ground (ROLO irradiance at
  the top of the atmosphere, `bandopt.datasets.moon`, times the one-way
  downward total transmittance at the Moon's zenith).
- `f_up · L_direct`: light a luminaire sends straight up, seen directly by the
  sensor. With an upward light output ratio `u` (0-0.5) and the downward flux
  landing in the pixel, the upward flux per ground area is `E_c u / (1 - u)`;
  spread over the pixel as a Lambertian emitter its radiance is
  `E_c u / (1 - u) / π · S_l`.
- `f_fire · ε · B(T_fire)`: blackbody emission (Planck) of a burning fraction
  of the pixel with emissivity ε (fire scenes only).
- `L_path,moon`: path radiance of moonlight scattered by the atmosphere
  (6S intrinsic reflectance x lunar irradiance). Path radiance of *lamp* light
  is neglected (thesis section 2.4).

**Cost.** Band radiance is linear in every factor, so the band radiance of
every combination is a contraction over wavelength of small factor arrays
(`band_terms`), never the full lamp x surface x atmosphere x moon x class x
wavelength array. A term a scenario set lacks (no Moon, no uplight, no fire, no
atmosphere) is `None` and costs nothing.
"""

import dataclasses
import math
from collections.abc import Mapping, Sequence
from types import MappingProxyType

import equinox as eqx
import jax.lax as lax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Float

from .spectra import GRID_1NM, planck_radiance, trapezoid_weights


LIGHTING_CLASSES: Mapping[str, tuple[str, float]] = MappingProxyType(
    {
        **{
            f"P{i + 1}": ("illuminance_lx", v)
            for i, v in enumerate((15.0, 10.0, 7.5, 5.0, 3.0, 2.0))
        },
        **{
            f"C{i}": ("illuminance_lx", v)
            for i, v in enumerate((50.0, 30.0, 20.0, 15.0, 10.0, 7.5))
        },
        **{
            f"M{i + 1}": ("luminance_cd_m2", v)
            for i, v in enumerate((2.0, 1.5, 1.0, 0.75, 0.5, 0.3))
        },
    }
)
"""EN 13201-2:2015 lighting classes: P and C classes are average horizontal
illuminances [lx]; M classes are average road luminances seen by a driver
[cd m⁻²]. Reference `CEN2015`."""

Q0_DRY_R3_PER_SR = 0.07
"""Average luminance coefficient Q0 of the standard dry road surfaces R3/C2
[sr⁻¹]; 0.10 for R1/C1 (`CIE2001`)."""


def class_illuminance_lx(name: str, *, q0_per_sr: float = Q0_DRY_R3_PER_SR) -> float:
    """Average horizontal illuminance of an EN 13201 class; M classes via
    `E = L / Q0`. [lx]"""
    key = name.strip().upper()
    if key not in LIGHTING_CLASSES:
        raise ValueError(
            f"Unknown lighting class {name!r}; expected one of "
            f"{list(LIGHTING_CLASSES)}."
        )
    if not q0_per_sr > 0:
        raise ValueError(f"q0_per_sr must be > 0, got {q0_per_sr!r}.")
    kind, value = LIGHTING_CLASSES[key]
    return value if kind == "illuminance_lx" else value / q0_per_sr


@dataclasses.dataclass(frozen=True)
class AtmosphereSpec:
    """An atmosphere of the 6S tables, or `None` fields for no atmosphere."""

    atmosphere: str
    aerosol: str
    visibility_km: float

    @property
    def label(self) -> str:
        return f"{self.atmosphere}/{self.aerosol}/{self.visibility_km:g}km"


NO_ATMOSPHERE = "none"


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
    - `uplight`: `u / (1 - u) / π`, or None. [sr⁻¹]
    - `fire`: `f_fire ε B(T)`, or None. (f, w) [W m⁻² sr⁻¹ nm⁻¹]
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
        )


class BandTerms(eqx.Module):
    """Band radiance of each term, contracted over wavelength. [W m⁻² sr⁻¹ nm⁻¹]
    (band-averaged) or [W m⁻² sr⁻¹] (band-integrated)

    - `lamp_surface`: `T_up ρ/π S_l` per lux. (l, s, a, b)
    - `uplight`: `T_up u/(1-u)/π S_l` per lux, or None. (l, a, b)
    - `moon`: `T_up ρ/π T_down E_moon cos θ`, or None. (s, a, m, b)
    - `path`: moonlight path radiance, or None. (a, m, b)
    - `fire`: `T_up f ε B`, or None. (f, a, b)
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
    lamp_surface = jnp.einsum(
        "lw,sw,abw->lsab", f.lamp, f.reflectance / math.pi, tw, precision=_HI
    )
    uplight = (
        None
        if f.uplight is None
        else f.uplight * jnp.einsum("lw,abw->lab", f.lamp, tw, precision=_HI)
    )
    moon = (
        None
        if f.moon_ground is None
        else jnp.einsum(
            "sw,amw,abw->samb",
            f.reflectance / math.pi,
            f.moon_ground,
            tw,
            precision=_HI,
        )
    )
    path = (
        None
        if f.path is None
        else jnp.einsum("amw,bw->amb", f.path, weights, precision=_HI)
    )
    fire = (
        None if f.fire is None else jnp.einsum("fw,abw->fab", f.fire, tw, precision=_HI)
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


@dataclasses.dataclass(frozen=True)
class ScenarioSet:
    """A product of lamps x surfaces x atmospheres x Moon states x classes, with
    labels, and its factor arrays (`factors`). Build with `build_scenarios`."""

    factors: Factors
    lamp_ids: tuple[str, ...]
    surface_labels: tuple[str, ...]
    atmosphere_labels: tuple[str, ...]
    moon_labels: tuple[str, ...]
    class_labels: tuple[str, ...]
    fire_labels: tuple[str, ...]
    config: dict

    @property
    def shape(self) -> tuple[int, ...]:
        return (
            len(self.lamp_ids),
            len(self.surface_labels),
            len(self.atmosphere_labels),
            max(len(self.moon_labels), 1),
            len(self.class_labels),
        )

    @property
    def n_lamp_scenes(self) -> int:
        return int(np.prod(self.shape))

    def subset_lamps(self, index: slice | Sequence[int]) -> "ScenarioSet":
        """The same set restricted to some lamps (a slice or index list)."""
        idx = np.arange(len(self.lamp_ids))[index]
        f = self.factors
        return dataclasses.replace(
            self,
            factors=Factors(
                f.wavelength_nm,
                f.lamp[idx],
                f.reflectance,
                f.t_up,
                f.moon_ground,
                f.path,
                f.illuminance_lx,
                f.uplight,
                f.fire,
            ),
            lamp_ids=tuple(self.lamp_ids[i] for i in idx),
        )


DEFAULT_SURFACES = (
    "asphalt",
    "road",
    "parking_lot",
    "sidewalk",
    "concrete_roof_tile",
    "soil",
    "grass",
)
DEFAULT_CLASSES = ("P1", "P4", "P6", "C0", "C3", "M1", "M4", "M6")
DEFAULT_ATMOSPHERES = (
    ("midlatitude_summer", "urban", 23.0),
    ("midlatitude_summer", "continental", 10.0),
    ("midlatitude_winter", "maritime", 23.0),
    ("tropical", "urban", 5.0),
)
DEFAULT_MOONS = (None, "full", "first_quarter")


def build_scenarios(
    *,
    lamps: Sequence[str] | None = None,
    scored_only: bool = False,
    surfaces: Sequence[str] = DEFAULT_SURFACES,
    surface_samples: int | None = None,
    atmospheres: Sequence[tuple[str, str, float] | str] = DEFAULT_ATMOSPHERES,
    moons: Sequence[str | None] = DEFAULT_MOONS,
    moon_zenith_deg: float = 30.0,
    classes: Sequence[str] = DEFAULT_CLASSES,
    q0_per_sr: float = Q0_DRY_R3_PER_SR,
    view_zenith_deg: float = 0.0,
    uplight_ratio: float = 0.0,
    fire_temperatures_k: Sequence[float] = (),
    fire_fraction: float = 0.01,
    fire_emissivity: float = 0.9,
    extend_nir: bool = True,
    wavelength_nm: np.ndarray = GRID_1NM,
    seed: int = 0,
) -> ScenarioSet:
    """Build a scenario set. Any factor may be a subset.

    - `lamps`: library ids (default: every measured lamp, or only scored ones
      with `scored_only`).
    - `surfaces`: surface types; each contributes its mean reflectance, or
      `surface_samples` measured spectra drawn with `seed`.
    - `atmospheres`: (atmosphere, aerosol, visibility_km) triples of the 6S
      tables, or `"none"` for no atmosphere (T = 1, no path radiance).
    - `moons`: named phases (`bandopt.datasets.moon.NAMED_PHASES`) at
      `moon_zenith_deg`, or None for a moonless night. An empty tuple drops
      the Moon terms entirely.
    - `classes`: EN 13201 classes; M classes use `q0_per_sr`.
    - `uplight_ratio`: upward light output ratio u of the luminaires (0-0.5).
    - `fire_temperatures_k`: fire scenes (blackbody, `fire_fraction` of the pixel
      burning with `fire_emissivity`).
    """
    from .datasets import atmosphere as atm_mod, moon as moon_mod, surfaces as surf_mod
    from .datasets.lamps import library

    grid = np.asarray(wavelength_nm, float)
    lib = library(extend_nir=extend_nir, wavelength_nm=grid)
    if lamps is None:
        lib = lib.select(scored_only=scored_only)
        lamp_ids = tuple(lib.ids)
        lamp = lib.values
    else:
        lamp_ids = tuple(lamps)
        lamp = lib.values[[lib.index(i) for i in lamp_ids]]
    if not np.all(np.isfinite(lamp)):
        bad = [lamp_ids[i] for i in np.flatnonzero(~np.isfinite(lamp).all(axis=1))]
        raise ValueError(
            f"Lamps {bad[:5]} have no data over part of {grid[0]:g}-{grid[-1]:g} nm "
            "(near-infrared extension off): crop the grid or switch the extension on."
        )

    refl, surface_labels = [], []
    for s in surfaces:
        if surface_samples is None:
            ids, mean = surf_mod.mean_reflectance([s], grid)
            refl.append(mean[0])
            surface_labels.append(ids[0])
        else:
            draws = surf_mod.sample_reflectance(s, surface_samples, seed, grid)
            refl.extend(draws)
            name = surf_mod.resolve_surface(s)
            surface_labels.extend(f"{name}#{k}" for k in range(surface_samples))

    if not 0.0 <= uplight_ratio <= 0.5:
        raise ValueError(f"uplight_ratio must lie in [0, 0.5], got {uplight_ratio!r}.")
    moon_states = []
    for m in moons:
        moon_states.append(
            None if m is None else moon_mod.named_phase(m, moon_zenith_deg)
        )
    has_moon = any(m is not None for m in moon_states)

    t_up, moon_ground, path, atm_labels = [], [], [], []
    for a in atmospheres:
        if isinstance(a, str) and a.lower() == NO_ATMOSPHERE:
            t_up.append(np.ones_like(grid))
            atm_labels.append(NO_ATMOSPHERE)
            spec = None
        else:
            spec = AtmosphereSpec(*a)
            t_up.append(
                atm_mod.transmittance(
                    "up",
                    spec.atmosphere,
                    spec.aerosol,
                    spec.visibility_km,
                    view_zenith_deg,
                    grid,
                )
            )
            atm_labels.append(spec.label)
        mg, pa = [], []
        for m in moon_states:
            if m is None:
                mg.append(np.zeros_like(grid))
                pa.append(np.zeros_like(grid))
                continue
            e_toa = m.irradiance_toa(grid)
            cos = math.cos(math.radians(m.zenith_deg))
            if spec is None:
                mg.append(e_toa * cos)
                pa.append(np.zeros_like(grid))
            else:
                t_down = atm_mod.transmittance(
                    "down",
                    spec.atmosphere,
                    spec.aerosol,
                    spec.visibility_km,
                    m.zenith_deg,
                    grid,
                )
                mg.append(t_down * e_toa * cos)
                pa.append(
                    atm_mod.path_radiance(
                        e_toa,
                        m.zenith_deg,
                        spec.atmosphere,
                        spec.aerosol,
                        spec.visibility_km,
                        view_zenith_deg,
                        grid,
                    )
                )
        moon_ground.append(mg)
        path.append(pa)

    fire = None
    if len(fire_temperatures_k):
        fire = (
            fire_fraction
            * fire_emissivity
            * planck_radiance(
                jnp.asarray(grid), jnp.asarray(fire_temperatures_k, float)
            )
        )
    any_path = has_moon and any(lab != NO_ATMOSPHERE for lab in atm_labels)
    factors = Factors(
        wavelength_nm=jnp.asarray(grid),
        lamp=jnp.asarray(lamp),
        reflectance=jnp.asarray(np.asarray(refl)),
        t_up=jnp.asarray(np.asarray(t_up)),
        moon_ground=jnp.asarray(np.asarray(moon_ground)) if has_moon else None,
        path=jnp.asarray(np.asarray(path)) if any_path else None,
        illuminance_lx=jnp.asarray(
            [class_illuminance_lx(c, q0_per_sr=q0_per_sr) for c in classes]
        ),
        uplight=(uplight_ratio / (1 - uplight_ratio) / math.pi)
        if uplight_ratio > 0
        else None,
        fire=fire,
    )
    moon_labels = tuple(
        "none" if m is None else f"{m.name}@{m.zenith_deg:g}deg" for m in moon_states
    )
    config = {
        "lamps": "all" if lamps is None else list(lamps),
        "scored_only": scored_only,
        "surfaces": list(surfaces),
        "surface_samples": surface_samples,
        "atmospheres": [a if isinstance(a, str) else list(a) for a in atmospheres],
        "moons": list(moons),
        "moon_zenith_deg": moon_zenith_deg,
        "classes": list(classes),
        "q0_per_sr": q0_per_sr,
        "view_zenith_deg": view_zenith_deg,
        "uplight_ratio": uplight_ratio,
        "fire_temperatures_k": list(fire_temperatures_k),
        "fire_fraction": fire_fraction,
        "fire_emissivity": fire_emissivity,
        "extend_nir": extend_nir,
        "wavelength_nm": [float(grid[0]), float(grid[-1]), float(grid[1] - grid[0])],
        "seed": seed,
    }
    return ScenarioSet(
        factors,
        lamp_ids,
        tuple(surface_labels),
        tuple(atm_labels),
        moon_labels if moon_labels else ("none",),
        tuple(c.upper() for c in classes),
        tuple(f"fire_{t:g}K" for t in fire_temperatures_k),
        config,
    )


def full_toa_radiance(
    factors: Factors, l: int, s: int, a: int, m: int | None, c: int
) -> Float[Array, " w"]:
    """Spectral TOA radiance of one scenario, evaluated term by term (the
    reference the contraction is tested against). [W m⁻² sr⁻¹ nm⁻¹]"""
    f = factors
    ground = f.illuminance_lx[c] * f.lamp[l]
    if m is not None and f.moon_ground is not None:
        ground = ground + f.moon_ground[a, m]
    inner = f.reflectance[s] / math.pi * ground
    if f.uplight is not None:
        inner = inner + f.uplight * f.illuminance_lx[c] * f.lamp[l]
    out = f.t_up[a] * inner
    if m is not None and f.path is not None:
        out = out + f.path[a, m]
    return out
