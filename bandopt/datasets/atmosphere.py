"""Atmospheric transmittance and moonlight path reflectance from shipped 6S tables.

The tables in `data/atmosphere/` were made with 6SV1.1 (`Vermote1997`,
`Kotchenova2006`) through Py6S (`Wilson2013`) by
``python -m bandopt.datasets._atmosphere_build`` (``make atmospheres``); 6S never
runs here. Monochromatic runs on a 2.5 nm grid over 350-1100 nm, for 4 standard
atmospheres x 3 aerosol models x 3 visibilities, zenith angles 0-75°.

- `transmittance`: one-way total transmittance, gas absorption x (Rayleigh +
  aerosol scattering, direct + diffuse), surface to top of atmosphere at the view
  zenith (``"up"``) or top of atmosphere to surface at the Moon's zenith
  (``"down"``). The two are reciprocal (6S gives equal values; the check is
  recorded in `table_info()["reciprocity_check"]`), so one table serves both.
  ``part="direct"`` gives the unscattered part only, gas x ``exp(-τ/cos θ)``
  with 6S's column optical depth τ (Rayleigh + aerosol), and ``"diffuse"``
  the rest (total - direct): 6S itself splits the signal at the sensor into a
  pixel (direct) and a background (diffuse) part this way, which the build
  checks (`table_info()["direct_transmittance_check"]`). A pixel much smaller
  than the adjacency footprint (10-100 m against ~1 km) sees its own surface
  through the direct part and its neighbourhood through the diffuse part
  (`bandopt.scene`).
- `optical_depth`: 6S's column optical depths, Rayleigh and aerosol.
- `path_reflectance`: 6S's atmospheric intrinsic reflectance ρ_atm with the
  Moon as illuminant, so that ``L_path = ρ_atm · E_moon,TOA · cos θ_moon / π``
  (`path_radiance`).
- `resolve_setting`: what an "auto" | "6s" | "none" setting gives here (the
  one availability decision; `tables_available`, `require_tables`).

Interpolation (stated once, used everywhere):

- in angle: linear in air mass ``m = 1/cos θ`` between the table angles, on
  ``ln T`` for transmittances (exact for a Beer-Lambert direct beam) and on ρ
  itself for path reflectances (single scattering grows like 1/cos θ);
- in wavelength: linear, after the angle; wavelengths outside 350-1100 nm raise;
- visibility: only the table values 5, 10, 23 km (no interpolation in AOT);
- names are matched ignoring case and separators (``"Midlatitude-Summer"``).

Off-nadir path reflectance (``0 < view_zenith_deg <= 30``) is the nadir table
times a factor from coarser 6S runs (relative azimuth 90° only, 25 nm, Moon
zeniths 15-75°): ``ρ(θm, θv) = ρ(θm, 0) · [1 + f(θv) (S(θm) - 1)] ·
T_gas(θv)/T_gas(0)``, where ``S = ρ_scat(θm, 30°)/ρ_scat(θm, 0)`` is the ratio
of scattering-only reflectances (smooth in wavelength, gas-free, independent of
the atmosphere type), ``f = (1/cos θv - 1)/(1/cos 30° - 1)`` and the gas ratio
adds the longer upward gas path. It is an approximation of a full 6S run
(azimuth fixed, gas absorption factorised).
"""

import functools
import json
from collections.abc import Sequence
from pathlib import Path

import numpy as np
from jaxtyping import ArrayLike, Float

from ..names import CanonicalMapping, canonical_key, validate_method
from ..spectra import GRID_1NM


ATMOSPHERES: tuple[str, ...] = (
    "midlatitude_summer",
    "midlatitude_winter",
    "tropical",
    "subarctic_winter",
)
"""6S standard atmospheres (gas and water-vapour profiles) in the tables."""
AEROSOLS: tuple[str, ...] = ("urban", "continental", "maritime")
"""6S aerosol models in the tables."""
VISIBILITIES_KM: tuple[float, ...] = (5.0, 10.0, 23.0)
"""Horizontal visibilities in the tables; 6S turns them into AOT550. [km]"""

DATA_DIR = Path(__file__).resolve().parent / "data" / "atmosphere"
_TABLE = DATA_DIR / "sixs_tables.npz"
_META = DATA_DIR / "sixs_tables.json"
_OFFNADIR_MAX_DEG = 30.0


def _index(name: str, choices: tuple[str, ...], argument: str) -> int:
    """Position of `name` in `choices` (`bandopt.names` rule: case and
    separators ignored)."""
    positions = CanonicalMapping({c: i for i, c in enumerate(choices)})
    if name not in positions:
        raise ValueError(
            f"Unknown `{argument}` {name!r}; expected one of {list(choices)}."
        )
    return positions[name]


def _vis_index(visibility_km) -> int:
    v = float(visibility_km)
    for i, choice in enumerate(VISIBILITIES_KM):
        if abs(v - choice) < 1e-9:
            return i
    raise ValueError(
        f"`visibility_km`={visibility_km!r} is not in the 6S tables; expected one of "
        f"{list(VISIBILITIES_KM)} (no interpolation in aerosol optical depth)."
    )


@functools.cache
def _tables() -> dict[str, np.ndarray]:
    if not _TABLE.is_file():
        raise FileNotFoundError(
            f"{_TABLE} is missing: regenerate it with `make atmospheres`."
        )
    with np.load(_TABLE) as f:
        return {k: np.asarray(f[k], float) for k in f.files}


@functools.cache
def _meta() -> dict:
    return json.loads(_META.read_text())


def _airmass(zenith_deg) -> np.ndarray:
    return np.asarray(1.0 / np.cos(np.deg2rad(zenith_deg)))


def _angle_weights(
    zenith_deg,
    table_deg: np.ndarray,
    argument: str,
    limit: float | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Lower table index and weight of the upper neighbour, linear in air mass."""
    z = np.asarray(zenith_deg, float)
    hi = float(table_deg[-1]) if limit is None else limit
    if not np.all(np.isfinite(z)) or np.any(z < 0) or np.any(z > hi):
        raise ValueError(
            f"`{argument}` must lie in [0, {hi:g}] degrees (the 6S table range), got "
            f"{np.asarray(zenith_deg).tolist()}."
        )
    x, xt = _airmass(z), _airmass(table_deg)
    i = np.clip(np.searchsorted(xt, x, side="right") - 1, 0, xt.size - 2)
    w = (x - xt[i]) / (xt[i + 1] - xt[i])
    return np.asarray(i), np.asarray(w)


def _wavelengths(wavelength_nm) -> np.ndarray:
    wl = np.asarray(wavelength_nm, float)
    grid = _tables()["wavelength_nm"]
    if wl.ndim != 1 or wl.size == 0:
        raise ValueError(
            f"`wavelength_nm` must be a non-empty 1-D array, got {wl.shape}."
        )
    if np.any(~np.isfinite(wl)) or wl.min() < grid[0] or wl.max() > grid[-1]:
        raise ValueError(
            f"`wavelength_nm` must lie in [{grid[0]:g}, {grid[-1]:g}] nm (the 6S table "
            f"range), got [{wl.min():g}, {wl.max():g}]."
        )
    return wl


def _interp_wavelength(
    rows: np.ndarray, grid: np.ndarray, wl: np.ndarray
) -> np.ndarray:
    flat = rows.reshape(-1, grid.size)
    out = np.stack([np.interp(wl, grid, r) for r in flat])
    return out.reshape((*rows.shape[:-1], wl.size))


def _combo(atmosphere: str, aerosol: str, visibility_km) -> tuple[int, int, int]:
    return (
        _index(atmosphere, ATMOSPHERES, "atmosphere"),
        _index(aerosol, AEROSOLS, "aerosol"),
        _vis_index(visibility_km),
    )


def _log_t_gas(k: tuple[int, int, int], zenith_deg, argument: str) -> np.ndarray:
    t = _tables()
    i, w = _angle_weights(zenith_deg, t["zenith_deg"], argument)
    lg = np.log(t["t_gas"][k])
    return (1 - w)[..., None] * lg[i] + w[..., None] * lg[i + 1]


PARTS: tuple[str, ...] = ("total", "direct", "diffuse")
"""Parts of the one-way transmittance `transmittance` returns."""


def _scattering(k: tuple[int, int, int], part: str) -> np.ndarray:
    t = _tables()
    if part == "total":
        return t["t_scat"][k]
    if "t_scat_direct" not in t:
        raise ValueError(
            f"{_TABLE} has no direct transmittance (`t_scat_direct`, tables made "
            "before 2026-11-25): regenerate them with `make atmospheres`."
        )
    return t["t_scat_direct"][k]


def transmittance(
    direction: str,
    atmosphere: str,
    aerosol: str,
    visibility_km: float | int,
    zenith_deg: float | ArrayLike | Sequence[float],
    wavelength_nm: Float[ArrayLike, " w"] | Sequence[float] = GRID_1NM,
    *,
    part: str = "total",
) -> Float[np.ndarray, "*batch w"]:
    """One-way transmittance, gas x scattering (Rayleigh + aerosol). [1]

    **Arguments:**

    - `direction`: ``"up"`` (surface to sensor at the view zenith) or ``"down"``
      (top of atmosphere to surface at the Moon's zenith); reciprocal, same table.
    - `atmosphere`, `aerosol`: one of `ATMOSPHERES`, `AEROSOLS`.
    - `visibility_km`: one of `VISIBILITIES_KM`. [km]
    - `zenith_deg`: zenith angle(s) of the path, 0-75; any shape `*batch`. [deg]
    - `wavelength_nm`: output grid within 350-1100 nm. [nm]
    - `part`: ``"total"`` (direct + diffuse, the default), ``"direct"``
      (unscattered: gas x ``exp(-τ/cos θ)``) or ``"diffuse"`` (total - direct).

    `ln T` is linear in air mass between table angles (exact for the direct
    part, Beer-Lambert), then T linear in wavelength; the diffuse part is the
    difference of the two interpolated parts.
    """
    if canonical_key(direction) not in ("up", "down"):
        raise ValueError(
            f"Unknown `direction` {direction!r}; expected one of ['down', 'up']."
        )
    key = canonical_key(part)
    if key not in PARTS:
        raise ValueError(f"Unknown `part` {part!r}; expected one of {list(PARTS)}.")
    if key == "diffuse":
        args = (direction, atmosphere, aerosol, visibility_km, zenith_deg)
        total = transmittance(*args, wavelength_nm)
        return total - transmittance(*args, wavelength_nm, part="direct")
    k = _combo(atmosphere, aerosol, visibility_km)
    wl = _wavelengths(wavelength_nm)
    t = _tables()
    i, w = _angle_weights(zenith_deg, t["zenith_deg"], "zenith_deg")
    lt = np.log(t["t_gas"][k] * _scattering(k, key))
    rows = np.exp((1 - w)[..., None] * lt[i] + w[..., None] * lt[i + 1])
    return _interp_wavelength(rows, t["wavelength_nm"], wl)


def optical_depth(
    atmosphere: str,
    aerosol: str,
    visibility_km: float | int,
    wavelength_nm: Float[ArrayLike, " w"] | Sequence[float] = GRID_1NM,
) -> tuple[Float[np.ndarray, " w"], Float[np.ndarray, " w"]]:
    """6S's column optical depths (Rayleigh, aerosol) at nadir, linear in
    wavelength. [1]"""
    k = _combo(atmosphere, aerosol, visibility_km)
    wl = _wavelengths(wavelength_nm)
    t = _tables()
    if "tau_rayleigh" not in t:
        raise ValueError(
            f"{_TABLE} has no optical depths (tables made before 2026-11-25): "
            "regenerate them with `make atmospheres`."
        )
    grid = t["wavelength_nm"]
    return (
        np.interp(wl, grid, t["tau_rayleigh"][k]),
        np.interp(wl, grid, t["tau_aerosol"][k]),
    )


def _offnadir_factor(
    k: tuple[int, int, int], moon_zenith_deg, view_zenith_deg: float
) -> np.ndarray:
    """``[1 + f(θv)(S(θm) - 1)] · T_gas(θv)/T_gas(0)`` on the 2.5 nm grid."""
    t = _tables()
    meta = _meta()
    a_off = ATMOSPHERES.index(meta["settings"]["offnadir_runs"]["atmosphere"])
    grid, cgrid = t["wavelength_nm"], t["offnadir_wavelength_nm"]
    cidx = np.searchsorted(grid, cgrid)
    zt = t["zenith_deg"]
    scat = t["rho_scat"][a_off, k[1], k[2]][:, cidx]  # (Z, wc), Moon at θ, nadir view
    view_row = int(
        np.argmin(np.abs(zt - meta["settings"]["offnadir_runs"]["view_zenith_deg"]))
    )
    # S on Moon zeniths (0, offnadir grid); at θm = 0 from the fast runs alone
    s0 = scat[view_row] / scat[0]
    moon_grid = t["offnadir_moon_zenith_deg"]
    rows = [int(np.argmin(np.abs(zt - m))) for m in moon_grid]
    s_tab = np.concatenate([s0[None], t["offnadir_rho_scat"][k[1], k[2]] / scat[rows]])
    m_tab = np.concatenate([[0.0], moon_grid])
    i, w = _angle_weights(moon_zenith_deg, m_tab, "moon_zenith_deg")
    s = (1 - w)[..., None] * s_tab[i] + w[..., None] * s_tab[i + 1]  # (*b, wc)
    s = _interp_wavelength(s, cgrid, grid)
    vmax = meta["settings"]["offnadir_runs"]["view_zenith_deg"]
    f = (_airmass(view_zenith_deg) - 1.0) / (_airmass(vmax) - 1.0)
    gas = np.exp(
        _log_t_gas(k, view_zenith_deg, "view_zenith_deg") - np.log(t["t_gas"][k][0])
    )
    return (1.0 + f * (s - 1.0)) * gas


def path_reflectance(
    atmosphere: str,
    aerosol: str,
    visibility_km: float | int,
    moon_zenith_deg: float | ArrayLike | Sequence[float],
    view_zenith_deg: float | int = 0.0,
    wavelength_nm: Float[ArrayLike, " w"] | Sequence[float] = GRID_1NM,
) -> Float[np.ndarray, "*batch w"]:
    """Atmospheric intrinsic (path) reflectance with the Moon as illuminant. [1]

    **Arguments:**

    - `atmosphere`, `aerosol`, `visibility_km`: as in `transmittance`. [km]
    - `moon_zenith_deg`: Moon zenith angle(s), 0-75; any shape `*batch`. [deg]
    - `view_zenith_deg`: sensor view zenith, 0-30; above 0 the off-nadir factor
      of the module docstring applies (relative azimuth 90°). [deg]
    - `wavelength_nm`: output grid within 350-1100 nm. [nm]

    Linear in air mass of the Moon between table angles, linear in wavelength.
    """
    k = _combo(atmosphere, aerosol, visibility_km)
    wl = _wavelengths(wavelength_nm)
    t = _tables()
    v = float(view_zenith_deg)
    if not 0.0 <= v <= _OFFNADIR_MAX_DEG:
        raise ValueError(
            f"`view_zenith_deg` must lie in [0, {_OFFNADIR_MAX_DEG:g}] degrees (the 6S "
            f"path-reflectance table range), got {view_zenith_deg!r}."
        )
    i, w = _angle_weights(moon_zenith_deg, t["zenith_deg"], "moon_zenith_deg")
    rho = t["rho_path"][k]
    rows = (1 - w)[..., None] * rho[i] + w[..., None] * rho[i + 1]
    if v > 0:
        rows = rows * _offnadir_factor(k, moon_zenith_deg, v)
    return _interp_wavelength(rows, t["wavelength_nm"], wl)


def path_radiance(
    lunar_irradiance_w_m2_nm: Float[ArrayLike, " w"] | Sequence[float],
    moon_zenith_deg: float | int,
    atmosphere: str,
    aerosol: str,
    visibility_km: float | int,
    view_zenith_deg: float | int = 0.0,
    wavelength_nm: Float[ArrayLike, " w"] | Sequence[float] = GRID_1NM,
) -> Float[np.ndarray, " w"]:
    """Path radiance of moonlight ``ρ_atm · E_moon · cos θ_moon / π``. [W m-2 sr-1 nm-1]

    **Arguments:**

    - `lunar_irradiance_w_m2_nm`: lunar irradiance at the top of the atmosphere on a
      surface facing the Moon, sampled on `wavelength_nm`. [W m-2 nm-1]
    - `moon_zenith_deg`: Moon zenith angle, 0-75. [deg]
    - the rest as in `path_reflectance`.
    """
    e = np.asarray(lunar_irradiance_w_m2_nm, float)
    wl = np.asarray(wavelength_nm, float)
    if e.shape != wl.shape:
        raise ValueError(
            f"`lunar_irradiance_w_m2_nm` has shape {e.shape} but `wavelength_nm` has "
            f"{wl.shape}; sample the irradiance on the same grid."
        )
    if np.ndim(moon_zenith_deg) != 0:
        raise ValueError("`moon_zenith_deg` must be a scalar for `path_radiance`.")
    rho = path_reflectance(
        atmosphere, aerosol, visibility_km, moon_zenith_deg, view_zenith_deg, wl
    )
    return rho * e * np.cos(np.deg2rad(float(moon_zenith_deg))) / np.pi


def atmosphere_ids() -> list[tuple[str, str, float]]:
    """All (atmosphere, aerosol, visibility_km) combinations in the tables."""
    return [(a, r, v) for a in ATMOSPHERES for r in AEROSOLS for v in VISIBILITIES_KM]


def table_info() -> dict:
    """Versions, settings, grids, checks and AOT550 per combination of the tables."""
    info = json.loads(json.dumps(_meta()))  # deep copy: callers may mutate
    aot = _tables()["aot550"]
    info["aot550"] = {
        f"{a}/{r}/{v:g}km": float(aot[_combo(a, r, v)]) for a, r, v in atmosphere_ids()
    }
    info["files"] = [str(_TABLE), str(_META)]
    return info


SETTINGS: tuple[str, ...] = ("auto", "6s", "none")
"""What a caller may ask for (`resolve_setting`): "auto" (the 6S tables when
installed, else no atmosphere), "6s" (the tables, an error without them) or
"none" (no atmosphere: T = 1, no path radiance)."""


def _missing_table() -> Path | None:
    """The first table file that is not installed, or None."""
    return next((p for p in (_TABLE, _META) if not p.is_file()), None)


def tables_available() -> bool:
    """Whether the 6S tables are installed (`make atmospheres` builds them)."""
    return _missing_table() is None


def require_tables() -> None:
    """`FileNotFoundError` naming the missing file and `make atmospheres`
    unless `tables_available()`."""
    path = _missing_table()
    if path is not None:
        raise FileNotFoundError(
            f"{path} is missing: regenerate the 6S tables with `make atmospheres`."
        )


def resolve_setting(setting: str = "auto", *, option: str = "atmospheres") -> str:
    """What an atmosphere `setting` of `SETTINGS` gives on this installation:
    "6s" or "none".

    The one place bandopt decides between the 6S tables and no atmosphere, so
    every part decides alike: "auto" is "6s" when `tables_available()`, else
    "none"; "6s" needs the tables; "none" is "none". Callers record the
    returned value, not the request, so a result says which atmosphere made
    it. Case and separators are ignored ("6S").

    `option` names the setting in errors (e.g. "--atmospheres"). Raises
    `ValueError` for a setting outside `SETTINGS` and `FileNotFoundError`
    naming `option`, the missing file and `make atmospheres` when "6s" is
    asked without the tables.
    """
    value = validate_method(setting, SETTINGS, option)
    if value == "auto":
        return "6s" if tables_available() else "none"
    if value == "6s" and not tables_available():
        path = _missing_table() or _TABLE
        raise FileNotFoundError(
            f"{option} {setting!r} needs the 6S tables, but {path} is missing: "
            "regenerate them with `make atmospheres`, or ask for 'auto' or 'none'."
        )
    return value
