"""Scenario sets: `ScenarioSet` (the labelled product of lamps, surfaces,
atmospheres, Moon states and classes, with its factor arrays), the default
factors, mixed lamps and surfaces, and `build_scenarios`, which reads the
library, the surfaces, the 6S tables and the Moon into `Factors`. Each set
records `PHYSICS_VERSION` in its config.
"""

import dataclasses
import math
from collections.abc import Sequence

import jax.numpy as jnp
import numpy as np

from ..datasets import atmosphere as atm_mod, moon as moon_mod, surfaces as surf_mod
from ..datasets.lamps import library
from ..names import canonical_key
from ..spectra import GRID_1NM, planck_radiance
from ._conditions import (
    DEFAULT_NEIGHBOURHOOD,
    NO_ATMOSPHERE,
    Q0_DRY_R3_PER_SR,
    AtmosphereSpec,
    Neighbourhood,
    class_illuminance_lx,
    resolve_neighbourhood,
)
from ._model import Factors
from ._uplight import uplight_factor


PHYSICS_VERSION = 2
"""Version of the radiance model, recorded in every `ScenarioSet.config`: 1 =
total transmittance and Lambertian uplight (until 2026-11-25); 2 = direct +
diffuse transmittance with a stated neighbourhood, uplight from measured
luminaire profiles, mixed pixels. Caches of results computed from scenario sets
should include it."""


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

    def with_lamps(self, lamp_ids: Sequence[str], spectra) -> "ScenarioSet":
        """The same scenes lit by other lamps: `spectra` `(l, w)` on this set's
        grid, normalised like the library (one lumen: `683 ∫ V S dλ = 1`,
        [W nm⁻¹ lm⁻¹]), named `lamp_ids`. For lamps outside the library, e.g.
        modelled spectra (`bandopt.lampmodels`); the rest of the scene is
        unchanged."""
        f = self.factors
        s = np.asarray(spectra, float)
        ids = tuple(lamp_ids)
        w = np.asarray(f.wavelength_nm).size
        if s.ndim != 2 or s.shape != (len(ids), w):
            raise ValueError(
                f"spectra: expected shape ({len(ids)}, {w}) (lamps x grid), "
                f"got {s.shape}."
            )
        if not np.all(np.isfinite(s)):
            bad = [ids[i] for i in np.flatnonzero(~np.isfinite(s).all(axis=1))]
            raise ValueError(f"spectra of lamps {bad[:5]} are not finite.")
        return dataclasses.replace(
            self,
            factors=dataclasses.replace(f, lamp=jnp.asarray(s, f.lamp.dtype)),
            lamp_ids=ids,
        )

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
                f.t_dir,
                f.neighbour_lamp,
                f.background,
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


MixSpec = tuple[str, str, float]
"""A mixed pixel: (a, b, fraction of a); the rest, 1 - fraction, is b."""


def _check_mix(entry, what: str) -> MixSpec:
    if not (isinstance(entry, Sequence) and len(entry) == 3):
        raise ValueError(f"A mixed {what} must be (a, b, fraction), got {entry!r}.")
    a, b, frac = entry
    if not (isinstance(a, str) and isinstance(b, str)):
        raise ValueError(f"A mixed {what} names two {what}s, got {entry!r}.")
    frac = float(frac)
    if not 0.0 <= frac <= 1.0:
        raise ValueError(
            f"The fraction of a mixed {what} must lie in [0, 1], got {entry!r}."
        )
    return a, b, frac


def mix_label(a: str, b: str, fraction: float) -> str:
    """Label of a mixed lamp or surface: ``"a+b@fraction"`` (fraction of a)."""
    return f"{a}+{b}@{fraction:g}"


def build_scenarios(
    *,
    lamps: Sequence[str | tuple] | None = None,
    scored_only: bool = False,
    surfaces: Sequence[str | tuple] = DEFAULT_SURFACES,
    surface_samples: int | None = None,
    atmospheres: Sequence[tuple[str, str, float] | str] = DEFAULT_ATMOSPHERES,
    moons: Sequence[str | None] = DEFAULT_MOONS,
    moon_zenith_deg: float = 30.0,
    classes: Sequence[str] = DEFAULT_CLASSES,
    q0_per_sr: float = Q0_DRY_R3_PER_SR,
    view_zenith_deg: float = 0.0,
    uplight_ratio: float = 0.0,
    uplight_model: str = "profile",
    neighbourhood: str | Neighbourhood = DEFAULT_NEIGHBOURHOOD,
    fire_temperatures_k: Sequence[float] = (),
    fire_fraction: float = 0.01,
    fire_emissivity: float = 0.9,
    extend_nir: bool = True,
    wavelength_nm: np.ndarray = GRID_1NM,
    seed: int = 0,
) -> ScenarioSet:
    """Build a scenario set. Any factor may be a subset.

    - `lamps`: library ids (default: every measured lamp, or only scored ones
      with `scored_only`); an entry ``(a, b, f)`` is a pixel lit by lamp `a`
      for a fraction `f` of its illuminance and by `b` for the rest (id
      ``"a+b@f"``, not a library lamp).
    - `surfaces`: surface types; each contributes its mean reflectance, or
      `surface_samples` measured spectra drawn with `seed`; an entry
      ``(a, b, f)`` is a pixel covered by `a` over a fraction `f` of its area
      and `b` over the rest (label ``"a+b@f"``; with `surface_samples`, the
      k-th draws of a and b are mixed).
    - `atmospheres`: (atmosphere, aerosol, visibility_km) triples of the 6S
      tables, or `"none"` for no atmosphere (T = 1, no path radiance).
    - `moons`: named phases (`bandopt.datasets.moon.NAMED_PHASES`) at
      `moon_zenith_deg`, or None for a moonless night. An empty tuple drops
      the Moon terms entirely.
    - `classes`: EN 13201 classes; M classes use `q0_per_sr`.
    - `uplight_ratio`: nominal upward light output ratio of the luminaires
      (0-0.5); `uplight_model` ``"profile"`` (measured profiles, default) or
      ``"lambertian"`` (the old shortcut); see `uplight_factor`. With
      `uplight_ratio > 0` the uplight term exists even where the profile sends
      nothing towards the sensor (factor 0: the 1-5 % profiles at nadir).
    - `neighbourhood`: what the diffuse upward transmittance sees, a name of
      `NEIGHBOURHOODS` or a `Neighbourhood` (default `DEFAULT_NEIGHBOURHOOD`;
      ``"uniform"`` is the total-transmittance model of earlier versions).
    - `fire_temperatures_k`: fire scenes (blackbody, `fire_fraction` of the pixel
      burning with `fire_emissivity`).
    """
    grid = np.asarray(wavelength_nm, float)
    hood = resolve_neighbourhood(neighbourhood)
    up_factor = uplight_factor(uplight_ratio, view_zenith_deg, uplight_model)
    lib = library(extend_nir=extend_nir, wavelength_nm=grid)
    lamp_mixes = []
    if lamps is None:
        lib = lib.select(scored_only=scored_only)
        lamp_ids = tuple(lib.ids)
        lamp = lib.values
    else:
        ids, rows = [], []
        for entry in lamps:
            if isinstance(entry, str):
                ids.append(entry)
                rows.append(lib.values[lib.index(entry)])
                continue
            a, b, frac = _check_mix(entry, "lamp")
            ids.append(mix_label(a, b, frac))
            rows.append(
                frac * lib.values[lib.index(a)] + (1 - frac) * lib.values[lib.index(b)]
            )
            lamp_mixes.append([a, b, frac])
        lamp_ids = tuple(ids)
        lamp = np.asarray(rows).reshape(len(ids), grid.size)
    if not np.all(np.isfinite(lamp)):
        bad = [lamp_ids[i] for i in np.flatnonzero(~np.isfinite(lamp).all(axis=1))]
        raise ValueError(
            f"Lamps {bad[:5]} have no data over part of {grid[0]:g}-{grid[-1]:g} nm "
            "(near-infrared extension off): crop the grid or switch the extension on."
        )

    def reflectances(name: str) -> tuple[list[np.ndarray], list[str]]:
        if surface_samples is None:
            ids, mean = surf_mod.mean_reflectance([name], grid)
            return [mean[0]], [ids[0]]
        draws = surf_mod.sample_reflectance(name, surface_samples, seed, grid)
        canon = surf_mod.resolve_surface(name)
        return list(draws), [f"{canon}#{k}" for k in range(surface_samples)]

    refl, surface_labels, surface_mixes = [], [], []
    for entry in surfaces:
        if isinstance(entry, str):
            r, lab = reflectances(entry)
        else:
            a, b, frac = _check_mix(entry, "surface")
            (ra, la), (rb, lb) = reflectances(a), reflectances(b)
            r = [frac * x + (1 - frac) * y for x, y in zip(ra, rb, strict=True)]
            lab = [mix_label(x, y, frac) for x, y in zip(la, lb, strict=True)]
            surface_mixes.append([a, b, frac])
        refl.extend(r)
        surface_labels.extend(lab)
    background = None
    if hood.surface is not None and not hood.is_uniform:
        background = surf_mod.mean_reflectance([hood.surface], grid)[1][0]

    moon_states = []
    for m in moons:
        moon_states.append(
            None if m is None else moon_mod.named_phase(m, moon_zenith_deg)
        )
    has_moon = any(m is not None for m in moon_states)

    t_up, t_dir, moon_ground, path, atm_labels = [], [], [], [], []
    for a in atmospheres:
        if isinstance(a, str) and a.lower() == NO_ATMOSPHERE:
            t_up.append(np.ones_like(grid))
            t_dir.append(np.ones_like(grid))
            atm_labels.append(NO_ATMOSPHERE)
            spec = None
        else:
            spec = AtmosphereSpec(*a)
            args = (
                "up",
                spec.atmosphere,
                spec.aerosol,
                spec.visibility_km,
                view_zenith_deg,
                grid,
            )
            t_up.append(atm_mod.transmittance(*args))
            if not hood.is_uniform:
                t_dir.append(atm_mod.transmittance(*args, part="direct"))
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
        # kept when asked for, even at 0 (a 5 % profile seen at nadir)
        uplight=up_factor if uplight_ratio > 0 else None,
        fire=fire,
        t_dir=None if hood.is_uniform else jnp.asarray(np.asarray(t_dir)),
        neighbour_lamp=None if hood.is_uniform else jnp.asarray(hood.lamp_factor),
        background=None if background is None else jnp.asarray(background),
    )
    moon_labels = tuple(
        "none" if m is None else f"{m.name}@{m.zenith_deg:g}deg" for m in moon_states
    )
    config = {
        "physics_version": PHYSICS_VERSION,
        "lamps": "all"
        if lamps is None
        else [e if isinstance(e, str) else list(e) for e in lamps],
        "scored_only": scored_only,
        "surfaces": [e if isinstance(e, str) else list(e) for e in surfaces],
        "surface_samples": surface_samples,
        "atmospheres": [a if isinstance(a, str) else list(a) for a in atmospheres],
        "moons": list(moons),
        "moon_zenith_deg": moon_zenith_deg,
        "classes": list(classes),
        "q0_per_sr": q0_per_sr,
        "view_zenith_deg": view_zenith_deg,
        "uplight_ratio": uplight_ratio,
        "uplight_model": canonical_key(uplight_model),
        "uplight_factor_per_sr": up_factor,
        "neighbourhood": hood.to_dict(),
        "lamp_mixtures": lamp_mixes,
        "surface_mixtures": surface_mixes,
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
