"""Luminaires: luminous intensity distributions per lumen on a regular (C, γ) grid.

A `Luminaire` holds `I(C, γ)` per lumen of luminaire output [cd lm⁻¹] on a
regular grid (`GAMMA_STEP_DEG`, `C_STEP_DEG`), normalised so that
`∫ I dΩ = 1`. Multiplied by the luminaire's flux [lm] it is the intensity
[cd]. Angles are Type C (`bandopt.spatial.read_photometry`): γ from nadir (0) to
zenith (180), C0 along the road (+x), C90 across it (+y) before the lamp's
own rotation.

Sources of a distribution:

- a photometric file (`from_file`: EULUMDAT or IES LM-63), resampled
  bilinearly onto the grid (periodic in C, zero outside the file's γ range);
- Illumina's azimuth-averaged profiles with 0-50 % uplight (`from_lop`,
  `Aube2018`, vendored in `data/luminaires/`, GPL-3.0);
- parametric shapes (`lambertian`, `uniform`, `cutoff`, `road_optic`).

The flux of a luminaire is the *luminaire* output (what leaves the fixture,
after its light output ratio): files are renormalised, so the LOR of a file is
not applied twice.
"""

import functools
import math
from pathlib import Path

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Float, Int

from .._photometric import IntensityTable, read_lop, read_photometry
from ..names import canonical_key


GAMMA_STEP_DEG = 0.5
C_STEP_DEG = 2.5
GAMMA_DEG = np.linspace(0.0, 180.0, round(180 / GAMMA_STEP_DEG) + 1)
C_DEG = np.linspace(0.0, 360.0, round(360 / C_STEP_DEG) + 1)
DATA_DIR = Path(__file__).parent / "data" / "luminaires"
LOP_UPLIGHT_PERCENT = (0, 1, 2, 5, 10, 15, 20, 50)


def _solid_angle_weights() -> np.ndarray:
    """(c, g) quadrature weights: `∫ f dΩ ≈ Σ w f` (trapezoid in C and γ with
    the sin γ factor). [sr]"""
    g = np.radians(GAMMA_DEG)
    wg = np.full(GAMMA_DEG.size, np.radians(GAMMA_STEP_DEG))
    wg[0] = wg[-1] = 0.5 * np.radians(GAMMA_STEP_DEG)
    wc = np.full(C_DEG.size, np.radians(C_STEP_DEG))
    wc[0] = wc[-1] = 0.5 * np.radians(C_STEP_DEG)
    return wc[:, None] * (wg * np.sin(g))[None, :]


SOLID_ANGLE_WEIGHTS = _solid_angle_weights()


class Luminaire(eqx.Module):
    """An intensity distribution per lumen on the regular grid.

    - `intensity_cd_per_lm`: (c, g) on `C_DEG` x `GAMMA_DEG`, `∫ I dΩ = 1`. [cd lm⁻¹]
    - `name`: label; `source`: how it was made (file path or parameters).
    """

    intensity_cd_per_lm: Float[Array, "c g"]
    name: str = eqx.field(static=True)
    source: str = eqx.field(static=True, default="")

    def __check_init__(self):
        if self.intensity_cd_per_lm.shape != (C_DEG.size, GAMMA_DEG.size):
            raise ValueError(
                f"intensity_cd_per_lm must have shape {(C_DEG.size, GAMMA_DEG.size)}, "
                f"got {self.intensity_cd_per_lm.shape}."
            )

    @property
    def uplight_fraction(self) -> float:
        """Share of the flux sent above the horizon (γ > 90°). [1]"""
        i = np.asarray(self.intensity_cd_per_lm)
        w = SOLID_ANGLE_WEIGHTS.copy()
        up = GAMMA_DEG > 90.0
        half = GAMMA_DEG == 90.0
        return float(np.sum((i * w)[:, up]) + 0.5 * np.sum((i * w)[:, half]))

    @property
    def zenith_cd_per_lm(self) -> float:
        """Intensity straight up (γ = 180°), seen by a nadir view. [cd lm⁻¹]"""
        return float(np.mean(np.asarray(self.intensity_cd_per_lm)[:, -1]))

    @property
    def max_cd_per_lm(self) -> float:
        """Largest intensity of the table. [cd lm⁻¹]"""
        return float(np.max(np.asarray(self.intensity_cd_per_lm)))


def _normalised(table: np.ndarray, name: str, source: str) -> Luminaire:
    table = np.asarray(table, float)
    if np.any(table < 0) or not np.all(np.isfinite(table)):
        raise ValueError(f"{source}: intensity must be finite and >= 0.")
    flux = float(np.sum(table * SOLID_ANGLE_WEIGHTS))
    if not flux > 0:
        raise ValueError(f"{source}: the distribution emits no light.")
    table = table.copy()
    table[-1] = table[0]  # C = 360 is C = 0
    table[:, 0] = np.mean(table[:, 0])  # one value at the poles
    table[:, -1] = np.mean(table[:, -1])
    flux = float(np.sum(table * SOLID_ANGLE_WEIGHTS))
    return Luminaire(jnp.asarray(table / flux), name=name, source=source)


def resample_table(table: IntensityTable) -> np.ndarray:
    """Bilinear resampling of a file's table onto `C_DEG` x `GAMMA_DEG`
    (periodic in C; zero outside the file's γ range). [unit of the table]"""
    c = np.asarray(table.c_deg, float)
    g = np.asarray(table.gamma_deg, float)
    i = np.asarray(table.intensity, float)
    along_c = np.empty((C_DEG.size, g.size))
    for k in range(g.size):
        along_c[:, k] = np.interp(C_DEG, c, i[:, k], period=360.0)
    out = np.empty((C_DEG.size, GAMMA_DEG.size))
    for k in range(C_DEG.size):
        out[k] = np.interp(GAMMA_DEG, g, along_c[k], left=0.0, right=0.0)
    return out


def from_table(table: IntensityTable, name: str | None = None) -> Luminaire:
    """A luminaire from a parsed photometric table (renormalised to 1 lm)."""
    return _normalised(
        resample_table(table), name or table.name or "file", table.source
    )


def from_file(path) -> Luminaire:
    """A luminaire from an `.ldt`, `.ies` or `.lop` file."""
    return from_table(read_photometry(path), Path(path).stem)


def from_lop(uplight_percent: int) -> Luminaire:
    """Illumina's averaged profile with `uplight_percent` % uplight
    (`LOP_UPLIGHT_PERCENT`; `Aube2018`)."""
    if uplight_percent not in LOP_UPLIGHT_PERCENT:
        raise ValueError(
            f"uplight_percent={uplight_percent!r}; expected one of "
            f"{list(LOP_UPLIGHT_PERCENT)}."
        )
    path = DATA_DIR / f"{uplight_percent}_pcUPLIGHT.lop"
    return from_table(read_lop(path), f"lop-{uplight_percent}pc")


def _grids():
    return np.meshgrid(np.radians(C_DEG), np.radians(GAMMA_DEG), indexing="ij")


def _taper(gamma_deg, edge_deg, width_deg):
    """1 below `edge - width`, 0 above `edge`, linear between."""
    return np.clip((edge_deg - gamma_deg) / width_deg, 0.0, 1.0)


def lambertian() -> Luminaire:
    """`I = cos γ / π` below the horizon, nothing above (flux 1 lm). [cd lm⁻¹]"""
    _, g = _grids()
    return _normalised(np.maximum(np.cos(g), 0.0), "lambertian", "parametric: cos γ")


def uniform() -> Luminaire:
    """Constant intensity over the lower hemisphere, `1 / 2π` (ground illuminance
    `E = I cos³θ / h²`, the point-source closed form). [cd lm⁻¹]"""
    _, g = _grids()
    table = np.where(
        np.degrees(g) < 90.0, 1.0, np.where(np.degrees(g) == 90.0, 0.5, 0.0)
    )
    return _normalised(table, "uniform", "parametric: constant below the horizon")


def cutoff(cutoff_deg: float = 70.0, taper_deg: float = 5.0) -> Luminaire:
    """A full cut-off optic: constant intensity up to `cutoff_deg - taper_deg`,
    falling linearly to 0 at `cutoff_deg` from nadir; no uplight."""
    if not 0.0 < taper_deg < cutoff_deg <= 90.0:
        raise ValueError(
            f"Need 0 < taper_deg < cutoff_deg <= 90, got {taper_deg!r}, {cutoff_deg!r}."
        )
    _, g = _grids()
    table = _taper(np.degrees(g), cutoff_deg, taper_deg)
    return _normalised(
        table, f"cutoff-{cutoff_deg:g}", f"parametric: cut-off at {cutoff_deg:g} deg"
    )


def road_optic(
    peak_along_deg: float = 68.0,
    peak_street_deg: float = 45.0,
    peak_house_deg: float = 15.0,
    width_deg: float = 12.0,
    uplight_fraction: float = 0.0,
) -> Luminaire:
    """An asymmetric road optic that throws light along the road.

    `I(C, γ) = exp(-(γ - γ_p(C))² / 2w²) · taper(γ, 90°)` with the peak angle
    `γ_p(C) = peak_along cos²C + peak_side sin²C`, `peak_side` =
    `peak_street_deg` towards C90 (the road) and `peak_house_deg` towards C270
    (behind the pole). An optional isotropic `uplight_fraction` of the flux goes
    to the upper hemisphere. A stylised shape (cf. the batwing of thesis Fig.
    3.2), not a measured product.
    """
    if not 0.0 <= uplight_fraction < 1.0:
        raise ValueError(
            f"uplight_fraction must lie in [0, 1), got {uplight_fraction!r}."
        )
    c, g = _grids()
    side = np.where(np.sin(c) >= 0.0, peak_street_deg, peak_house_deg)
    peak = peak_along_deg * np.cos(c) ** 2 + side * np.sin(c) ** 2
    gd = np.degrees(g)
    down = np.exp(-0.5 * ((gd - peak) / width_deg) ** 2) * _taper(gd, 90.0, 3.0)
    down /= np.sum(down * SOLID_ANGLE_WEIGHTS)
    if uplight_fraction > 0:
        up = (gd > 90.0) + 0.5 * (gd == 90.0)
        up = up / np.sum(up * SOLID_ANGLE_WEIGHTS)
        down = (1 - uplight_fraction) * down + uplight_fraction * up
    return _normalised(
        down,
        "road-optic",
        f"parametric: road optic, peaks {peak_along_deg:g}/{peak_street_deg:g}/"
        f"{peak_house_deg:g} deg, uplight {uplight_fraction:g}",
    )


_NAMED = {
    "lambertian": lambertian,
    "uniform": uniform,
    "cutoff": cutoff,
    "roadoptic": road_optic,
    **{f"lop{p}": functools.partial(from_lop, p) for p in LOP_UPLIGHT_PERCENT},
}
LUMINAIRE_NAMES = (
    "lambertian",
    "uniform",
    "cutoff",
    "road-optic",
    *(f"lop-{p}" for p in LOP_UPLIGHT_PERCENT),
)


@functools.lru_cache(maxsize=64)
def _named(key: str) -> Luminaire:
    return _NAMED[key]()


def luminaire(name_or_path: str, *, base_dir: str | Path | None = None) -> Luminaire:
    """A luminaire by name (`LUMINAIRE_NAMES`, matched ignoring case and
    separators; `"lop-5"` is Illumina's 5 % uplight profile) or by the path of
    a `.ldt`, `.ies` or `.lop` file (relative to `base_dir` if given)."""
    if not isinstance(name_or_path, str):
        raise ValueError(f"luminaire must be a name or a path, got {name_or_path!r}.")
    key = canonical_key(name_or_path)
    if key in _NAMED:
        return _named(key)
    suffix = Path(name_or_path).suffix.lower()
    if suffix in (".ldt", ".ies", ".lop"):
        path = Path(name_or_path)
        if base_dir is not None and not path.is_absolute():
            path = Path(base_dir) / path
        return from_file(path)
    raise ValueError(
        f"Unknown luminaire {name_or_path!r}; expected one of {list(LUMINAIRE_NAMES)} "
        "or a .ldt/.ies/.lop file path."
    )


def stack_tables(luminaires: list[Luminaire]) -> Float[Array, "n c g"]:
    """Stack the tables of several luminaires for the renderer."""
    return jnp.stack([lum.intensity_cd_per_lm for lum in luminaires])


@jax.jit
def lookup_cd_per_lm(
    tables: Float[Array, "n c g"],
    index: Int[Array, "*batch"],
    c_rad: Float[Array, "*batch"],
    gamma_rad: Float[Array, "*batch"],
) -> Float[Array, "*batch"]:
    """Bilinear interpolation of table `index` at (C, γ); C taken modulo 2π,
    γ clipped to [0, π]. [cd lm⁻¹]"""
    gi = jnp.clip(gamma_rad, 0.0, math.pi) / math.radians(GAMMA_STEP_DEG)
    ci = jnp.mod(c_rad, 2 * math.pi) / math.radians(C_STEP_DEG)
    g0 = jnp.clip(jnp.floor(gi), 0, GAMMA_DEG.size - 2).astype(jnp.int32)
    c0 = jnp.clip(jnp.floor(ci), 0, C_DEG.size - 2).astype(jnp.int32)
    fg = gi - g0
    fc = ci - c0
    t = tables
    v00 = t[index, c0, g0]
    v01 = t[index, c0, g0 + 1]
    v10 = t[index, c0 + 1, g0]
    v11 = t[index, c0 + 1, g0 + 1]
    return (1 - fc) * ((1 - fg) * v00 + fg * v01) + fc * ((1 - fg) * v10 + fg * v11)
