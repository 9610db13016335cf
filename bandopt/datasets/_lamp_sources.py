"""The lamp library's measured spectra: read, classified, deduplicated, screened.

The part of `bandopt.datasets.lamps` that needs no near-infrared model: the
source loaders, the two-level typology (`LEVEL1`, `LEVEL2`) and its rules, the
deduplication across sources, and the lamps measured to 900 nm
(`measured_nir_spectra`, screened by `nir_quality`). `bandopt.datasets.lamps`
describes the sources, the typology and the deduplication rule, and
re-exports every public name here; import them from there. The readers of the
source files are in `_lamp_readers` and the screens of a spectrum's red and
near-infrared end (with the extension range, `EXTENSION_START_NM`,
`EXTENSION_END_NM`) in `_lamp_screens`; both are re-exported here.

It is a module of its own so that the import graph is one-way:
`bandopt.datasets.nir` calibrates and validates its near-infrared extension on
these measured spectra, and `lamps` extends the spectra measured only to
780-850 nm with `nir`. So `_lamp_sources` <- `nir` <- `lamps`: this module and
its two helpers never import `nir` or `lamps` (checked by
`tests/test_imports.py`). The extension range and the extension technology of
a class (`technology_of`) are here because the measured spectra are selected
and labelled with them; `nir` re-exports them.
"""

import functools
import os
import warnings

import numpy as np

from ..photometry import CCT_MAX_K, CCT_MIN_K
from ._lamp_readers import (
    _COLOR_POLLUTION as _COLOR_POLLUTION,
    _LSPDD as _LSPDD,
    TM30_MEASURED as TM30_MEASURED,
    _long_csv as _long_csv,
    _Raw,
    _raw_sources,
    _tm30_level2 as _tm30_level2,
    _tm30_sources as _tm30_sources,
    color_pollution_measured as color_pollution_measured,
    parse_lspdd_spectrum as parse_lspdd_spectrum,
)
from ._lamp_screens import (
    CONTAMINATION_FIT_NM as CONTAMINATION_FIT_NM,
    CONTAMINATION_MAX_FRACTION as CONTAMINATION_MAX_FRACTION,
    CUT_MIN_NM as CUT_MIN_NM,
    EDGE_HOLD_NM,
    EXTENSION_END_NM,
    EXTENSION_START_NM as EXTENSION_START_NM,
    MERCURY_PLATEAU_FROM_NM as MERCURY_PLATEAU_FROM_NM,
    MERCURY_PLATEAU_RATIO as MERCURY_PLATEAU_RATIO,
    NIR_CLIPPED_MAX as NIR_CLIPPED_MAX,
    NIR_RISING_EDGE as NIR_RISING_EDGE,
    TRUNCATION_LEVEL as TRUNCATION_LEVEL,
    TRUNCATION_MIN_NM as TRUNCATION_MIN_NM,
    UsableRange as UsableRange,
    contamination_start as contamination_start,
    measured_end,
    nir_quality,
    plateau_start as plateau_start,
    rising_component as rising_component,
    usable_range as usable_range,
)


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
LSPDD_ENV = "BANDOPT_LSPDD"


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
    return _classes_with_measured_nir(lspdd_enabled(lspdd))


@functools.cache
def _classes_with_measured_nir(lspdd: bool) -> frozenset[str]:
    """`classes_with_measured_nir` for a resolved LSPDD setting, computed once
    per process: it screens every measured spectrum (`measured_nir_spectra`,
    ~45 ms) and `bandopt.datasets.nir.extension_error` asks it for every
    near-infrared variant of every lamp a prior holds (thousands per fit).
    The spectra it reads are themselves cached (`_classified`), so the answer
    cannot change within a process; the result is immutable."""
    return frozenset(
        m["level2"]
        for m in measured_nir_spectra(lspdd)
        if m["nir_quality"] is None and m["level2"] is not None
    )
