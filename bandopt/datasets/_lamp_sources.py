"""The lamp library's measured spectra: read, classified, deduplicated, screened.

The part of `bandopt.datasets.lamps` that needs no near-infrared model: the
source loaders, the two-level typology (`LEVEL1`, `LEVEL2`) and its rules, the
deduplication across sources, and the lamps measured to 900 nm
(`measured_nir_spectra`, screened by `nir_quality`). `bandopt.datasets.lamps`
describes the sources, the typology and the deduplication rule, and
re-exports every public name here; import them from there.

It is a module of its own so that the import graph is one-way:
`bandopt.datasets.nir` calibrates and validates its near-infrared extension on
these measured spectra, and `lamps` extends the spectra measured only to
780-850 nm with `nir`. So `_lamp_sources` <- `nir` <- `lamps`: this module
never imports `nir` or `lamps` (checked by `tests/test_imports.py`). The
extension range (`EXTENSION_START_NM`, `EXTENSION_END_NM`) and the extension
technology of a class (`technology_of`) are here because the measured spectra
are selected and labelled with them; `nir` re-exports them.
"""

import csv
import dataclasses
import functools
import json
import os
import warnings
from pathlib import Path

import numpy as np

from ..photometry import CCT_MAX_K, CCT_MIN_K
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
    "ies_tm30",
)
"""Which copy of a duplicate is kept: the first source listed. The old sources
come first so the ids other modules name (e.g. `nist_traditional_hps`) stay;
the IES TM-30-15 set (only with `tm30=True`) comes last, so it never displaces
a lamp of the default library."""
AMBER_MIN_PURITY = 0.9
AMBER_DOMINANT_NM = (575.0, 610.0)
PC_AMBER_MIN_BLUE = 0.002
DIRECT_AMBER_MAX_WIDTH_NM = 40.0
WHITE_SON_MIN_CCT_K = 2300.0
EDGE_HOLD_NM = 5.0
LSPDD_ENV = "BANDOPT_LSPDD"

EXTENSION_START_NM = 780.0
EXTENSION_END_NM = 900.0
"""The near-infrared extension of `bandopt.datasets.nir` covers (780, 900] nm."""

_TECHNOLOGY = {
    "hps": "hps",
    "lps": "lps",
    "metal_halide": "metal_halide",
    "mercury": "mercury",
    "fluorescent_linear": "fluorescent",
    "fluorescent_compact": "fluorescent",
    "incandescent_halogen": "incandescent",
    "led_warm": "led",
    "led_cool": "led",
    "led_amber": "led",
    "led_rgb": "led",
}


def technology_of(level2: str | None, level1: str | None = None) -> str | None:
    """The extension technology for a level-2 class (None: no extension). Every
    LED class, amber included, is `led`: an amber LED is never given sodium lines."""
    if level2 in _TECHNOLOGY:
        return _TECHNOLOGY[level2]
    return {
        "fluorescent": "fluorescent",
        "led": "led",
        "incandescent": "incandescent",
        "lps": "lps",
    }.get(level1 or "")


_DATA = Path(__file__).parent / "data"
_LI1800 = _DATA / "lamps_li1800"
_LSPDD = _DATA / "lamps_lspdd"
_PHOTOBIOLOGY = _DATA / "lamps_photobiology"
_COLOR_POLLUTION = _DATA / "lamps_color_pollution"
_IES_TM30 = _DATA / "lamps_ies_tm30"


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


TM30_MEASURED = ("Commercial", "Experimental")
"""`category` values of the IES TM-30-15 set that are measured sources (the
others are `Model` and `Theoretical`: computed spectra, never read)."""

_TM30_TYPE = {
    "Fluorescent Broadband": "fluorescent_linear",
    "Fluorescent Narrowband": "fluorescent_linear",
    "Incandescent/Filament": "incandescent_halogen",
    "LED Phosphor": None,
    "LED Hybrid": None,
    "LED Mixed": "led_rgb",
}
"""IES TM-30-15 `type` -> level 2 (None: an LED, classified by its spectrum
like the library's other LEDs). Every fluorescent entry is a linear tube
(F32T8, F34T12, F40T12); "Incandescent/Filament" holds halogen, incandescent
and filtered (neodymium) filament lamps, as the library's class does. High
intensity discharge lamps are classified by name (`_TM30_HID`); the type
"Other" (a plasma lamp) is not a class of the library and is not read."""

_TM30_HID = (("HPS", "hps"), ("Metal Halide", "metal_halide"), ("Mercury", "mercury"))
"""Name fragment -> level 2 of the IES TM-30-15 "High Intensity Discharge"
entries (e.g. "C100S54 (1) - HPS Standard", "CDM 830 (1) - Metal Halide")."""


def _tm30_level2(name: str, kind: str) -> str | None:
    if kind == "High Intensity Discharge":
        for key, level2 in _TM30_HID:
            if key in name:
                return level2
        raise ValueError(
            f"{_IES_TM30 / 'IESTM30_15_Sinfo.txt'}: discharge lamp {name!r} is "
            "neither HPS, metal halide nor mercury."
        )
    return _TM30_TYPE[kind]


def _tm30_sources() -> list[_Raw]:
    """The measured lamps of the IES TM-30-15 set (`IES2015`, vendored from
    LuxPy, `Smet2020`): every `TM30_MEASURED` entry of a lamp technology
    (`_TM30_TYPE`, `_TM30_HID`), ids `ies_tm30_<nr>_<name>`."""
    spd_path = _IES_TM30 / "IESTM30_15_Sspds.dat"
    info_path = _IES_TM30 / "IESTM30_15_Sinfo.txt"
    data = np.atleast_2d(np.loadtxt(spd_path, delimiter=","))
    with info_path.open(newline="") as fh:
        rows = [r for r in csv.reader(fh)][1:]
    if data.shape[1] != len(rows) + 1:
        raise ValueError(
            f"{spd_path}: {data.shape[1] - 1} spectra for the {len(rows)} sources "
            f"of {info_path.name}."
        )
    w = data[:, 0]
    if np.any(np.diff(w) <= 0) or w[0] > 380.0 or w[-1] < 780.0:
        raise ValueError(f"{spd_path}: wavelength column must rise over 380-780 nm.")
    raws = []
    for j, r in enumerate(rows):
        if len(r) < 4:
            raise ValueError(f"{info_path}: row {j + 2} has {len(r)} fields, not 4.")
        nr, name, kind, category = (x.strip() for x in r[:4])
        if category not in TM30_MEASURED or kind == "Other":
            continue
        if kind not in _TM30_TYPE and kind != "High Intensity Discharge":
            raise ValueError(f"{info_path}: row {j + 2}: unknown type {kind!r}.")
        values = data[:, j + 1].copy()
        if np.any(values < 0) or not np.any(values > 0):
            raise ValueError(
                f"{spd_path}: source {nr} ({name}) has negative or no power."
            )
        raws.append(
            _Raw(
                f"ies_tm30_{int(nr):03d}_{_slug(name)}",
                name,
                "IES2015",
                "ies_tm30",
                _tm30_level2(name, kind),
                w.copy(),
                values,
            )
        )
    return raws


def _raw_sources(lspdd: bool = True, tm30: bool = False) -> list[_Raw]:
    raws = _colour_sources() + _li1800_sources()
    raws += _color_pollution_sources() + _photobiology_sources()
    if lspdd:
        raws += _lspdd_sources()
    if tm30:
        raws += _tm30_sources()
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


@functools.cache
def _classified(lspdd: bool, tm30: bool = False) -> tuple:
    """Raw spectra, their classification, and the deduplication (cached)."""
    raws = _raw_sources(lspdd, tm30)
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


TRUNCATION_MIN_NM = 700.0
"""A run of negligible samples (`TRUNCATION_LEVEL`) to the end of a spectrum
after a larger sample at or beyond this wavelength is the end of the
measurement (data truncated, clipped or rounded away and written as zeros:
the NIST phosphor LED tables from 720-775 nm, the clipped tails of LSPDD
records), not a measured darkness: every lamp class here emits a smooth red
or near-infrared tail or lines there. A dark gap that starts earlier
(low-pressure sodium is dark from 590 nm to 780 nm in the tabulated NIST
spectrum) is kept as data."""

TRUNCATION_LEVEL = 1e-5
"""Samples at or below this fraction of a spectrum's peak count as zeros for
`measured_end`: the last decimal of the NIST and CIE tables read relative to
their peak (five decimals); the NIST phosphor LED tables fall from this level
to 1e-12 within 10-50 nm, faster than any measured tail here."""


def measured_end(wavelength_nm: np.ndarray, values: np.ndarray) -> float:
    """The last measured wavelength of a spectrum [nm]: the last sample above
    `TRUNCATION_LEVEL` of the peak when only samples at or below it follow and
    it lies at or beyond `TRUNCATION_MIN_NM`, else the last sample."""
    w, s = np.asarray(wavelength_nm, float), np.asarray(values, float)
    above = np.flatnonzero(s > TRUNCATION_LEVEL * s.max()) if s.max() > 0 else []
    if len(above) == 0 or above[-1] == s.size - 1:
        return float(w[-1])
    last = float(w[above[-1]])
    return last if last >= TRUNCATION_MIN_NM else float(w[-1])


CONTAMINATION_MAX_FRACTION = 0.1
"""A spectrum whose near-infrared rises like a detector edge or stray light
(`nir_quality` "rising edge") carries that rising component into the visible;
where the component, extrapolated downwards, reaches this fraction of the
measured value below 780 nm, the visible part is contaminated and the
component is subtracted. Below it the component changes the spectrum by less
than 10 % and falls exponentially towards shorter wavelengths; the 700-780 nm
part holds a few per cent of the visible power and little luminous flux, so
what is left moves a lamp's luminous efficacy by well under 1 %."""

CONTAMINATION_FIT_NM = (800.0, 895.0)
"""The rising component is the exponential fitted (least squares on the
logarithm of the positive samples) to this range of a spectrum flagged as a
rising edge, where it dominates: its 850-900 nm median is at least
`NIR_RISING_EDGE` times its 800-850 nm median by that flag. [nm]"""

CUT_MIN_NM = 650.0
"""No spectrum is corrected, or cut to be continued by a near-infrared
extension, below this wavelength: below it every class has features
(phosphor peaks, the Eu 611 nm and the 650-710 nm lines of fluorescent tubes)
that neither a tail model nor an extrapolated background knows. A lamp whose
contamination reaches below it is excluded from scoring."""


def rising_component(
    wavelength_nm: np.ndarray, values: np.ndarray
) -> np.ndarray | None:
    """The rising near-infrared component of a spectrum flagged "rising edge"
    by `nir_quality`, on its own wavelengths: the exponential fitted over
    `CONTAMINATION_FIT_NM`; None when the spectrum is not flagged so or the
    fit does not rise. [unit of `values`]"""
    w, s = np.asarray(wavelength_nm, float), np.asarray(values, float)
    quality = nir_quality(w, s) if w[-1] >= CONTAMINATION_FIT_NM[1] else None
    if not (quality and quality.startswith("rising edge")):
        return None
    lo, hi = CONTAMINATION_FIT_NM
    fit = (w >= lo) & (w <= hi) & (s > 0.0)
    slope, intercept = np.polyfit(w[fit], np.log(s[fit]), 1)
    if slope <= 0.0:
        return None
    return np.exp(intercept + slope * w)


def contamination_start(wavelength_nm: np.ndarray, values: np.ndarray) -> float | None:
    """Where the rising component (`rising_component`) of a spectrum first
    reaches `CONTAMINATION_MAX_FRACTION` of the measured value in 380-780 nm:
    the sample before that crossing [nm]; None when it never does (or the
    spectrum has no such component)."""
    w, s = np.asarray(wavelength_nm, float), np.asarray(values, float)
    component = rising_component(w, s)
    if component is None:
        return None
    vis = (w >= 380.0) & (w <= EXTENSION_START_NM)
    over = np.flatnonzero(vis & (component >= CONTAMINATION_MAX_FRACTION * s))
    if over.size == 0:
        return None
    return float(w[max(over[0] - 1, 0)])


MERCURY_PLATEAU_RATIO = 3.0
"""Samples from 760 nm on that exceed this multiple of the 760 nm level of a
mercury lamp are the 765-780 nm plateau artefact (8.7-12x in two NIST Philips
spectra): no Hg I line is strong there, and the two other mercury spectra here
(NIST traditional, color-pollution HgV measured to 930 nm) are flat within
1.3x over 740-790 nm."""

MERCURY_PLATEAU_FROM_NM = 760.0
"""Where the plateau screen of `plateau_start` starts. [nm]"""


def plateau_start(wavelength_nm: np.ndarray, values: np.ndarray) -> float | None:
    """The last sample before the 765-780 nm plateau artefact of a mercury
    spectrum (first sample beyond `MERCURY_PLATEAU_FROM_NM` above
    `MERCURY_PLATEAU_RATIO` times the level there) [nm], or None."""
    w, s = np.asarray(wavelength_nm, float), np.asarray(values, float)
    if w[-1] <= MERCURY_PLATEAU_FROM_NM or w[0] >= MERCURY_PLATEAU_FROM_NM:
        return None
    ref = float(np.interp(MERCURY_PLATEAU_FROM_NM, w, s))
    after = np.flatnonzero(
        (w > MERCURY_PLATEAU_FROM_NM)
        & (w <= EXTENSION_START_NM)
        & (s > MERCURY_PLATEAU_RATIO * ref)
    )
    if after.size == 0 or ref <= 0.0:
        return None
    return float(w[after[0] - 1])


@dataclasses.dataclass(frozen=True)
class UsableRange:
    """The part of a source spectrum the library keeps as measured.

    - `end_nm`: the last kept wavelength; beyond it the library extends. [nm]
    - `values`: the source values on the source's wavelengths, with a rising
      background subtracted where one was found (else the source values).
    - `reason`: why it ends before the source's last sample or was corrected
      (None: neither).
    - `excluded`: reason to keep the lamp out of scoring (None: no reason).
    """

    end_nm: float
    values: np.ndarray = dataclasses.field(repr=False, compare=False)
    reason: str | None = None
    excluded: str | None = None


def usable_range(
    wavelength_nm: np.ndarray, values: np.ndarray, level2: str | None
) -> UsableRange:
    """Where the measured part of a spectrum that the library keeps ends, and
    why. The rules, applied in turn, each only shortening it:

    1. trailing zeros end the measurement (`measured_end`);
    2. near-infrared that `nir_quality` rejects is not kept: the spectrum is
       cut at 780 nm (`EXTENSION_START_NM`);
    3. a rising component reaching `CONTAMINATION_MAX_FRACTION` of the
       spectrum below 780 nm (`contamination_start`) is subtracted (it is
       fitted where it dominates, `rising_component`); where it reaches that
       fraction below `CUT_MIN_NM` the lamp is excluded from scoring;
    4. a mercury spectrum's 765-780 nm plateau (`plateau_start`) is cut.
    """
    w, s = np.asarray(wavelength_nm, float), np.asarray(values, float)
    end, reasons, excluded = float(w[-1]), [], None
    last = measured_end(w, s)
    if last < end:
        end = last
        reasons.append(
            f"zeros (<= {TRUNCATION_LEVEL:g} of peak) from {last:g} nm to the end: "
            "end of measurement"
        )
    measured_nir = w[-1] >= EXTENSION_END_NM - EDGE_HOLD_NM
    quality = nir_quality(w, s) if measured_nir else None
    if quality:
        end = min(end, EXTENSION_START_NM)
        reasons.append(f"measured NIR rejected, not NIR evidence: {quality}")
    start = contamination_start(w, s)
    if start is not None:
        s = np.clip(s - rising_component(w, s), 0.0, None)
        reasons.append(
            f"a rising background reaches {CONTAMINATION_MAX_FRACTION:.0%} of the "
            f"spectrum beyond {start:g} nm: the exponential fitted over "
            f"{CONTAMINATION_FIT_NM[0]:g}-{CONTAMINATION_FIT_NM[1]:g} nm subtracted"
        )
        if start < CUT_MIN_NM:
            excluded = (
                f"visible part contaminated (a rising background reaches "
                f"{CONTAMINATION_MAX_FRACTION:.0%} of the spectrum at {start:g} nm, "
                f"below {CUT_MIN_NM:g} nm)"
            )
    if level2 == "mercury":
        plateau = plateau_start(w, s)
        if plateau is not None and plateau < end:
            end = plateau
            reasons.append(
                f"765-780 nm plateau (> {MERCURY_PLATEAU_RATIO:g}x the "
                f"{MERCURY_PLATEAU_FROM_NM:g} nm level): an artefact, cut at "
                f"{plateau:g} nm"
            )
    return UsableRange(end, s, "; ".join(reasons) or None, excluded)


def measured_nir_spectra(lspdd: bool | None = None) -> list[dict]:
    """The library's distinct lamps measured to 900 nm (within `EDGE_HOLD_NM`),
    not excluded, on their native wavelengths: the calibration and validation
    set of `bandopt.datasets.nir` (`nir_quality` None only; the others are
    returned with their reason, for the record). Trailing zeros end a
    measurement (`measured_end`): a spectrum is measured to 900 nm when its
    last positive sample is, and is returned up to that sample. Each: id,
    level1, level2, subtype, technology, source_set, nir_quality,
    wavelength_nm, values."""
    raws, classified, kept, _, _ = _classified(lspdd_enabled(lspdd))
    out = []
    for i in kept:
        r = raws[i]
        level1, level2, subtype, excluded = classified[i]
        end = measured_end(r.wavelength_nm, r.values)
        if excluded or end < EXTENSION_END_NM - EDGE_HOLD_NM:
            continue
        out.append(
            {
                "id": r.id,
                "level1": level1,
                "level2": level2,
                "subtype": subtype,
                "technology": technology_of(level2, level1),
                "source_set": r.source_set,
                "nir_quality": nir_quality(r.wavelength_nm, r.values),
                "wavelength_nm": r.wavelength_nm[r.wavelength_nm <= end],
                "values": r.values[r.wavelength_nm <= end],
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
