"""Band radiance distributions of a scenario set, by scene group (thesis
section 4.2.1, Tables 4.5-4.6).

Four groups, each from the factorised model of `bandopt.scene` (one contraction
per term, nothing materialised over wavelength):

- `lamp`: lamp light reflected by the surface (plus moonlight and moonlight
  path radiance for the Moon states of the set), no direct uplight:
  (lamp, surface, atmosphere, moon, class, band);
- `moon`: moonlit surfaces without lamps, Moon states only (the moonless
  state, which is 0, is dropped): (surface, atmosphere, moon, band);
- `uplight`: light sent straight up by the luminaire alone,
  `E_c · T_up · u/(1-u)/π · S_l` at the set's upward light output ratio u:
  (lamp, atmosphere, class, band);
- `fire`: burning fraction of the pixel, `T_up f ε B(T)`: (temperature,
  atmosphere, band).

Radiances are band averages (thesis Eq. 2.14) [W m⁻² sr⁻¹ nm⁻¹] on the grid
cropped to the bands' support. A band reaching beyond the scenario grid is
averaged over its on-grid part (the response is cropped, as in
`bandopt.forward`): its radiance is the on-grid average.
"""

import dataclasses

import numpy as np

from ..forward import cropped
from ..scene import BandTerms, ScenarioSet, band_terms, band_weights, lamp_scenes


GROUPS: tuple[str, ...] = ("lamp", "moon", "uplight", "fire")
"""Scene groups, in report order."""

PERCENTILES: tuple[float, ...] = (0.0, 1.0, 5.0, 25.0, 50.0, 75.0, 95.0, 99.0, 100.0)
"""Percentiles of the distribution tables (0 and 100 are min and max). [%]"""


@dataclasses.dataclass(frozen=True)
class RadianceGroups:
    """Band radiances of a scenario set split by scene group (see module
    docstring); a group the set lacks is None. [W m⁻² sr⁻¹ nm⁻¹]"""

    band_names: tuple[str, ...]
    lamp: np.ndarray
    moon: np.ndarray | None
    uplight: np.ndarray | None
    fire: np.ndarray | None
    moonless_index: int | None
    class_illuminance_lx: np.ndarray
    uplight_ratio: float

    def group(self, name: str) -> np.ndarray | None:
        if name not in GROUPS:
            raise ValueError(f"Unknown group {name!r}; expected one of {list(GROUPS)}.")
        return getattr(self, name)

    def flat(self, name: str) -> np.ndarray | None:
        """A group as (scenes, band)."""
        g = self.group(name)
        return None if g is None else g.reshape(-1, g.shape[-1])

    def dim_scenes(self) -> np.ndarray:
        """Per lamp and band: the dimmest class, moonless (or the dimmest Moon
        state if the set has none), on the surface and through the atmosphere
        that give the lowest radiance in that band. (lamp, band)"""
        c = int(np.argmin(self.class_illuminance_lx))
        lamp = self.lamp[:, :, :, :, c, :]  # (l, s, a, m, b)
        if self.moonless_index is not None:
            lamp = lamp[:, :, :, self.moonless_index, :]
        else:
            lamp = lamp.min(axis=3)
        return lamp.min(axis=(1, 2))


def _without_uplight(t: BandTerms) -> BandTerms:
    return BandTerms(t.lamp_surface, None, t.moon, t.path, t.fire, t.illuminance_lx)


def radiance_groups(scen: ScenarioSet, bands) -> RadianceGroups:
    """Band radiance of every scene group of `scen` for `bands` (module
    docstring)."""
    f, resp = cropped(scen, bands)
    terms = band_terms(f, band_weights(resp, f.wavelength_nm))
    lamp = np.asarray(lamp_scenes(_without_uplight(terms)))
    e = np.asarray(terms.illuminance_lx)
    moonless = [i for i, m in enumerate(scen.moon_labels) if m == "none"]
    moonless_index = moonless[0] if moonless else None
    moon = None
    if terms.moon is not None:
        m = np.asarray(terms.moon)
        if terms.path is not None:
            m = m + np.asarray(terms.path)[None]
        keep = [i for i, lab in enumerate(scen.moon_labels) if lab != "none"]
        moon = m[:, :, keep, :]
    uplight = None
    if terms.uplight is not None:
        uplight = np.asarray(terms.uplight)[:, :, None, :] * e[None, None, :, None]
    fire = None if terms.fire is None else np.asarray(terms.fire)
    names = tuple(getattr(bands, "names", ())) or tuple(
        f"B{i + 1}" for i in range(lamp.shape[-1])
    )
    return RadianceGroups(
        names,
        lamp,
        moon,
        uplight,
        fire,
        moonless_index,
        e,
        float(scen.config.get("uplight_ratio", 0.0)),
    )


def radiance_percentiles(
    values: np.ndarray, percentiles: tuple[float, ...] = PERCENTILES
) -> np.ndarray:
    """Percentiles over all scenes of `values` (..., band): (len(percentiles),
    band), linear interpolation between order statistics. [same unit as input]"""
    v = np.asarray(values, float)
    if v.ndim < 1 or v.shape[-1] == 0:
        raise ValueError(f"values must have a band axis, got shape {v.shape}.")
    if not np.all(np.isfinite(v)):
        raise ValueError("values contain NaN or infinity.")
    return np.percentile(v.reshape(-1, v.shape[-1]), percentiles, axis=0)


def distribution_rows(
    groups: RadianceGroups,
    *,
    band_set: str,
    percentiles: tuple[float, ...] = PERCENTILES,
) -> list[dict]:
    """One row per (group, band): number of scenes, min, percentiles, max.
    [W m⁻² sr⁻¹ nm⁻¹]"""
    rows = []
    for g in GROUPS:
        v = groups.flat(g)
        if v is None:
            continue
        p = radiance_percentiles(v, percentiles)
        for j, name in enumerate(groups.band_names):
            row = {
                "band_set": band_set,
                "group": g,
                "band": name,
                "n_scenes": v.shape[0],
            }
            for q, val in zip(percentiles, p[:, j], strict=True):
                key = "min" if q == 0 else "max" if q == 100 else f"p{q:g}"
                row[key] = float(val)
            rows.append(row)
    return rows
