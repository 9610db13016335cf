"""The lamp library: real measured spectra with a two-level typology.

Sources (keys in `references.bib`):

- colour-science's NIST CQS sets (`Ohno2008a` traditional and Philips,
  `Ohno2008b` LED), 380-780 nm at 5 nm;
- the CIE 015:2018 illuminants FL1-FL12, FL3.1-FL3.15, HP1-HP5, LED-B1..B5,
  LED-BH1, LED-RGB1, LED-V1/V2 (`CIE2018`), labelled as CIE *typical* spectra,
  380-780 nm at 5 nm;
- 13 LI-1800 measurements (`Aphalo2023`), 300-900 nm, photon units converted
  to energy;
- the LSPDD (`LSPDD2016`): about 200 lamps measured 273-899.5 nm (LED incl.
  outdoor road, wall-pack and step luminaires, CFL, halogen, incandescent,
  metal halide), vendored verbatim (CC BY-NC-ND 2.5 CA) and parsed in memory;
  switchable: `library(lspdd=False)` or the environment variable
  `BANDOPT_LSPDD=0` builds the library without it (`LSPDD_ENV`);
- the photobiology R data (`Aphalo2025lamps`, `Aphalo2025leds`, GPL >= 2):
  CFLs, linear fluorescents, household LED bulbs and tubes, white LED packages,
  incandescent/halogen and amber LED emitters, ~251-899 nm, converted by
  `_lamps_build` (the 13 LI-1800 lamps it also holds are not taken twice);
- the color-pollution outdoor set (`Robinson2016`, MIT): LPS, HPS, metal
  halide, mercury, field LEDs, a measured PC-amber LED, 380-930 nm. The
  provenance of most of its files is not documented (`provenance_documented`
  False); their line positions are checked in `tests/test_lamps.py`;
- modelled spectra from Planck's law (`Planck1901`): incandescent 2400-3200 K
  and fire 700-1200 K, labelled `modelled` and not counted as lamps.

Reserved for independent validation, never loaded here: the IES TM-30 sample
spectra (luxpy) and the LSPDD records absent from the vendored set.

**Grid and units.** Every spectrum is linearly interpolated onto the library
grid (default `GRID_1NM`, 380-900 nm at 1 nm) and normalised to one lumen:
`683 ∫_380^780 V S dλ = 1`, so `values` are spectral radiant flux per lumen
[W nm⁻¹ lm⁻¹]; multiplied by an illuminance [lx] they give spectral irradiance
[W m⁻² nm⁻¹]. Beyond a spectrum's measured range the values are the
near-infrared extension of `bandopt.datasets.nir` (flag `extended`), or NaN
when the extension is switched off (`library(extend_nir=False)`). A spectrum
measured to within `EDGE_HOLD_NM` of the grid end (LSPDD to 899.5 nm,
photobiology to ~899 nm) is measured, not extended: its last sample is held
over the remaining < `EDGE_HOLD_NM` (flag `nir_measured`).

**Typology** (fixed identifiers): level 1 `LEVEL1`, level 2 `LEVEL2`. White
phosphor LEDs are `led_warm` for CCT <= 3500 K and `led_cool` above. A
level-2 class with fewer than `MIN_LAMPS_FOR_SCORING` distinct measured lamps is
"insufficient for scoring". Research RGB mixes are `led_rgb` (their own class,
never scored); coloured fluorescent tubes (|Duv| > 0.02) have no level-2 class
and are excluded from scoring, as are fluorescent tubes whose CCT lies
outside 1000-25000 K (the red TL-D /15). An LED whose chromaticity has an
excitation purity >= `AMBER_MIN_PURITY` (against illuminant E) and a dominant
wavelength in `AMBER_DOMINANT_NM` (amber and yellow-filtered light for dark-sky
areas) is `led_amber`, subtype `direct_amber` (AlInGaP emitters: spectral
width at half maximum < `DIRECT_AMBER_MAX_WIDTH_NM`), `pc_amber` (broad, and a
blue pump leaks: >= `PC_AMBER_MIN_BLUE` of its visible power below 500 nm) or
`broad_amber` (broad without blue: a phosphor or a filtered white luminaire,
the spectrum cannot tell); the source's own label wins where it has one. Any
other LED off the white region
(|Duv| > 0.02 or CCT outside 1000-25000 K) is a coloured LED: no level-2
class, never scored. HPS lamps with CCT >= `WHITE_SON_MIN_CCT_K` are subtype
`white_son` (high-CRI HPS): their NIR extension is never flagged validated (no
measured White SON reaches 900 nm here).

**Deduplication rule** (`DUPLICATE_RMS`): two spectra, each normalised to unit
visible power and compared on 380-780 nm at 5 nm, are the same lamp when the
RMS of their difference is below 3 % of their mean value; the copy from the
source listed first in `SOURCE_PRIORITY` is kept (within a source, a copy with
documented provenance first). The rule runs across all sources, including
colour-science's CIE and NIST sets.
"""

import dataclasses
import functools
import json
import os
import warnings
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from ..photometry import CCT_MAX_K, CCT_MIN_K, K_M_LM_PER_W
from ..spectra import GRID_1NM, planck_radiance
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
SOURCE_PRIORITY = (
    "li1800",
    "nist_philips",
    "nist_traditional",
    "nist_led",
    "cie015",
    "color_pollution",
    "photobiology",
    "lspdd",
)
"""Which copy of a duplicate is kept: the first source listed. The old sources
come first so the ids other modules name (e.g. `nist_traditional_hps`) stay."""
NEVER_SCORED = ("led_rgb",)
AMBER_MIN_PURITY = 0.9
AMBER_DOMINANT_NM = (575.0, 610.0)
PC_AMBER_MIN_BLUE = 0.002
DIRECT_AMBER_MAX_WIDTH_NM = 40.0
WHITE_SON_MIN_CCT_K = 2300.0
EDGE_HOLD_NM = 5.0
LSPDD_ENV = "BANDOPT_LSPDD"

_DATA = Path(__file__).parent / "data"
_LI1800 = _DATA / "lamps_li1800"
_LSPDD = _DATA / "lamps_lspdd"
_PHOTOBIOLOGY = _DATA / "lamps_photobiology"
_COLOR_POLLUTION = _DATA / "lamps_color_pollution"

LICENCES = {
    "li1800": "GPL (>= 2)",
    "photobiology": "GPL (>= 2)",
    "lspdd": "CC BY-NC-ND 2.5 CA (verbatim, switchable)",
    "color_pollution": "MIT",
    "nist_philips": "NIST data via colour-science (BSD-3-Clause)",
    "nist_traditional": "NIST data via colour-science (BSD-3-Clause)",
    "nist_led": "NIST data via colour-science (BSD-3-Clause)",
    "cie015": "CIE 015:2018 data via colour-science (BSD-3-Clause)",
    "planck": "modelled",
}


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
    - `licence`: licence of the source data.
    - `provenance_documented`: the source documents instrument and lamp (False
      for most color-pollution files: line positions checked instead).
    - `subtype`: finer type where it matters (`pc_amber`, `direct_amber`,
      `white_son`) or None.
    - `nir_measured`: the spectrum itself is measured to the grid end (within
      `EDGE_HOLD_NM`), so nothing beyond 780 nm is modelled.
    - `nir_note`: where its values beyond 780 nm come from, and whether the
      extension of its technology has measured evidence.
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
    licence: str = ""
    provenance_documented: bool = True
    subtype: str | None = None
    nir_measured: bool = False
    nir_note: str = ""

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
    - `source_sets`: the collections the library was built from.
    """

    wavelength_nm: np.ndarray
    values: np.ndarray
    records: tuple[LampRecord, ...]
    insufficient: tuple[str, ...]
    removed: tuple[tuple[str, str], ...]
    source_sets: tuple[str, ...] = ()

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
                    "excluded": n_excl,
                    "cie_typical": sum(r.cie_typical for r in members),
                    "nir_measured": sum(
                        r.nir_measured and r.excluded is None for r in members
                    ),
                    "status": status,
                }
            )
        for l1 in LEVEL1:
            unclassed = [r for r in lamps if r.level2 is None and r.level1 == l1]
            if not unclassed:
                continue
            kinds = sorted({r.excluded.split(" (")[0] for r in unclassed if r.excluded})
            rows.append(
                {
                    "level1": l1,
                    "level2": None,
                    "lamps": len(unclassed),
                    "cie_typical": sum(r.cie_typical for r in unclassed),
                    "nir_measured": sum(r.nir_measured for r in unclassed),
                    "status": "excluded: " + "; ".join(kinds),
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


_LSPDD_CATEGORY = {
    "LED": None,  # decided by the spectrum (white warm/cool, amber, coloured)
    "CFL": "fluorescent_compact",
    "Halo": "incandescent_halogen",
    "INC": "incandescent_halogen",
    "MH": "metal_halide",
    "HPS": "hps",
    "FL": "fluorescent_linear",
}
"""LSPDD `category` -> level 2 (None: an LED, classified by its spectrum). The
categories "Standard Illuminant", "Biological Sensitivities" and "sun" are not
lamps and are not vendored (`_lamps_build.EXCLUDED_LSPDD_CATEGORIES`)."""

_HINT_LEVEL2 = {
    "led": None,
    "led_amber_direct": "led_amber",
    "led_amber_pc": "led_amber",
}
_HINT_SUBTYPE = {"led_amber_direct": "direct_amber", "led_amber_pc": "pc_amber"}


@dataclasses.dataclass
class _Raw:
    id: str
    name: str
    source: str
    source_set: str
    level2: str | None  # None: LED, decided by its spectrum
    wavelength_nm: np.ndarray
    values: np.ndarray  # energy units
    cie_typical: bool = False
    provenance_documented: bool = True
    subtype: str | None = None


def _colour_sources() -> list[_Raw]:
    # start-up time: colour takes ~1.5 s to import (only to build the library)
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
    return raws


def _li1800_sources() -> list[_Raw]:
    raws = []
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


def parse_lspdd_spectrum(text: str, where: str = "spectraldata") -> tuple:
    """Wavelengths [nm] and values of an LSPDD `spectraldata` CSV string.

    The records mix layouts: `300.00,1.3620E-005`, `300,0.0000024599`, and a
    decimal comma in the value (`273.5,0,00E+00` is 273.5 nm, 0.00). Lines that
    are empty or hold no pair (`,`, `:5`) are skipped; repeated wavelengths
    keep their first value; negative values (detector noise around zero) are
    clipped to 0.
    """
    lines = text.replace("\r", "").split("\n")
    if not lines or not lines[0].strip().lower().startswith("wavelength"):
        raise ValueError(f"{where}: expected a 'wavelength,...' header line.")
    w, v = [], []
    for line in lines[1:]:
        p = line.strip().split(",")
        if len(p) == 3:
            p = [p[0], f"{p[1]}.{p[2]}"]
        if len(p) != 2 or not p[0] or not p[1]:
            continue
        try:
            w.append(float(p[0]))
            v.append(float(p[1]))
        except ValueError as e:
            raise ValueError(f"{where}: cannot read line {line!r}.") from e
    w_arr, first = np.unique(np.array(w), return_index=True)
    v_arr = np.clip(np.array(v)[first], 0.0, None)
    if w_arr.size < 50:
        raise ValueError(f"{where}: only {w_arr.size} samples.")
    return w_arr, v_arr


def _lspdd_sources() -> list[_Raw]:
    raws = []
    for path in sorted(_LSPDD.glob("*.json"), key=lambda p: int(p.stem)):
        rec = json.loads(path.read_text())
        cat = rec.get("category")
        if cat not in _LSPDD_CATEGORY:
            raise ValueError(
                f"{path.name}: LSPDD category {cat!r} has no class; expected one "
                f"of {sorted(_LSPDD_CATEGORY)}."
            )
        w, v = parse_lspdd_spectrum(rec["spectraldata"], f"{path.name} spectraldata")
        label = " ".join(
            str(x)
            for x in (rec.get("brand"), rec.get("lamptype"), rec.get("name"))
            if x and str(x).strip() not in ("-", "")
        )
        raws.append(
            _Raw(
                f"lspdd_{int(rec['id'])}",
                f"LSPDD {rec['id']} {cat} {label}".strip(),
                "LSPDD2016",
                "lspdd",
                _LSPDD_CATEGORY[cat],
                w,
                v,
            )
        )
    return raws


def _long_csv(path: Path) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """`name,wavelength_nm,value` rows -> {name: (wavelength, value)}."""
    names = np.loadtxt(path, delimiter=",", skiprows=1, usecols=0, dtype=str)
    num = np.loadtxt(path, delimiter=",", skiprows=1, usecols=(1, 2))
    out = {}
    for name in dict.fromkeys(names):
        m = names == name
        out[str(name)] = (num[m, 0], num[m, 1])
    return out


def _photobiology_sources() -> list[_Raw]:
    meta = json.loads((_PHOTOBIOLOGY / "metadata.json").read_text())
    spectra = _long_csv(_PHOTOBIOLOGY / "spectra.csv")
    raws = []
    for name, (w, v) in spectra.items():
        hint = meta[name]["hint"]
        leds = meta[name]["object"] == "leds.mspct"
        raws.append(
            _Raw(
                f"photobiology_{_slug(name)}",
                name.replace("_", " ") if leds else name.replace(".", " "),
                "Aphalo2025leds" if leds else "Aphalo2025lamps",
                "photobiology",
                _HINT_LEVEL2.get(hint, hint),
                w,
                np.clip(v, 0.0, None),
                subtype=_HINT_SUBTYPE.get(hint),
            )
        )
    return raws


def _color_pollution_sources() -> list[_Raw]:
    meta = json.loads((_COLOR_POLLUTION / "metadata.json").read_text())
    spectra = _long_csv(_COLOR_POLLUTION / "spectra.csv")
    raws = []
    for name, (w, v) in spectra.items():
        hint = meta[name]["hint"]
        raws.append(
            _Raw(
                f"color_pollution_{_slug(name)}",
                f"color-pollution {name}",
                "Robinson2016",
                "color_pollution",
                _HINT_LEVEL2.get(hint, hint),
                w,
                np.clip(v, 0.0, None),
                provenance_documented=meta[name]["provenance_documented"],
                subtype=_HINT_SUBTYPE.get(hint),
            )
        )
    return raws


def lspdd_enabled(lspdd: bool | None = None) -> bool:
    """Whether the LSPDD set is used: the argument, else the environment
    variable `LSPDD_ENV` ("0", "false", "no", "off" switch it off), else on."""
    if lspdd is not None:
        return bool(lspdd)
    return os.environ.get(LSPDD_ENV, "1").strip().lower() not in (
        "0",
        "false",
        "no",
        "off",
    )


def _raw_sources(lspdd: bool = True) -> list[_Raw]:
    raws = _colour_sources() + _li1800_sources()
    raws += _color_pollution_sources() + _photobiology_sources()
    if lspdd:
        raws += _lspdd_sources()
    return raws


def _visible_5nm(w, s):
    grid = np.arange(380.0, 780.1, 5.0)
    v = np.interp(grid, w, s)
    return v / np.trapezoid(v, grid)


def _cct_duv(w, s):
    """CCT (Ohno 2013) and Duv with colour-science on the 1 nm-interpolated spectrum."""
    # start-up time: colour takes ~1.5 s to import (only to build the library)
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
    """Planck's law: `bandopt.spectra.planck_radiance`. [W m⁻² sr⁻¹ nm⁻¹]"""
    return planck_radiance(np.asarray(wavelength_nm, float), temperature_k)


MODELLED_INCANDESCENT_K = (2400.0, 2600.0, 2800.0, 3000.0, 3200.0)
MODELLED_FIRE_K = (700.0, 800.0, 900.0, 1000.0, 1100.0, 1200.0)


def _per_lumen(wavelength_nm, values):
    # start-up time: colour takes ~1.5 s to import
    from colour import SDS_LEFS

    v = SDS_LEFS["CIE 1924 Photopic Standard Observer"]
    vis = (wavelength_nm >= 380.0) & (wavelength_nm <= 780.0)
    w = wavelength_nm[vis]
    lum = K_M_LM_PER_W * np.trapezoid(values[vis] * v[w], w)
    return values / lum


def _colour_metrics(raws: list[_Raw]) -> dict[str, np.ndarray]:
    """CCT (Ohno 2013), Duv, excitation purity and dominant wavelength (against
    illuminant E) and the share of visible power below 500 nm, per spectrum,
    from its 1 nm-interpolated 380-780 nm part (same numbers as `_cct_duv`)."""
    # start-up time: colour takes ~1.5 s to import (only to build the library)
    import colour

    grid = np.arange(380.0, 781.0, 1.0)
    spd = np.array([np.interp(grid, r.wavelength_nm, r.values) for r in raws])
    cmfs = (
        colour.MSDS_CMFS["CIE 1931 2 Degree Standard Observer"]
        .copy()
        .trim(colour.SpectralShape(380.0, 780.0, 1.0))
    )
    xyz = spd @ cmfs.values
    uv = colour.UCS_to_uv(colour.XYZ_to_UCS(xyz))
    xy = colour.XYZ_to_xy(xyz)
    white = np.array([1.0 / 3.0, 1.0 / 3.0])
    with warnings.catch_warnings():
        # Colour warns when the nearest Planckian point is the table's end (the
        # red TL-D /15, 458 K; amber LEDs): flagged by their CCT range below.
        warnings.simplefilter("ignore", colour.utilities.ColourRuntimeWarning)
        cct_duv = np.atleast_2d(colour.temperature.uv_to_CCT_Ohno2013(uv))
    dom = np.array([float(colour.dominant_wavelength(c, white)[0]) for c in xy])
    purity = np.array([float(colour.excitation_purity(c, white)) for c in xy])
    blue = spd[:, grid < 500.0].sum(axis=1) / spd.sum(axis=1)
    width = (spd >= 0.5 * spd.max(axis=1, keepdims=True)).sum(axis=1) * 1.0
    return {
        "cct": cct_duv[:, 0],
        "duv": cct_duv[:, 1],
        "purity": purity,
        "dominant_nm": dom,
        "blue_share": blue,
        "width_nm": width,
    }


def _classify(r: _Raw, m: dict) -> tuple[str, str | None, str | None, str | None]:
    """(level1, level2, subtype, excluded) of one spectrum by the typology rules."""
    cct, duv = m["cct"], m["duv"]
    level2, subtype, excluded = r.level2, r.subtype, None
    white = abs(duv) <= COLOURED_DUV and CCT_MIN_K <= cct <= CCT_MAX_K
    if level2 is None:  # an LED: amber, white (warm/cool) or coloured
        lo, hi = AMBER_DOMINANT_NM
        if m["purity"] >= AMBER_MIN_PURITY and lo <= m["dominant_nm"] <= hi:
            level2 = "led_amber"
            if m["width_nm"] < DIRECT_AMBER_MAX_WIDTH_NM:
                subtype = "direct_amber"
            elif m["blue_share"] >= PC_AMBER_MIN_BLUE:
                subtype = "pc_amber"
            else:
                subtype = "broad_amber"
        elif not white:
            excluded = (
                f"coloured LED (|Duv| = {abs(duv):.3f}, CCT = {cct:.0f} K: beyond "
                f"|Duv| <= {COLOURED_DUV} and {CCT_MIN_K:g}-{CCT_MAX_K:g} K)"
            )
            return "led", None, None, excluded
        else:
            level2 = "led_warm" if cct <= LED_WARM_MAX_CCT_K else "led_cool"
    elif level2.startswith("fluorescent") and not white:
        excluded = (
            f"coloured tube (|Duv| = {abs(duv):.3f}, CCT = {cct:.0f} K: beyond "
            f"|Duv| <= {COLOURED_DUV} and {CCT_MIN_K:g}-{CCT_MAX_K:g} K)"
        )
        return "fluorescent", None, None, excluded
    elif level2 == "hps" and cct >= WHITE_SON_MIN_CCT_K:
        subtype = "white_son"
    if r.id in DATASHEET_LIKE:
        excluded = DATASHEET_LIKE[r.id]
    return LEVEL2_PARENT[level2], level2, subtype, excluded


DATASHEET_LIKE = {
    "color_pollution_pc_amber": "datasheet-like curve (Nichia NVSA219B: values to "
    "4 decimals, 400-800 nm, no instrument): kept for training, not a measured lamp",
}
"""Spectra that look like a manufacturer's typical curve, not a measurement:
in the library, never scored."""

LOW_FILL_MAX = 0.01
"""A spectrum that starts after 380 nm is filled with 0 below its first sample
only when that sample is below this fraction of its peak (PC_Amber.csv starts
at 400 nm at 0.1 % of peak); otherwise the build fails."""


def _dedup(raws: list[_Raw]) -> tuple[list[int], dict[int, list[str]], list]:
    order = sorted(
        range(len(raws)),
        key=lambda i: (
            SOURCE_PRIORITY.index(raws[i].source_set),
            not raws[i].provenance_documented,
        ),
    )
    shapes = np.array([_visible_5nm(r.wavelength_nm, r.values) for r in raws])
    kept: list[int] = []
    dup_of: dict[int, list[str]] = {}
    removed = []
    for i in order:
        if kept:
            ks = shapes[kept]
            rms = np.sqrt(np.mean((ks - shapes[i]) ** 2, axis=1))
            lim = DUPLICATE_RMS * np.mean((ks + shapes[i]) / 2, axis=1)
            hit = np.flatnonzero(rms < lim)
        else:
            hit = []
        if len(hit) == 0:
            kept.append(i)
        else:
            j = kept[int(hit[0])]
            dup_of.setdefault(j, []).append(raws[i].id)
            removed.append((raws[i].id, raws[j].id))
    kept.sort()
    return kept, dup_of, removed


def _nir_note(extended, measured, tech, validated, end_nm, quality=None):
    if measured:
        if quality:
            return f"measured to {end_nm:g} nm; not NIR evidence: {quality}"
        return f"measured to {end_nm:g} nm"
    if not extended:
        return "beyond the measured range: unknown (NaN), extension off"
    if validated:
        return (
            f"extended beyond {end_nm:g} nm ({tech}); the extension of this "
            "technology is validated leave-one-out on measured spectra"
        )
    return (
        f"extended beyond {end_nm:g} nm ({tech}); no leave-one-out validation on "
        "measured spectra of this class (see results/library/nir_validation.json)"
    )


@functools.cache
def _classified(lspdd: bool) -> tuple:
    """Raw spectra, their classification, and the deduplication (cached)."""
    raws = _raw_sources(lspdd)
    metrics = _colour_metrics(raws)
    classified = [
        _classify(r, {k: v[i] for k, v in metrics.items()}) for i, r in enumerate(raws)
    ]
    kept, dup_of, removed = _dedup(raws)
    return raws, classified, kept, dup_of, removed


NIR_CLIPPED_MAX = 0.2
NIR_RISING_EDGE = 2.0


def nir_quality(wavelength_nm: np.ndarray, values: np.ndarray) -> str | None:
    """Why a spectrum measured to 900 nm cannot serve as near-infrared evidence,
    or None. Two screens, both seen in LSPDD records:

    - *clipped*: more than `NIR_CLIPPED_MAX` of its 700-900 nm samples are
      exactly 0 (background subtracted and clipped: a real tail and a clipped
      one cannot be told apart);
    - *rising edge*: the 850-900 nm median exceeds `NIR_RISING_EDGE` times the
      800-850 nm median and 0.5 % of peak (a detector edge artefact: no lamp
      class here rises that fast; a 2800 K Planck spectrum rises 1.05x).
    """
    w, s = np.asarray(wavelength_nm, float), np.asarray(values, float)
    tail = (w >= 700.0) & (w <= 900.0)
    zero = float(np.mean(s[tail] == 0.0))
    if zero > NIR_CLIPPED_MAX:
        return f"clipped ({zero:.0%} of the 700-900 nm samples are 0)"
    hi = float(np.median(s[(w >= 850.0) & (w <= 900.0)]))
    mid = float(np.median(s[(w >= 800.0) & (w < 850.0)]))
    if hi > NIR_RISING_EDGE * mid and hi > 0.005 * s.max():
        return (
            f"rising edge (850-900 nm median {hi / s.max():.1%} of peak, "
            f"{hi / max(mid, 1e-300):.1f}x the 800-850 nm median)"
        )
    return None


def measured_nir_spectra(lspdd: bool | None = None) -> list[dict]:
    """The library's distinct lamps measured to 900 nm (within `EDGE_HOLD_NM`),
    not excluded, on their native wavelengths: the calibration and validation
    set of `bandopt.datasets.nir` (`nir_quality` None only; the others are
    returned with their reason, for the record). Each: id, level1, level2,
    subtype, technology, source_set, nir_quality, wavelength_nm, values."""
    raws, classified, kept, _, _ = _classified(lspdd_enabled(lspdd))
    out = []
    for i in kept:
        r = raws[i]
        level1, level2, subtype, excluded = classified[i]
        if excluded or r.wavelength_nm[-1] < nir.EXTENSION_END_NM - EDGE_HOLD_NM:
            continue
        out.append(
            {
                "id": r.id,
                "level1": level1,
                "level2": level2,
                "subtype": subtype,
                "technology": nir.technology_of(level2, level1),
                "source_set": r.source_set,
                "nir_quality": nir_quality(r.wavelength_nm, r.values),
                "wavelength_nm": r.wavelength_nm,
                "values": r.values,
            }
        )
    return out


def classes_with_measured_nir(lspdd: bool | None = None) -> frozenset[str]:
    """Level-2 classes with at least one lamp whose measured near-infrared is
    usable evidence (`nir_quality` None). An extended lamp of any other class
    is never flagged validated, whatever its technology."""
    return frozenset(
        m["level2"]
        for m in measured_nir_spectra(lspdd)
        if m["nir_quality"] is None and m["level2"] is not None
    )


@functools.cache
def _build(
    extend_nir: bool, grid_key: tuple[float, float, float], lspdd: bool = True
) -> LampLibrary:
    lo, hi, step = grid_key
    grid = np.arange(lo, hi + step / 2, step)
    raws, classified, kept, dup_of, removed = _classified(lspdd)
    with_nir = classes_with_measured_nir(lspdd)

    values, records = [], []
    for i in kept:
        r = raws[i]
        level1, level2, subtype, excluded = classified[i]
        w, s = r.wavelength_nm, r.values
        start, end = float(w[0]), float(w[-1])
        row = np.full(grid.shape, np.nan)
        inside = (grid >= start) & (grid <= end)
        row[inside] = np.interp(grid[inside], w, s)
        below = grid < start
        if below.any():
            if s[0] > LOW_FILL_MAX * s.max():
                raise ValueError(
                    f"{r.id}: spectrum starts at {start:g} nm at "
                    f"{s[0] / s.max():.1%} of peak; cannot fill 380-{start:g} nm."
                )
            row[below] = 0.0
        beyond = grid > end
        measured_nir = bool(end >= hi - EDGE_HOLD_NM and hi > nir.EXTENSION_START_NM)
        extended, validated = False, None
        tech = nir.technology_of(level2, level1)
        if beyond.any() and measured_nir:
            row[beyond] = s[-1]  # hold the last sample over < EDGE_HOLD_NM
        elif beyond.any() and extend_nir:
            row[beyond] = nir.extend_spectrum(w, s, tech, grid[beyond], lspdd=lspdd)
            extended = True
            validated = (
                nir.is_validated(tech) and subtype != "white_son" and level2 in with_nir
            )
        quality = nir_quality(w, s) if measured_nir else None
        note = (
            _nir_note(extended, measured_nir, tech, validated, end, quality)
            if beyond.any() or measured_nir
            else ""
        )
        if subtype == "white_son" and extended:
            note += "; White SON (high-CRI HPS): the HPS calibration is standard HPS"
        elif extended and level2 not in with_nir:
            note += f"; no measured near-infrared for class {level2} here"
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
                measured_range_nm=(start, end),
                extended=extended,
                extension_validated=validated,
                modelled=False,
                cie_typical=r.cie_typical,
                excluded=excluded,
                duplicates=tuple(dup_of.get(i, ())),
                licence=LICENCES[r.source_set],
                provenance_documented=r.provenance_documented,
                subtype=subtype,
                nir_measured=measured_nir,
                nir_note=note,
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
                licence=LICENCES["planck"],
                nir_note="modelled (Planck's law)",
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
    sets = tuple(dict.fromkeys(r.source_set for r in raws))
    return LampLibrary(
        grid, values_arr, tuple(records), insufficient, tuple(removed), sets
    )


def library(
    *,
    extend_nir: bool = True,
    wavelength_nm: Sequence[float] | np.ndarray = GRID_1NM,
    lspdd: bool | None = None,
) -> LampLibrary:
    """The lamp library on a uniform grid (default 380-900 nm at 1 nm).

    `extend_nir=False` leaves values beyond each spectrum's measured range NaN
    (unknown), so a band reaching there fails loudly rather than reading zeros.
    `lspdd=False` (or the environment variable `BANDOPT_LSPDD=0` when `lspdd`
    is None) builds it without the LSPDD set (CC BY-NC-ND). Built once per
    argument set and cached in memory.
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
    return _build(
        bool(extend_nir),
        (float(w[0]), float(w[-1]), float(step[0])),
        lspdd_enabled(lspdd),
    )
