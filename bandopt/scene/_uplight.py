"""Direct uplight from the luminaires: Illumina's azimuth-averaged profiles
(`uplight_profiles`, read once per process from
`bandopt/spatial/data/luminaires/`) and `uplight_factor`, the radiance seen at
the view zenith per unit ground illuminance (or the old Lambertian shortcut).
Apart because it is the one part of the scene model that reads luminaire
files.
"""

import functools
import math
from pathlib import Path

import numpy as np

from .._photometric import read_lop
from ..names import canonical_key


UPLIGHT_PROFILE_PERCENT: tuple[int, ...] = (0, 1, 2, 5, 10, 15, 20, 50)
"""Nominal uplight percentages of Illumina's luminaire profiles (`Aube2018`)."""
UPLIGHT_MODELS: tuple[str, ...] = ("profile", "lambertian")
_LOP_DIR = Path(__file__).resolve().parents[1] / "spatial" / "data" / "luminaires"


@functools.cache
def uplight_profiles() -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Illumina's azimuth-averaged luminaire profiles `<p>_pcUPLIGHT.lop`
    (`Aube2018`, GPL-3.0, vendored verbatim in `bandopt/spatial/data/luminaires/`)
    normalised to a luminaire flux of 1 lm.

    Returns `(percent, zenith_deg, intensity, downward)`: nominal uplight
    percentages (p,); zenith angles 0 (straight up) .. 180 (p, z) [deg];
    intensity per lumen `i(z)` with `2π ∫ i sin z dz = 1` (trapezoid rule in z
    on the files' 1° grid) (p, z) [cd lm⁻¹ = sr⁻¹]; downward fraction `d` of
    the flux (zenith 90-180°, the 90° sample shared half and half) (p,) [1].
    """
    zen, inten, down = [], [], []
    for pc in UPLIGHT_PROFILE_PERCENT:
        table = read_lop(_LOP_DIR / f"{pc}_pcUPLIGHT.lop")
        z = 180.0 - np.asarray(table.gamma_deg, float)[::-1]
        i = np.asarray(table.intensity, float)[0, ::-1]
        if z[0] != 0.0 or z[-1] != 180.0:
            raise ValueError(f"{table.source}: zenith angles must span 0-180 degrees.")
        d, up = _hemisphere_fluxes(z, i)
        zen.append(z)
        inten.append(i / (d + up))
        down.append(d / (d + up))
    if any(z.shape != zen[0].shape or np.any(z != zen[0]) for z in zen):
        raise ValueError(f"The profiles in {_LOP_DIR} use different zenith grids.")
    return (
        np.asarray(UPLIGHT_PROFILE_PERCENT, float),
        np.asarray(zen[0]),
        np.asarray(inten),
        np.asarray(down),
    )


def _hemisphere_fluxes(z_deg: np.ndarray, i: np.ndarray) -> tuple[float, float]:
    """(downward, upward) flux `2π ∫ i sin z dz` by the trapezoid rule, split at
    z = 90° (which must be a grid node). [unit of i x sr]"""
    zr = np.radians(z_deg)
    f = 2 * np.pi * i * np.sin(zr)
    seg = 0.5 * (f[1:] + f[:-1]) * np.diff(zr)
    mid = 0.5 * (z_deg[1:] + z_deg[:-1])
    if not np.any(z_deg == 90.0):
        raise ValueError("The profile's zenith grid must contain 90 degrees.")
    return float(seg[mid > 90].sum()), float(seg[mid < 90].sum())


def uplight_factor(
    uplight_ratio: float, view_zenith_deg: float = 0.0, model: str = "profile"
) -> float:
    """`f_up`: direct uplight radiance per unit ground illuminance, seen at
    `view_zenith_deg` (the zenith angle of the direction towards the sensor).
    [sr⁻¹]; times `E_c S_l` it is spectral radiance.

    - ``model="profile"``: `i(θv) / (d cos θv)` from Illumina's profiles
      (`uplight_profiles`); `uplight_ratio` is the nominal uplight fraction of
      the files (0, 0.01, 0.02, 0.05, 0.10, 0.15, 0.20, 0.50), between them
      the two neighbouring profiles are mixed linearly (a mix of luminaires;
      intensity and downward fraction mix with the same weights); `i` is
      linear in zenith angle between the files' 1° samples.
    - ``model="lambertian"``: the thesis's shortcut `u / (1 - u) / π`
      (upward flux `u/(1-u)` of the ground illuminance, emitted as a
      Lambertian surface), which over-states nadir uplight 2x (50 % profile)
      to > 100x (5-10 %) against the measured profiles.
    """
    u = float(uplight_ratio)
    if not 0.0 <= u <= 0.5:
        raise ValueError(f"uplight_ratio must lie in [0, 0.5], got {uplight_ratio!r}.")
    v = float(view_zenith_deg)
    if not 0.0 <= v < 90.0:
        raise ValueError(
            f"view_zenith_deg must lie in [0, 90), got {view_zenith_deg!r}."
        )
    key = canonical_key(model)
    if key not in UPLIGHT_MODELS:
        raise ValueError(
            f"Unknown uplight model {model!r}; expected one of {list(UPLIGHT_MODELS)}."
        )
    if key == "lambertian":
        return u / (1 - u) / math.pi
    pc, z, inten, down = uplight_profiles()
    x = 100.0 * u
    j = int(np.clip(np.searchsorted(pc, x, side="right") - 1, 0, pc.size - 2))
    w = (x - pc[j]) / (pc[j + 1] - pc[j])
    i_v = (1 - w) * np.interp(v, z, inten[j]) + w * np.interp(v, z, inten[j + 1])
    d = (1 - w) * down[j] + w * down[j + 1]
    return float(i_v / (d * math.cos(math.radians(v))))
