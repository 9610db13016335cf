"""The lamp library: real measured spectra with a two-level typology.

Sources (keys in `references.bib`):

- colour-science's NIST CQS sets (`Ohno2008a` traditional and Philips,
  `Ohno2008b` LED), 380-780 nm at 5 nm;
- the CIE 015:2018 illuminants FL1-FL12, FL3.1-FL3.15, HP1-HP5, LED-B1..B5,
  LED-BH1, LED-RGB1, LED-V1/V2 (`CIE2018`), labelled as CIE *typical* spectra,
  380-780 nm at 5 nm;
- 13 LI-1800 measurements (`Aphalo2023`), 300-900 nm, photon units converted
  to energy;
- modelled spectra from Planck's law (`Planck1901`): incandescent 2400-3200 K
  and fire 700-1200 K, labelled `modelled` and not counted as lamps.

Reserved for independent validation, never loaded here: the IES TM-30 sample
spectra (luxpy) and the Illumina/LSPDD example spectra.

**Grid and units.** Every spectrum is linearly interpolated onto the library
grid (default `GRID_1NM`, 380-900 nm at 1 nm) and normalised to one lumen:
`683 ∫_380^780 V S dλ = 1`, so `values` are spectral radiant flux per lumen
[W nm⁻¹ lm⁻¹]; multiplied by an illuminance [lx] they give spectral irradiance
[W m⁻² nm⁻¹]. Beyond a spectrum's measured range the values are the
near-infrared extension of `bandopt.datasets.nir` (flag `extended`), or NaN
when the extension is switched off (`library(extend_nir=False)`).

**Typology** (fixed identifiers): level 1 `LEVEL1`, level 2 `LEVEL2`. White
phosphor LEDs are `led_warm` for CCT <= 3500 K and `led_cool` above. A
level-2 class with fewer than `MIN_LAMPS_FOR_SCORING` distinct measured lamps is
"insufficient for scoring". Research RGB mixes are `led_rgb` (their own class,
never scored); coloured fluorescent tubes (|Duv| > 0.02) have no level-2 class
and are excluded from scoring, as are fluorescent tubes whose CCT lies
outside 1000-25000 K (the red TL-D /15).

**Deduplication rule** (`DUPLICATE_RMS`): two spectra, each normalised to unit
visible power and compared on 380-780 nm at 5 nm, are the same lamp when the
RMS of their difference is below 3 % of their mean value; the copy from the
source listed first in `SOURCE_PRIORITY` is kept.
"""

import dataclasses
import functools
import warnings
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from ..spectra import GRID_1NM
from . import nir
from .loaders import SpectrumWarning, read_prn


LEVEL1 = ("led", "hid", "lps", "fluorescent", "incandescent", "fire", "moon")
LEVEL2 = (
    "led_warm",
    "led_cool",
    "led_amber",
    "led_rgb",
    "hps",
    "mercury",
    "metal_halide",
    "lps",
    "fluorescent_linear",
    "fluorescent_compact",
    "incandescent_halogen",
)
LEVEL2_PARENT = {
    "led_warm": "led",
    "led_cool": "led",
    "led_amber": "led",
    "led_rgb": "led",
    "hps": "hid",
    "mercury": "hid",
    "metal_halide": "hid",
    "lps": "lps",
    "fluorescent_linear": "fluorescent",
    "fluorescent_compact": "fluorescent",
    "incandescent_halogen": "incandescent",
}
MIN_LAMPS_FOR_SCORING = 3
LED_WARM_MAX_CCT_K = 3500.0
COLOURED_DUV = 0.02
DUPLICATE_RMS = 0.03
SOURCE_PRIORITY = ("li1800", "nist_philips", "nist_traditional", "nist_led", "cie015")
NEVER_SCORED = ("led_rgb",)

_LI1800 = Path(__file__).parent / "data" / "lamps_li1800"


@dataclasses.dataclass(frozen=True)
class LampRecord:
    """What the library knows about one spectrum.

    - `id`: stable identifier, e.g. `nist_philips_c100s54_hps`.
    - `name`: the name in its source.
    - `level1`, `level2`: typology (`LEVEL1`, `LEVEL2`; `level2` may be None).
    - `source`: bibliography key; `source_set`: the collection.
    - `unit`: unit of the library values.
    - `measured_range_nm`: what was measured. [nm]
    - `extended`: values beyond the measured range come from `bandopt.datasets.nir`.
    - `extension_validated`: the extension's technology was checked against a
      measurement (None when not extended).
    - `modelled`: from Planck's law, not a measurement (never counted as a lamp).
    - `cie_typical`: a CIE 015 typical spectrum, not a specific product.
    - `excluded`: reason the lamp is kept out of scored classes (or None).
    - `duplicates`: ids of near-duplicates removed in its favour.
    """

    id: str
    name: str
    level1: str
    level2: str | None
    source: str
    source_set: str
    unit: str
    measured_range_nm: tuple[float, float]
    extended: bool
    extension_validated: bool | None
    modelled: bool
    cie_typical: bool
    excluded: str | None
    duplicates: tuple[str, ...] = ()

    def as_dict(self) -> dict:
        d = dataclasses.asdict(self)
        d["measured_range_nm"] = list(self.measured_range_nm)
        d["duplicates"] = list(self.duplicates)
        return d


@dataclasses.dataclass(frozen=True)
class LampLibrary:
    """Lamp spectra on one grid with their records (row i of `values` is `records[i]`).

    - `wavelength_nm`: the grid. [nm]
    - `values`: spectral radiant flux per lumen. [W nm⁻¹ lm⁻¹]
    - `records`: one `LampRecord` per row.
    - `insufficient`: level-2 classes with fewer than `MIN_LAMPS_FOR_SCORING`
      distinct measured lamps ("insufficient for scoring").
    - `removed`: near-duplicates removed, as (removed id, kept id).
    """

    wavelength_nm: np.ndarray
    values: np.ndarray
    records: tuple[LampRecord, ...]
    insufficient: tuple[str, ...]
    removed: tuple[tuple[str, str], ...]

    def __len__(self) -> int:
        return len(self.records)

    @property
    def ids(self) -> list[str]:
        return [r.id for r in self.records]

    def index(self, lamp_id: str) -> int:
        ids = self.ids
        if lamp_id not in ids:
            raise ValueError(f"Unknown lamp id {lamp_id!r}; see `bandopt library`.")
        return ids.index(lamp_id)

    def is_scored(self, record: LampRecord) -> bool:
        """Counted in a scored level-2 class: measured, not excluded, in a
        sufficient class."""
        return (
            not record.modelled
            and record.excluded is None
            and record.level2 is not None
            and record.level2 not in self.insufficient
            and record.level2 not in NEVER_SCORED
        )

    def select(
        self, *, lamps_only: bool = True, scored_only: bool = False
    ) -> "LampLibrary":
        """A sub-library: `lamps_only` drops modelled spectra; `scored_only`
        keeps only lamps in scored classes."""
        keep = [
            i
            for i, r in enumerate(self.records)
            if (not lamps_only or not r.modelled)
            and (not scored_only or self.is_scored(r))
        ]
        return dataclasses.replace(
            self,
            values=self.values[keep],
            records=tuple(self.records[i] for i in keep),
        )

    def counts(self) -> list[dict]:
        """Distinct measured lamps per level-2 class, with the scoring status."""
        rows = []
        lamps = [r for r in self.records if not r.modelled]
        for l2 in LEVEL2:
            members = [r for r in lamps if r.level2 == l2]
            n_excl = sum(r.excluded is not None for r in members)
            n = len(members) - n_excl
            if l2 in NEVER_SCORED:
                status = "own type, never scored (research mixes)"
            elif l2 in self.insufficient:
                status = "insufficient for scoring"
            else:
                status = "scored"
            rows.append(
                {
                    "level1": LEVEL2_PARENT[l2],
                    "level2": l2,
                    "lamps": n,
                    "cie_typical": sum(r.cie_typical for r in members),
                    "status": status,
                }
            )
        unclassed = [r for r in lamps if r.level2 is None]
        if unclassed:
            rows.append(
                {
                    "level1": "fluorescent",
                    "level2": None,
                    "lamps": len(unclassed),
                    "cie_typical": sum(r.cie_typical for r in unclassed),
                    "status": "excluded: "
                    + "; ".join(sorted({r.excluded for r in unclassed})),
                }
            )
        return rows


def _slug(text: str) -> str:
    out = "".join(c.lower() if c.isalnum() else "_" for c in text)
    while "__" in out:
        out = out.replace("__", "_")
    return out.strip("_")


# (source_set, name) -> (level1, level2); None level2 means decided by CCT/Duv.
_NIST_TRADITIONAL = {
    "Cool White FL": "fluorescent_linear",
    "Daylight FL": "fluorescent_linear",
    "HPS": "hps",
    "Incandescent": "incandescent_halogen",
    "LPS": "lps",
    "Mercury": "mercury",
    "Metal Halide": "metal_halide",
    "Neodimium Incandescent": "incandescent_halogen",
    "Super HPS": "hps",
    "Triphosphor FL": "fluorescent_linear",
}
_NIST_PHILIPS = {
    "60 A/W (Soft White)": "incandescent_halogen",
    "C100S54 (HPS)": "hps",
    "C100S54C (HPS)": "hps",
    "H38HT-100 (Mercury)": "mercury",
    "H38JA-100/DX (Mercury DX)": "mercury",
    "MHC100/U/MP/3K": "metal_halide",
    "MHC100/U/MP/4K": "metal_halide",
    "SDW-T 100W/LV (Super HPS)": "hps",
}  # every other Philips entry is a linear fluorescent tube (F32T8, F34, F40)
_CIE_HP = {
    "HP1": "hps",
    "HP2": "hps",
    "HP3": "metal_halide",
    "HP4": "metal_halide",
    "HP5": "metal_halide",
}
_LI1800_CLASS = {
    "Incandescent.60W": "incandescent_halogen",
    "Osram.36W.25": "fluorescent_linear",
    "Osram.HQIT.400W": "metal_halide",
    "Osram.Super.Vialox": "hps",
    "Philips.PLS11W.827": "fluorescent_compact",
    "Philips.TLD36W.15": "fluorescent_linear",
    "Philips.TLD36W.18": "fluorescent_linear",
    "Philips.TLD36W.83": "fluorescent_linear",
    "Philips.TLD36W.865": "fluorescent_linear",
    "Philips.TLD36W.89": "fluorescent_linear",
    "Philips.TLD36W.92": "fluorescent_linear",
    "Philips.TLL36W.950": "fluorescent_linear",
    "Sylvania.215W.VHO": "fluorescent_linear",
}


@dataclasses.dataclass
class _Raw:
    id: str
    name: str
    source: str
    source_set: str
    level2: str | None  # None: phosphor LED, decided by CCT
    wavelength_nm: np.ndarray
    values: np.ndarray  # energy units
    cie_typical: bool = False


def _raw_sources() -> list[_Raw]:
    import colour
    from colour.colorimetry.datasets.light_sources import sds as light_sources

    raws: list[_Raw] = []
    for name, sd in light_sources.SDS_LIGHT_SOURCES_NIST_TRADITIONAL.items():
        raws.append(
            _Raw(
                f"nist_traditional_{_slug(name)}",
                name,
                "Ohno2008a",
                "nist_traditional",
                _NIST_TRADITIONAL[name],
                sd.wavelengths.copy(),
                sd.values.copy(),
            )
        )
    for name, sd in light_sources.SDS_LIGHT_SOURCES_NIST_PHILIPS.items():
        raws.append(
            _Raw(
                f"nist_philips_{_slug(name)}",
                name,
                "Ohno2008a",
                "nist_philips",
                _NIST_PHILIPS.get(name, "fluorescent_linear"),
                sd.wavelengths.copy(),
                sd.values.copy(),
            )
        )
    for name, sd in light_sources.SDS_LIGHT_SOURCES_NIST_LED.items():
        rgb = name.startswith(("3-LED", "4-LED"))
        raws.append(
            _Raw(
                f"nist_led_{_slug(name)}",
                name,
                "Ohno2008b",
                "nist_led",
                "led_rgb" if rgb else None,
                sd.wavelengths.copy(),
                sd.values.copy(),
            )
        )
    for name, sd in colour.SDS_ILLUMINANTS.items():
        if name.startswith("FL"):
            level2 = "fluorescent_linear"
        elif name in _CIE_HP:
            level2 = _CIE_HP[name]
        elif name == "LED-RGB1":
            level2 = "led_rgb"
        elif name.startswith("LED-"):
            level2 = None
        else:
            continue
        raws.append(
            _Raw(
                f"cie_{_slug(name)}",
                f"CIE {name}",
                "CIE2018",
                "cie015",
                level2,
                sd.wavelengths.copy(),
                sd.values.copy(),
                cie_typical=True,
            )
        )
    for path in sorted(_LI1800.glob("*.PRN")):
        with warnings.catch_warnings():
            # Two samples of TLD36W.15 are slightly negative (noise, documented in
            # data/lamps_li1800/README.md); read_prn clips them.
            warnings.simplefilter("ignore", SpectrumWarning)
            s = read_prn(path)
        raws.append(
            _Raw(
                f"li1800_{_slug(path.stem)}",
                path.stem.replace(".", " "),
                "Aphalo2023",
                "li1800",
                _LI1800_CLASS[path.stem],
                s.wavelength_nm,
                s.values,
            )
        )
    return raws


def _visible_5nm(w, s):
    grid = np.arange(380.0, 780.1, 5.0)
    v = np.interp(grid, w, s)
    return v / np.trapezoid(v, grid)


def _cct_duv(w, s):
    """CCT (Ohno 2013) and Duv with colour-science on the 1 nm-interpolated spectrum."""
    import colour

    grid = np.arange(380.0, 781.0, 1.0)
    sd = colour.SpectralDistribution(np.interp(grid, w, s), grid)
    cmfs = (
        colour.MSDS_CMFS["CIE 1931 2 Degree Standard Observer"]
        .copy()
        .trim(colour.SpectralShape(380.0, 780.0, 1.0))
    )
    xyz = colour.sd_to_XYZ(sd, cmfs=cmfs, method="Integration")
    uv = colour.UCS_to_uv(colour.XYZ_to_UCS(xyz))
    with warnings.catch_warnings():
        # Colour warns when the nearest Planckian point is the table's end: the red
        # TL-D /15 (458 K). Such tubes are flagged by their CCT range below.
        warnings.simplefilter("ignore", colour.utilities.ColourRuntimeWarning)
        cct, duv = colour.temperature.uv_to_CCT_Ohno2013(uv)
    return float(cct), float(duv)


def planck_spectrum(wavelength_nm: np.ndarray, temperature_k: float) -> np.ndarray:
    """Planck's law, spectral radiance of a blackbody (`Planck1901`).
    [W m⁻² sr⁻¹ nm⁻¹]"""
    h, c, k = 6.62607015e-34, 2.99792458e8, 1.380649e-23
    lam = np.asarray(wavelength_nm, float) * 1e-9
    return 2 * h * c**2 / lam**5 / np.expm1(h * c / (lam * k * temperature_k)) * 1e-9


MODELLED_INCANDESCENT_K = (2400.0, 2600.0, 2800.0, 3000.0, 3200.0)
MODELLED_FIRE_K = (700.0, 800.0, 900.0, 1000.0, 1100.0, 1200.0)


def _per_lumen(wavelength_nm, values):
    from colour import SDS_LEFS

    v = SDS_LEFS["CIE 1924 Photopic Standard Observer"]
    vis = (wavelength_nm >= 380.0) & (wavelength_nm <= 780.0)
    lum = 683.0 * np.trapezoid(values[vis] * v[wavelength_nm[vis]], wavelength_nm[vis])
    return values / lum


@functools.cache
def _build(extend_nir: bool, grid_key: tuple[float, float, float]) -> LampLibrary:
    lo, hi, step = grid_key
    grid = np.arange(lo, hi + step / 2, step)
    raws = _raw_sources()

    # Typology: phosphor LEDs by CCT; coloured tubes excluded by |Duv|.
    classified = []
    for r in raws:
        cct, duv = _cct_duv(r.wavelength_nm, r.values)
        excluded = None
        level2 = r.level2
        if level2 is None:
            level2 = "led_warm" if cct <= LED_WARM_MAX_CCT_K else "led_cool"
        if level2.startswith("fluorescent") and (
            abs(duv) > COLOURED_DUV or not 1000.0 <= cct <= 25000.0
        ):
            excluded = (
                f"coloured tube (|Duv| = {abs(duv):.3f}, CCT = {cct:.0f} K: beyond "
                f"|Duv| <= {COLOURED_DUV} and 1000-25000 K)"
            )
            level2 = None
        classified.append((r, level2, excluded))

    # Near-duplicates across (and within) sources.
    order = sorted(
        range(len(classified)),
        key=lambda i: SOURCE_PRIORITY.index(classified[i][0].source_set),
    )
    shapes = {i: _visible_5nm(raws[i].wavelength_nm, raws[i].values) for i in order}
    kept: list[int] = []
    dup_of: dict[int, list[str]] = {}
    removed = []
    for i in order:
        match = None
        for j in kept:
            a, b = shapes[i], shapes[j]
            if np.sqrt(np.mean((a - b) ** 2)) < DUPLICATE_RMS * np.mean((a + b) / 2):
                match = j
                break
        if match is None:
            kept.append(i)
        else:
            dup_of.setdefault(match, []).append(raws[i].id)
            removed.append((raws[i].id, raws[match].id))
    kept.sort()

    values, records = [], []
    for i in kept:
        r, level2, excluded = classified[i]
        level1 = LEVEL2_PARENT[level2] if level2 else "fluorescent"
        w, s = r.wavelength_nm, r.values
        inside = (grid >= w[0]) & (grid <= w[-1])
        row = np.full(grid.shape, np.nan)
        row[inside] = np.interp(grid[inside], w, s)
        row[grid < w[0]] = np.nan
        beyond = grid > w[-1]
        extended = False
        validated = None
        if beyond.any() and extend_nir:
            tech = nir.technology_of(level2, level1)
            row[beyond] = nir.extend_spectrum(w, s, tech, grid[beyond])
            extended = True
            validated = nir.VALIDATED.get(tech, False)
        values.append(_per_lumen(grid, row))
        records.append(
            LampRecord(
                id=r.id,
                name=r.name,
                level1=level1,
                level2=level2,
                source=r.source,
                source_set=r.source_set,
                unit="W nm-1 lm-1",
                measured_range_nm=(float(w[0]), float(w[-1])),
                extended=extended,
                extension_validated=validated,
                modelled=False,
                cie_typical=r.cie_typical,
                excluded=excluded,
                duplicates=tuple(dup_of.get(i, ())),
            )
        )

    modelled = [
        (
            f"planck_incandescent_{int(t)}k",
            f"Planck {int(t)} K",
            "incandescent",
            "incandescent_halogen",
            t,
        )
        for t in MODELLED_INCANDESCENT_K
    ] + [
        (f"planck_fire_{int(t)}k", f"Fire (blackbody) {int(t)} K", "fire", None, t)
        for t in MODELLED_FIRE_K
    ]
    for lamp_id, name, level1, level2, t in modelled:
        values.append(_per_lumen(grid, planck_spectrum(grid, t)))
        records.append(
            LampRecord(
                id=lamp_id,
                name=name,
                level1=level1,
                level2=level2,
                source="Planck1901",
                source_set="planck",
                unit="W nm-1 lm-1",
                measured_range_nm=(float(grid[0]), float(grid[-1])),
                extended=False,
                extension_validated=None,
                modelled=True,
                cie_typical=False,
                excluded=None,
            )
        )

    # Classes with too few distinct measured lamps.
    measured = [rec for rec in records if not rec.modelled and rec.excluded is None]
    insufficient = tuple(
        l2
        for l2 in LEVEL2
        if sum(rec.level2 == l2 for rec in measured) < MIN_LAMPS_FOR_SCORING
    )
    values_arr = np.asarray(values)
    values_arr.setflags(write=False)
    return LampLibrary(grid, values_arr, tuple(records), insufficient, tuple(removed))


def library(
    *, extend_nir: bool = True, wavelength_nm: Sequence[float] | np.ndarray = GRID_1NM
) -> LampLibrary:
    """The lamp library on a uniform grid (default 380-900 nm at 1 nm).

    `extend_nir=False` leaves values beyond each spectrum's measured range NaN
    (unknown), so a band reaching there fails loudly rather than reading zeros.
    """
    w = np.asarray(wavelength_nm, float)
    step = np.diff(w)
    if w.ndim != 1 or w.size < 2 or not np.allclose(step, step[0]):
        raise ValueError("wavelength_nm must be a uniform 1-D grid.")
    if w[0] < 380.0 or w[-1] > nir.EXTENSION_END_NM:
        raise ValueError(
            f"wavelength_nm must lie in 380-900 nm (got {w[0]:g}-{w[-1]:g}): no lamp "
            "data exist outside it."
        )
    return _build(bool(extend_nir), (float(w[0]), float(w[-1]), float(step[0])))
