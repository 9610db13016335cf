"""Measured surface reflectance: urban materials, soil, sand, grass, water, snow.

Every surface type keeps *all* its measured spectra (soil: a seeded subsample),
so its spread can be sampled, not just its mean. Values are reflectance as a
fraction [1] in [0, 1], on each source's own grid from 380 to 1100 nm.

Sources
-------
- `Anderson2023` (earthlib 1.1.0, full library): the measured urban ("built")
  classes asphalt, road, parking lot, sidewalk, driveway, composition shingle,
  wood shingle, tile roof, metal roof and concrete roof tile (Santa Barbara
  field spectra, probably those of `Herold2004`), plus sand and soil,
  400-1100 nm at 10 nm. Vendored in `data/surfaces/earthlib_surfaces.npz`,
  rebuilt by `_surfaces_build.py`.
  Soil keeps a seeded subsample of 500 of earthlib's 4,185 spectra.
  Package licence MIT; earthlib states no licence for the spectra.
- `Aube2018` (Illumina model files, GPL-3.0, in the layout of the ASTER
  spectral library `Baldridge2009`): one spectrum each of grass, snow and water,
  vendored unchanged as `data/surfaces/*.aster`. The water spectrum is turbid
  water (11.7 % at 650-700 nm; clear water is darker in the visible).

Out of range
------------
earthlib measures nothing below 400 nm. Its spectra are extended to 380 and
390 nm with the **constant 400 nm value** and flagged: `extrapolated_range_nm`
is `(380.0, 400.0)` and `extrapolated_mask` is true for every sample in
[380, 400) nm, on the native grid and after resampling (a sample at 395 nm
interpolates between 390 and 400 nm and so depends on the extrapolated value).
Why constant and not linear from 400-420 nm: on the three ASTER spectra, where
380 nm is measured, a constant overestimates 380 nm by +13 % (grass), +33 %
(water), +0.2 % (snow) and a linear fit by -37 %, +1 %, -0.1 %; neither wins,
and the constant never amplifies the noisy 400 nm edge of the field spectra
nor leaves [0, 1]. Beyond 380-1100 nm nothing is returned: a grid outside that
range raises `ValueError`.

Resampling is linear interpolation (`bandopt.spectra.resample`).
"""

import dataclasses
import functools
import json
import re
from collections.abc import Iterable, Mapping, Sequence
from pathlib import Path
from types import MappingProxyType

import numpy as np
from jaxtyping import ArrayLike, Bool, Float

from ..names import canonical_key
from ..spectra import GRID_1NM, resample


DATA_DIR = Path(__file__).parent / "data" / "surfaces"
EARTHLIB_FILE = DATA_DIR / "earthlib_surfaces.npz"

RANGE_NM: tuple[float, float] = (380.0, 1100.0)
"""Wavelength range every surface set covers. [nm]"""

EARTHLIB_EXTRAPOLATED_NM: tuple[float, float] = (380.0, 400.0)
"""Range filled by constant extrapolation for earthlib spectra, [low, high). [nm]"""

GridLike = ArrayLike | Sequence[float]
"""A wavelength grid: an array or a sequence of numbers. [nm]"""

_EARTHLIB_TYPES: Mapping[str, str] = MappingProxyType(
    {
        "asphalt": "asphalt pavement (Santa Barbara field spectra)",
        "road": "road surfaces, mostly asphalt and concrete (Santa Barbara)",
        "parking_lot": "parking lots (Santa Barbara)",
        "sidewalk": "sidewalks, mostly concrete (Santa Barbara)",
        "driveway": "driveways (Santa Barbara)",
        "composition_shingle": "composition (asphalt) shingle roofs (Santa Barbara)",
        "wood_shingle": "wood shingle roofs (Santa Barbara)",
        "tile_roof": "tile roofs, e.g. red clay (Santa Barbara)",
        "metal_roof": "metal roofs (Santa Barbara)",
        "concrete_roof_tile": "concrete roof tiles (Santa Barbara)",
        "soil": "soils, ICRAF-ISRIC world soil library and field spectra",
        "sand": "sand",
    }
)

_ASTER_TYPES: Mapping[str, tuple[str, str, str, str]] = MappingProxyType(
    {
        # id: (file, wavelength unit, reflectance unit, description); the files
        # have no header, so their units are stated here (read off the data
        # and the Illumina folder).
        "grass": ("grass.aster", "micrometers", "percent", "green grass"),
        "water": ("water.aster", "micrometers", "fraction", "turbid water"),
        "snow": ("snow.aster", "micrometers", "percent", "snow"),
    }
)

SURFACE_TYPES: tuple[str, ...] = (*_EARTHLIB_TYPES, *_ASTER_TYPES)
"""Identifiers of the surface types, in display order."""

_ALIASES: Mapping[str, str] = MappingProxyType(
    {  # earthlib's own class names
        "compshingle": "composition_shingle",
        "tile": "tile_roof",
        "metal": "metal_roof",
        "concretetile": "concrete_roof_tile",
    }
)


_LOOKUP: Mapping[str, str] = MappingProxyType(
    {**{canonical_key(n): n for n in SURFACE_TYPES}, **_ALIASES}
)


def resolve_surface(name: str) -> str:
    """Canonical id of a surface type, matched ignoring case and `-`, `_`, spaces.

    Raises `ValueError` listing the valid ids for an unknown name.
    """
    if not isinstance(name, str) or canonical_key(name) not in _LOOKUP:
        raise ValueError(
            f"Unknown surface type {name!r}; expected one of {list(SURFACE_TYPES)}."
        )
    return _LOOKUP[canonical_key(name)]


def _readonly(a: np.ndarray) -> np.ndarray:
    a = np.array(a, copy=True)
    a.flags.writeable = False
    return a


@dataclasses.dataclass(frozen=True, eq=False)
class SurfaceSet:
    """All measured reflectance spectra of one surface type on one grid.

    **Attributes:**

    - `name`: surface type id (one of `SURFACE_TYPES`).
    - `wavelength_nm`: sample wavelengths, strictly increasing. [nm]
    - `reflectance`: one row per measured spectrum, in [0, 1]. [1]
    - `source`: BibTeX key in `bandopt/datasets/references.bib`.
    - `extrapolated_range_nm`: `(low, high)`: samples with `low <= λ < high`
      are extrapolated, not measured (the same for every spectrum of the set);
      `None` if nothing is. [nm]
    - `measured_range_nm`: first and last measured wavelength. [nm]
    - `spectrum_ids`: the source's name of each spectrum (row).
    - `description`: what the spectra are, and any subsampling.
    """

    name: str
    wavelength_nm: Float[np.ndarray, " w"]
    reflectance: Float[np.ndarray, "n w"]
    source: str
    extrapolated_range_nm: tuple[float, float] | None
    measured_range_nm: tuple[float, float]
    spectrum_ids: tuple[str, ...]
    description: str = ""

    def __post_init__(self):
        wl = np.asarray(self.wavelength_nm, float)
        r = np.asarray(self.reflectance)
        if wl.ndim != 1 or r.ndim != 2 or r.shape[1] != wl.size:
            raise ValueError(
                f"SurfaceSet {self.name!r}: `reflectance` has shape {r.shape}, "
                f"expected (n_spectra, {wl.size})."
            )
        if np.any(np.diff(wl) <= 0):
            raise ValueError(
                f"SurfaceSet {self.name!r}: `wavelength_nm` must increase strictly."
            )
        if not np.all(np.isfinite(r)) or np.any(r < 0) or np.any(r > 1):
            raise ValueError(
                f"SurfaceSet {self.name!r}: `reflectance` must be finite and in [0, 1]."
            )
        if len(self.spectrum_ids) != r.shape[0]:
            raise ValueError(
                f"SurfaceSet {self.name!r}: {len(self.spectrum_ids)} spectrum_ids "
                f"for {r.shape[0]} spectra."
            )
        object.__setattr__(self, "wavelength_nm", _readonly(wl))
        object.__setattr__(self, "reflectance", _readonly(r))

    @property
    def n(self) -> int:
        """Number of spectra."""
        return self.reflectance.shape[0]

    @property
    def extrapolated_mask(self) -> Bool[np.ndarray, " w"]:
        """True where a sample depends on extrapolated values (all spectra)."""
        if self.extrapolated_range_nm is None:
            return np.zeros(self.wavelength_nm.shape, bool)
        lo, hi = self.extrapolated_range_nm
        return (self.wavelength_nm >= lo) & (self.wavelength_nm < hi)

    def mean(self) -> Float[np.ndarray, " w"]:
        """Mean over the spectra. [1]"""
        return self.reflectance.mean(axis=0)

    def resample(self, wavelength_nm: GridLike) -> "SurfaceSet":
        """The same set linearly interpolated onto `wavelength_nm` [nm].

        Raises `ValueError` if the grid leaves this set's wavelength range.
        """
        grid = _check_grid(
            wavelength_nm, (self.wavelength_nm[0], self.wavelength_nm[-1])
        )
        return dataclasses.replace(
            self,
            wavelength_nm=grid,
            reflectance=_interp(self.wavelength_nm, self.reflectance, grid),
        )


def _interp(x: np.ndarray, y: np.ndarray, grid: np.ndarray) -> np.ndarray:
    """Linear interpolation; `grid` has been checked to lie inside `x`."""
    out = resample(x, y, grid, outside="nan")
    if not np.all(np.isfinite(out)):
        raise ValueError(
            f"`wavelength_nm` ({grid[0]:g}-{grid[-1]:g} nm) leaves the data range "
            f"{x[0]:g}-{x[-1]:g} nm."
        )
    return out


def _check_grid(
    wavelength_nm: GridLike, covered_nm: tuple[float, float] = RANGE_NM
) -> np.ndarray:
    grid = np.asarray(wavelength_nm, dtype=float)
    if grid.ndim != 1 or grid.size == 0:
        raise ValueError(
            f"`wavelength_nm` must be a non-empty 1-D array, got {grid.shape}."
        )
    if not np.all(np.isfinite(grid)) or np.any(np.diff(grid) <= 0):
        raise ValueError("`wavelength_nm` must be finite and strictly increasing.")
    lo, hi = float(covered_nm[0]), float(covered_nm[1])
    tol = 1e-6
    if grid[0] < lo - tol or grid[-1] > hi + tol:
        raise ValueError(
            f"`wavelength_nm` spans {grid[0]:g}-{grid[-1]:g} nm but the surface "
            f"spectra cover {lo:g}-{hi:g} nm only."
        )
    return np.clip(grid, lo, hi)


# ---------------------------------------------------------------- ASTER files

_WAVELENGTH_UNITS = {
    "micrometers": 1000.0,
    "micrometer": 1000.0,
    "micrometre": 1000.0,
    "micrometres": 1000.0,
    "microns": 1000.0,
    "micron": 1000.0,
    "um": 1000.0,
    "µm": 1000.0,
    "μm": 1000.0,
    "nanometers": 1.0,
    "nanometer": 1.0,
    "nanometres": 1.0,
    "nanometre": 1.0,
    "nm": 1.0,
}
_REFLECTANCE_UNITS = {
    "percent": 0.01,
    "percentage": 0.01,
    "%": 0.01,
    "fraction": 1.0,
    "ratio": 1.0,
    "1": 1.0,
    "unitless": 1.0,
}


def _unit_scale(
    path: Path,
    field: str,
    header: dict[str, str],
    given: str | None,
    arg: str,
    table: dict[str, float],
) -> float:
    def scale_of(text: str, where: str) -> float:
        inner = re.search(r"\(([^)]*)\)", text)
        unit = (inner.group(1) if inner else text).strip().lower()
        if unit not in table:
            raise ValueError(
                f"{path}: {where}: unknown unit {text!r}; "
                f"expected one of {sorted(table)}."
            )
        return table[unit]

    in_file = header.get(field.lower())
    if in_file is None and given is None:
        raise ValueError(
            f"{path}: no {field!r} header field; pass {arg}= (one of {sorted(table)})."
        )
    if in_file is None:
        return scale_of(given, f"{arg}")
    scale = scale_of(in_file, f"field {field!r}")
    if given is not None and scale_of(given, arg) != scale:
        raise ValueError(
            f"{path}: field {field!r} says {in_file!r} but {arg}={given!r} was given."
        )
    return scale


def _numbers(tokens: list[str]) -> list[float] | None:
    try:
        return [float(t) for t in tokens]
    except ValueError:
        return None


def read_aster(
    path: str | Path,
    *,
    wavelength_unit: str | None = None,
    reflectance_unit: str | None = None,
) -> tuple[Float[np.ndarray, " w"], Float[np.ndarray, " w"]]:
    """Read a spectrum in ASTER spectral library layout (`Baldridge2009`).

    The file is an optional header of `Field: value` lines (continuation lines
    without a colon extend the previous field) followed by lines of two
    numbers, wavelength and reflectance, in ascending or descending order.
    Units come from the header fields `X Units` / `Y Units` (e.g.
    `Wavelength (micrometers)`, `Reflectance (percent)`) or, for files without a
    header, from `wavelength_unit` / `reflectance_unit`; both given and
    disagreeing is an error. `Number of X Values`, `First X Value` and `Last X
    Value` are checked when present.

    Returns `(wavelength_nm [nm], reflectance [1])`, ascending, unclipped.
    Raises `ValueError` naming the file and the line or field on bad input,
    including reflectance outside [-0.02, 1.5] after conversion (a wrong unit).
    A percent file read as a fraction is caught; a fraction file read as
    percent only looks very dark and is not.
    """
    path = Path(path)
    text = path.read_bytes().decode("utf-8", errors="replace")
    header: dict[str, str] = {}
    last_key = None
    rows: list[tuple[float, float]] = []
    lines: list[int] = []
    for lineno, raw in enumerate(text.splitlines(), start=1):
        line = raw.strip()
        if not line:
            continue
        nums = _numbers(line.split())
        if rows or nums is not None:
            if nums is None or len(nums) != 2:
                raise ValueError(
                    f"{path}: line {lineno}: expected two numbers "
                    f"'wavelength reflectance', got {line[:60]!r}."
                )
            if not all(np.isfinite(nums)):
                raise ValueError(f"{path}: line {lineno}: non-finite value {line!r}.")
            rows.append((nums[0], nums[1]))
            lines.append(lineno)
        elif ":" in line:
            key, _, value = line.partition(":")
            last_key = key.strip().lower()
            header[last_key] = value.strip()
        elif last_key is not None:
            header[last_key] = f"{header[last_key]} {line}"
        else:
            raise ValueError(
                f"{path}: line {lineno}: neither a 'Field: value' header line nor "
                f"two numbers: {line[:60]!r}."
            )
    if len(rows) < 2:
        raise ValueError(f"{path}: fewer than two data lines.")
    x, y = np.array(rows, dtype=float).T

    if "number of x values" in header:
        try:
            expected = int(float(header["number of x values"]))
        except ValueError:
            raise ValueError(
                f"{path}: field 'Number of X Values': not a number "
                f"{header['number of x values']!r}."
            ) from None
        if expected != x.size:
            raise ValueError(
                f"{path}: field 'Number of X Values' says {expected} but the file "
                f"has {x.size} data lines."
            )
    for field, value in (("first x value", x[0]), ("last x value", x[-1])):
        if field in header:
            stated = _numbers(header[field].split()[:1])
            if not stated or abs(stated[0] - value) > 1e-6 * max(1.0, abs(value)):
                raise ValueError(
                    f"{path}: field {field.title()!r} says {header[field]!r} but the "
                    f"data give {value:g}."
                )

    d = np.diff(x)
    if np.all(d < 0):
        x, y = x[::-1], y[::-1]
    elif not np.all(d > 0):
        bad = int(np.flatnonzero(d <= 0)[0]) if np.any(d > 0) else 0
        raise ValueError(
            f"{path}: line {lines[bad + 1]}: wavelengths are not strictly monotonic."
        )

    x_scale = _unit_scale(
        path, "X Units", header, wavelength_unit, "wavelength_unit", _WAVELENGTH_UNITS
    )
    y_scale = _unit_scale(
        path,
        "Y Units",
        header,
        reflectance_unit,
        "reflectance_unit",
        _REFLECTANCE_UNITS,
    )
    wavelength_nm = np.round(x * x_scale, 6)
    reflectance = y * y_scale
    if wavelength_nm[0] < 100.0 or wavelength_nm[-1] > 1e5:
        raise ValueError(
            f"{path}: wavelengths span {wavelength_nm[0]:g}-{wavelength_nm[-1]:g} nm "
            f"after conversion; is the wavelength unit ('X Units') right?"
        )
    if reflectance.min() < -0.02 or reflectance.max() > 1.5:
        raise ValueError(
            f"{path}: reflectance spans "
            f"{reflectance.min():.4g}-{reflectance.max():.4g} "
            f"after conversion, not a fraction in [0, 1]; is the reflectance unit "
            f"('Y Units') right?"
        )
    return wavelength_nm, reflectance


# ---------------------------------------------------------------- loading


@functools.cache
def _earthlib_npz() -> dict[str, np.ndarray]:
    with np.load(EARTHLIB_FILE, allow_pickle=False) as f:
        return {k: f[k] for k in f.files}


def library_info() -> dict:
    """Provenance of the vendored earthlib extract: earthlib version, licences,
    and per type the earthlib class, its count in earthlib and the count kept."""
    return json.loads(str(_earthlib_npz()["info"]))


def _earthlib_set(name: str) -> SurfaceSet:
    data = _earthlib_npz()
    info = library_info()["classes"][name]
    wl = data["wavelength_nm"]
    r = data[f"reflectance__{name}"]
    lo, hi = EARTHLIB_EXTRAPOLATED_NM
    ext = np.arange(lo, hi, wl[1] - wl[0])
    if wl[0] != hi:
        raise ValueError(
            f"{EARTHLIB_FILE}: earthlib grid starts at {wl[0]} nm, not {hi}."
        )
    wavelength_nm = np.concatenate([ext, wl])
    reflectance = np.concatenate([np.repeat(r[:, :1], ext.size, axis=1), r], axis=1)
    description = _EARTHLIB_TYPES[name]
    if info["subsample"]:
        s = info["subsample"]
        description += (
            f"; seeded subsample ({s['method']}, seed {s['seed']}) of {s['n']} of "
            f"earthlib's {info['n_in_earthlib']} spectra"
        )
    return SurfaceSet(
        name=name,
        wavelength_nm=wavelength_nm,
        reflectance=np.clip(reflectance, 0.0, 1.0),
        source="Anderson2023",
        extrapolated_range_nm=EARTHLIB_EXTRAPOLATED_NM,
        measured_range_nm=(float(wl[0]), float(wl[-1])),
        spectrum_ids=tuple(str(s) for s in data[f"ids__{name}"]),
        description=description,
    )


def _aster_set(name: str) -> SurfaceSet:
    file, x_unit, y_unit, description = _ASTER_TYPES[name]
    path = DATA_DIR / file
    wl, r = read_aster(path, wavelength_unit=x_unit, reflectance_unit=y_unit)
    lo, hi = RANGE_NM
    i0 = max(int(np.searchsorted(wl, lo, side="right")) - 1, 0)
    i1 = int(np.searchsorted(wl, hi, side="left")) + 1
    wl, r = wl[i0:i1], r[i0:i1]
    if wl[0] > lo or wl[-1] < hi:
        raise ValueError(
            f"{path}: covers {wl[0]:g}-{wl[-1]:g} nm, not {lo:g}-{hi:g} nm."
        )
    return SurfaceSet(
        name=name,
        wavelength_nm=wl,
        reflectance=np.clip(r, 0.0, 1.0)[None, :],
        source="Aube2018",
        extrapolated_range_nm=None,
        measured_range_nm=(float(wl[0]), float(wl[-1])),
        spectrum_ids=(file,),
        description=f"{description} (Illumina file {file}, ASTER layout)",
    )


@functools.cache
def _surface(name: str) -> SurfaceSet:
    return _earthlib_set(name) if name in _EARTHLIB_TYPES else _aster_set(name)


def surface(name: str) -> SurfaceSet:
    """All measured spectra of one surface type on its source's own grid
    (earthlib: 380-1100 nm at 10 nm, 380-390 nm extrapolated; ASTER files:
    their own steps). The arrays are read-only (the set is cached)."""
    return _surface(resolve_surface(name))


def _names(names: str | Iterable[str] | None) -> tuple[str, ...]:
    if names is None:
        return SURFACE_TYPES
    if isinstance(names, str):
        names = (names,)
    return tuple(resolve_surface(n) for n in names)


def surfaces(
    names: str | Iterable[str] | None = None,
    wavelength_nm: GridLike = GRID_1NM,
) -> dict[str, SurfaceSet]:
    """Surface sets resampled (linearly) onto `wavelength_nm` [nm], keyed by id.

    `names=None` gives every type in `SURFACE_TYPES`. The grid must lie within
    380-1100 nm.
    """
    grid = _check_grid(wavelength_nm)
    return {n: surface(n).resample(grid) for n in _names(names)}


def mean_reflectance(
    names: str | Iterable[str] | None = None,
    wavelength_nm: GridLike = GRID_1NM,
) -> tuple[tuple[str, ...], Float[np.ndarray, "s v"]]:
    """Mean reflectance of each surface type on `wavelength_nm` [nm]: the ids and
    an array with one row per id. [1]"""
    grid = _check_grid(wavelength_nm)
    ids = _names(names)
    rows = [surface(n).resample(grid).mean() for n in ids]
    return ids, np.stack(rows) if rows else np.zeros((0, grid.size))


def sample_reflectance(
    name: str,
    n: int,
    seed: int,
    wavelength_nm: GridLike = GRID_1NM,
) -> Float[np.ndarray, "n v"]:
    """`n` measured spectra of one surface type drawn uniformly with replacement
    (`numpy.random.default_rng(seed)`), resampled onto `wavelength_nm`. [1]

    A type with one spectrum (grass, water, snow) returns `n` copies of it.
    """
    if isinstance(n, bool) or not isinstance(n, int | np.integer) or n < 0:
        raise ValueError(f"`n` must be a non-negative integer, got {n!r}.")
    s = surface(name)
    grid = _check_grid(wavelength_nm)
    idx = np.random.default_rng(seed).integers(0, s.n, size=int(n))
    return _interp(s.wavelength_nm, s.reflectance[idx], grid)
