"""The readers of the lamp library's measured spectra, one per source set.

Each source (colour-science's NIST and CIE tables, the LI-1800 files, LSPDD
records, the photobiology and color-pollution sets, the IES TM-30-15 set)
becomes a list of `_Raw` spectra labelled with the level-2 class the source
states (None: an LED, classified by its spectrum in `_lamp_sources`).
`_raw_sources` joins them. A module of its own so that `_lamp_sources` holds
the typology, its rules and the deduplication, not the file formats; it
imports nothing of the library above the loaders, and `_lamp_sources`
re-exports the names other modules and tests use.
"""

import csv
import dataclasses
import json
import warnings
from pathlib import Path

import numpy as np

from .loaders import SpectrumWarning, read_prn


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


def color_pollution_measured() -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """The colour-pollution set's spectra as measured, on their own grid:
    {name: (wavelength [nm], relative value)} (`Robinson2016`); for checks
    of line positions, before any resampling."""
    return _long_csv(_COLOR_POLLUTION / "spectra.csv")


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
