"""A lamp's technology from robust features of its visible spectrum, and the
near-infrared extension of a user's spectrum by that technology.

The technologies are those of `bandopt.datasets.nir.TECHNOLOGIES` (the NIR
models). The features are physical: the mercury lines at 404.7, 435.8, 546.1
and 577.0/579.1 nm (NIST ASD air wavelengths, `NISTASD`), the sodium D lines
(589.0/589.6 nm) and the pressure-broadened sodium band of high-pressure
sodium lamps, the Eu³⁺ 611 nm line of rare-earth (tri-phosphor) fluorescent
lamps, the Tl 535 nm line of metal halide lamps, the blue pump and broad
phosphor of white LEDs, and the smooth red-rising continuum of a filament
(Planck's law, `Planck1901`). Each is measured as a power fraction, a width or
a line's prominence over its local continuum, so that it survives what real
measurements hold: noise (SNR 30 per nm), a flat background of a few percent
of the visible power, 2-10 nm resolution and wavelength shifts of 1-2 nm.

The spectrum is first put on a 1 nm grid over 380-780 nm, divided by its mean
there (so every level below is in units of the mean visible level) and
smoothed by a Gaussian of `SMOOTH_FWHM_NM`. A line's *prominence* is its
height above the grey opening of the spectrum (a morphological baseline that
follows every feature wider than `BASELINE_WIDTH_NM`) divided by that baseline
plus `PROMINENCE_GUARD`.

Scores are products of soft thresholds (logistic steps) on these features,
one product per technology, normalised to sum to 1; `identify_technology`
names the top one unless the evidence is ambiguous (`AMBIGUITY_RATIO`).
No lamp spectrum trained any threshold: each sits between the physical
values of the technologies it separates, and `tests/test_technology.py`
checks the result on the library's lamps, clean and perturbed.
"""

import dataclasses
from pathlib import Path

import numpy as np
from scipy.ndimage import gaussian_filter1d, grey_opening
from scipy.signal import find_peaks, peak_widths

from ..names import CanonicalMapping
from ..spectra import GRID_1NM, planck_radiance
from . import nir as nir_models
from .loaders import read_spectrum


VISIBLE_NM = (380.0, 780.0)
"""The analysed range: every user spectrum covers it (`evaluate` refuses
others). [nm]"""

SMOOTH_FWHM_NM = 3.0
"""Gaussian smoothing before any feature: it averages spectrometer noise over
~3 samples (SNR 30 per nm becomes ~50) and barely widens a line measured at
2-10 nm resolution. [nm]"""

BASELINE_WIDTH_NM = 21
"""Width of the grey opening that is the local continuum: wider than a line at
10 nm resolution (whose base spans ~20 nm), so a line stands above it, but
comparable to an LED band (FWHM >= 15 nm), which the opening mostly follows.
[nm, odd number of 1 nm samples]"""

PROMINENCE_GUARD = 0.05
"""Added to the local continuum before dividing by it, in units of the mean
visible level: a line over (nearly) zero continuum gets a finite prominence,
and a flat background of 2 % of the visible power (0.02) changes no
prominence by more than a factor 1.4. [1]"""

LINE_TOLERANCE_NM = 3.0
"""A line is looked for within this distance of its wavelength: covers a 2 nm
wavelength-scale error plus the shift of a blended doublet's centroid. [nm]"""

NARROW_PEAK_MAX_FWHM_NM = 12.5
"""A peak of the smoothed spectrum at most this wide (at half its prominence)
is a line: an atomic line reads <= 11 nm at 10 nm resolution after
`SMOOTH_FWHM_NM`, while the narrowest LED band (direct amber, 14-15 nm) reads
>= 15 nm. [nm]"""

NARROW_PEAK_MIN_PROMINENCE = 0.15
"""Smallest prominence (in units of the mean visible level) of a counted line:
~7 noise standard deviations at SNR 30 per nm after smoothing. [1]"""

HG_LINES_NM = {"Hg 405": 404.66, "Hg 436": 435.83, "Hg 546": 546.07}
"""The three strong visible Hg I lines of every mercury-bearing lamp
(fluorescent, mercury vapour, most metal halide), NIST ASD air wavelengths."""

HG_YELLOW_NM = 578.0
"""Centre of the Hg I 576.96/579.07 nm yellow doublet (read as one line at
>= 2 nm resolution). [nm]"""

EU_RED_NM = 611.0
"""The Eu³⁺ (Y₂O₃:Eu) 611-612 nm line of tri-phosphor fluorescent lamps. [nm]"""

TL_GREEN_NM = 535.05
"""The Tl I 535.05 nm line of sodium-thallium-indium metal halide lamps. [nm]"""

NA_D_NM = 589.3
"""Centre of the Na I D doublet (588.99/589.59 nm). [nm]"""

HG_MIN_PROMINENCE = 0.5
"""An Hg line is present when it stands at least half its continuum level
above it (and `NARROW_PEAK_MIN_PROMINENCE` above it in absolute terms): 90 %
of the library's fluorescent lamps show Hg 436 at >= 2 and halophosphate
tubes keep >= 0.5 at 10 nm resolution; 90 % of its LEDs read <= 0.35 at
436 nm, and an LED's pump can mimic one Hg line, never the two of three that
are required. [1]"""

YELLOW_GREEN_MERCURY = 0.35
"""Hg 578 / Hg 546 height ratio above which the lamp is a high-pressure
mercury lamp: pressure broadening and self-absorption raise the yellow
doublet to 0.6-1.2 of the green line in high-pressure mercury, while a
low-pressure (fluorescent) discharge keeps it near 0.05-0.15 of the green
line plus the Tb 545 nm phosphor line under it. [1]"""

EU_MIN_PROMINENCE = 1.0
"""Eu 611 nm line present (tri-phosphor fluorescent): prominence >= 1. [1]"""

LPS_MIN_CORE_FRACTION = 0.6
"""Low-pressure sodium: at least this fraction of the visible power within
`NA_CORE_HALF_WIDTH_NM` of 589 nm (measured LPS: 0.95-1.0; HPS <= 0.31; the
fraction stays >= 0.9 at 10 nm resolution and drops by the background's
share). [1]"""

NA_CORE_HALF_WIDTH_NM = 8.0
"""Half width of the Na D core window (holds 94 % of a line read at 10 nm
resolution). [nm]"""

LPS_MAX_FWHM_NM = 13.0
"""LPS's single band is narrower than this (3-8 nm measured, ~11 nm at 10 nm
resolution); a direct amber LED at 589 nm is wider (>= 14 nm). [nm]"""

HPS_BAND_NM = (555.0, 630.0)
"""The self-reversed, pressure-broadened Na band of high-pressure sodium. [nm]"""

HPS_MIN_BAND_FRACTION = 0.45
"""HPS: at least this fraction of the visible power in `HPS_BAND_NM` (measured
HPS 0.30-0.74, half of them above 0.57; white LEDs 0.3-0.5). The blue
fraction and the missing Hg lines carry the rest of the decision. [1]"""

BLUE_NM = (380.0, 500.0)
"""The blue range whose power fraction separates sodium and filament lamps
(little blue) from mercury, metal halide and white LEDs. [nm]"""

HPS_MAX_BLUE_FRACTION = 0.14
"""HPS: below this fraction of the visible power in `BLUE_NM` (measured HPS
0.07-0.10; metal halide >= 0.17). [1]"""

SODIUM_MIN_LINE_FRACTION = 0.03
"""HPS: at least this fraction of its power in structure narrower than the
baseline (the self-reversal, the Na 568/616 nm lines; measured >= 0.04), which
a smooth phosphor-converted amber LED lacks. [1]"""

PLANCK_RANGE_NM = (450.0, 760.0)
"""Range of the Planck fit: blue enough to see a filament's steep rise,
clear of the weak 380-450 nm end where noise dominates. [nm]"""

PLANCK_TEMPERATURES_K = np.arange(1500.0, 4001.0, 50.0)
"""Temperatures tried by the Planck fit (every filament lamp lies in it). [K]"""

PLANCK_MAX_RESIDUAL = 0.12
"""Incandescent: median of the absolute log ratio of the spectrum to its best
Planck curve over
`PLANCK_RANGE_NM` below this (filaments <= 0.09, neodymium glass with its
580 nm notch included; phosphor LEDs >= 0.2 but for two built to imitate a
filament, which `INCANDESCENT_MAX_BLUE_FRACTION` separates). The median
ignores notches and absorption bands. [1]"""

INCANDESCENT_MAX_BLUE_FRACTION = 0.11
"""Incandescent: below this fraction in `BLUE_NM` (filaments at <= 3200 K:
<= 0.094; the two filament-imitating LEDs: >= 0.12). [1]"""

MAX_LINE_FRACTION_SMOOTH = 0.03
"""A continuum lamp (filament) has less than this fraction of its power above
the local baseline (measured filaments <= 0.015). [1]"""

LED_MAX_NARROW_PEAKS = 1.5
"""An LED has at most one peak narrower than `NARROW_PEAK_MAX_FWHM_NM`
(noise, a sharp phosphor edge): discharge lamps have several lines. [1]"""

MH_MIN_OTHER_LINES = 2.5
"""Metal halide: at least this many lines in `MH_LINES_RANGE_NM` at
wavelengths where no mercury or fluorescent-phosphor line lies (In 410/451,
Sc, Tl 535, Na 498/515, Li, Dy, ... lines; fluorescent lamps show none
there, metal halide lamps with a line spectrum 3-14). [1]"""

MH_LINES_RANGE_NM = (380.0, 560.0)
"""Where metal halide lines are counted: the blue-green, where a fluorescent
lamp has only Hg and Tb lines (its Eu phosphor lines and the Ar/Kr lines of
a warming-up tube lie beyond 580 nm). [nm]"""

COMMON_LINES_NM = (404.7, 435.8, 487.7, 491.0, 546.1)
"""Lines that a fluorescent or mercury lamp shows in `MH_LINES_RANGE_NM` (Hg;
Tb 488/491). Metal halide lines are counted away from them. [nm]"""

TL_MIN_PROMINENCE = 1.0
"""A Tl 535 nm line at least this prominent, in a spectrum without Hg lines,
marks a ceramic metal halide lamp (LEDs <= 0.55). [1]"""

MERCURY_MIN_LINE_FRACTION = 0.4
"""A high-pressure mercury lamp emits at least this fraction of its visible
power in lines (measured 0.62-0.77, coated lamps included); a halophosphate
fluorescent lamp, whose Hg 578 nm doublet can look strong on its broad
phosphor band, 0.1-0.2. [1]"""

NA_BLUE_NM = 498.2
"""The Na I 498.1/498.3 nm line, present in every high-pressure sodium
spectrum of the library, white SON included. [nm]"""

NA_BLUE_MIN_PROMINENCE = 0.3
"""Na 498 nm present: prominence >= 0.3 (a weak line on the sodium lamp's low
blue continuum). [1]"""

COMMON_LINE_EXCLUSION_NM = 6.0
"""A line within this distance of `COMMON_LINES_NM` is not counted as a metal
halide line. [nm]"""

SOFTNESS = 0.15
"""Width of every soft threshold, as a fraction of the threshold (a feature
15 % beyond its threshold scores 0.73 / 0.27 on either side). [1]"""

AMBIGUITY_RATIO = 0.5
"""The evidence is ambiguous when the second-best technology scores at least
this fraction of the best: every technology within it is a candidate. [1]"""

NA_IR_NM = 819.0
"""Centre of the Na I 818.3/819.5 nm doublet, read where the spectrum reaches
`NA_IR_NM + 6` nm. [nm]"""

NA_IR_MIN_PROMINENCE = 1.0
"""Na 819 nm present (sodium lamps 1.7-11 in the library's spectra measured
to 900 nm; LEDs <= 0.5). [1]"""


@dataclasses.dataclass(frozen=True)
class SpectralFeatures:
    """Robust features of a visible spectrum (see the module docstring).

    - `line_prominence`: line name -> prominence over the local continuum [1].
    - `line_height`: line name -> height above the local continuum, in units of
      the mean visible level [1].
    - `na_core_fraction`: visible power within `NA_CORE_HALF_WIDTH_NM` of
      589.3 nm / visible power [1].
    - `hps_band_fraction`, `blue_fraction`: the same for `HPS_BAND_NM`,
      `BLUE_NM` [1].
    - `line_fraction`: power above the local continuum / visible power [1].
    - `main_fwhm_nm`: full width at half maximum of the highest band [nm].
    - `narrow_peaks`: wavelengths of the peaks narrower than
      `NARROW_PEAK_MAX_FWHM_NM` [nm].
    - `other_lines`: those away from `COMMON_LINES_NM` [nm].
    - `planck_residual`, `planck_temperature_k`: the Planck fit [1], [K].
    - `na_ir_prominence`: prominence of Na 819 nm, or None (not measured) [1].
    """

    line_prominence: dict[str, float]
    line_height: dict[str, float]
    na_core_fraction: float
    hps_band_fraction: float
    blue_fraction: float
    line_fraction: float
    main_fwhm_nm: float
    narrow_peaks: tuple[float, ...]
    other_lines: tuple[float, ...]
    planck_residual: float
    planck_temperature_k: float
    na_ir_prominence: float | None


@dataclasses.dataclass(frozen=True)
class TechnologyEvidence:
    """Which technology a spectrum is, and why.

    - `technology`: the best-scoring technology, or None when ambiguous.
    - `candidates`: the technologies within `AMBIGUITY_RATIO` of the best,
      best first (one when not ambiguous).
    - `scores`: technology -> score, summing to 1 [1].
    - `evidence`: human-readable findings ("Hg 436 nm line, prominence 8.1x").
    - `ambiguous`: more than one candidate.
    - `features`: the measured features.
    """

    technology: str | None
    candidates: tuple[str, ...]
    scores: dict[str, float]
    evidence: tuple[str, ...]
    ambiguous: bool
    features: SpectralFeatures

    def to_json(self) -> dict:
        """JSON-ready summary (scores rounded to 3 decimals)."""
        return {
            "technology": self.technology,
            "candidates": list(self.candidates),
            "ambiguous": self.ambiguous,
            "scores": {k: round(v, 3) for k, v in self.scores.items()},
            "evidence": list(self.evidence),
        }


def _visible(wavelength_nm, values):
    """The spectrum on the 1 nm visible grid, in units of its mean there,
    smoothed by `SMOOTH_FWHM_NM`. Linear interpolation; NaN read as 0."""
    w = np.asarray(wavelength_nm, float)
    s = np.nan_to_num(np.asarray(values, float))
    if w.ndim != 1 or w.shape != s.shape or w.size < 3:
        raise ValueError(
            "wavelength_nm and values must be 1-d arrays of one length >= 3 "
            f"(got shapes {w.shape} and {s.shape})."
        )
    if w[0] > VISIBLE_NM[0] or w[-1] < VISIBLE_NM[1]:
        raise ValueError(
            f"the spectrum covers {w[0]:g}-{w[-1]:g} nm; need "
            f"{VISIBLE_NM[0]:g}-{VISIBLE_NM[1]:g} nm."
        )
    grid = np.arange(VISIBLE_NM[0], VISIBLE_NM[1] + 0.5)
    x = np.interp(grid, w, s)
    mean = x.mean()
    if not mean > 0:
        raise ValueError("the spectrum has no power in 380-780 nm.")
    x = gaussian_filter1d(x / mean, SMOOTH_FWHM_NM / 2.3548, mode="nearest")
    return grid, x


def _fraction(grid, x, lo, hi) -> float:
    m = (grid >= lo) & (grid <= hi)
    return float(x[m].sum() / x.sum())


def _line(grid, x, base, centre_nm) -> tuple[float, float]:
    """(height, prominence) of the highest point above the baseline within
    `LINE_TOLERANCE_NM` of `centre_nm`."""
    m = np.abs(grid - centre_nm) <= LINE_TOLERANCE_NM
    excess = x[m] - base[m]
    i = int(np.argmax(excess))
    return float(excess[i]), float(excess[i] / (base[m][i] + PROMINENCE_GUARD))


def _main_fwhm(x) -> float:
    i = int(np.argmax(x))
    above = x >= x[i] / 2
    lo = i
    while lo > 0 and above[lo - 1]:
        lo -= 1
    hi = i
    while hi < x.size - 1 and above[hi + 1]:
        hi += 1
    return float(hi - lo + 1)


def _planck_fit(grid, x) -> tuple[float, float]:
    """(median |log residual|, temperature) of the best Planck curve, scale
    free, over `PLANCK_RANGE_NM`."""
    m = (grid >= PLANCK_RANGE_NM[0]) & (grid <= PLANCK_RANGE_NM[1])
    logx = np.log(np.maximum(x[m], 1e-6))
    logb = np.log(planck_radiance(grid[m], PLANCK_TEMPERATURES_K))
    r = logx[None] - logb
    r -= np.median(r, axis=1, keepdims=True)
    err = np.median(np.abs(r), axis=1)
    k = int(np.argmin(err))
    return float(err[k]), float(PLANCK_TEMPERATURES_K[k])


def _na_ir(wavelength_nm, values, mean) -> float | None:
    w = np.asarray(wavelength_nm, float)
    if w[-1] < NA_IR_NM + 2 * LINE_TOLERANCE_NM:
        return None
    grid = np.arange(NA_IR_NM - 25.0, NA_IR_NM + 2 * LINE_TOLERANCE_NM + 0.5)
    x = np.interp(grid, w, np.nan_to_num(np.asarray(values, float))) / mean
    x = gaussian_filter1d(x, SMOOTH_FWHM_NM / 2.3548, mode="nearest")
    base = grey_opening(x, size=BASELINE_WIDTH_NM, mode="nearest")
    return _line(grid, x, base, NA_IR_NM)[1]


def spectral_features(wavelength_nm, values) -> SpectralFeatures:
    """Measure the robust features of a spectrum covering 380-780 nm
    (`wavelength_nm` [nm] increasing, `values` any spectral unit)."""
    grid, x = _visible(wavelength_nm, values)
    base = grey_opening(x, size=BASELINE_WIDTH_NM, mode="nearest")
    lines = {
        **HG_LINES_NM,
        "Hg 578": HG_YELLOW_NM,
        "Na 589": NA_D_NM,
        "Eu 611": EU_RED_NM,
        "Tl 535": TL_GREEN_NM,
        "Na 498": NA_BLUE_NM,
    }
    height, prominence = {}, {}
    for name, c in lines.items():
        height[name], prominence[name] = _line(grid, x, base, c)
    peaks, props = find_peaks(x, prominence=NARROW_PEAK_MIN_PROMINENCE)
    widths = peak_widths(
        x,
        peaks,
        rel_height=0.5,
        prominence_data=(
            props["prominences"],
            props["left_bases"],
            props["right_bases"],
        ),
    )[0]
    narrow = tuple(
        float(grid[p])
        for p, wd in zip(peaks, widths, strict=True)
        if wd <= NARROW_PEAK_MAX_FWHM_NM
    )
    common = np.asarray(COMMON_LINES_NM)
    other = tuple(
        c
        for c in narrow
        if MH_LINES_RANGE_NM[0] <= c <= MH_LINES_RANGE_NM[1]
        and np.min(np.abs(common - c)) > COMMON_LINE_EXCLUSION_NM
    )
    resid, temp = _planck_fit(grid, x)
    raw_mean = float(
        np.interp(
            grid,
            np.asarray(wavelength_nm, float),
            np.nan_to_num(np.asarray(values, float)),
        ).mean()
    )
    return SpectralFeatures(
        line_prominence=prominence,
        line_height=height,
        na_core_fraction=_fraction(
            grid, x, NA_D_NM - NA_CORE_HALF_WIDTH_NM, NA_D_NM + NA_CORE_HALF_WIDTH_NM
        ),
        hps_band_fraction=_fraction(grid, x, *HPS_BAND_NM),
        blue_fraction=_fraction(grid, x, *BLUE_NM),
        line_fraction=float(np.sum(x - base) / np.sum(x)),
        main_fwhm_nm=_main_fwhm(x),
        narrow_peaks=narrow,
        other_lines=other,
        planck_residual=resid,
        planck_temperature_k=temp,
        na_ir_prominence=_na_ir(wavelength_nm, values, raw_mean),
    )


def _above(value: float, threshold: float) -> float:
    """Soft step: 0.5 at `threshold`, width `SOFTNESS` x |threshold|."""
    scale = SOFTNESS * max(abs(threshold), 1e-9)
    return float(1.0 / (1.0 + np.exp(-(value - threshold) / scale)))


def _below(value: float, threshold: float) -> float:
    return 1.0 - _above(value, threshold)


def technology_scores(f: SpectralFeatures) -> dict[str, float]:
    """Unnormalised score of every technology (a product of soft thresholds,
    each named in the module constants) from the features `f`."""
    p = f.line_prominence
    h = f.line_height

    def line(name, min_prominence):  # prominent over its continuum and above noise
        return _above(p[name], min_prominence) * _above(
            h[name], NARROW_PEAK_MIN_PROMINENCE
        )

    hg_each = [line(k, HG_MIN_PROMINENCE) for k in HG_LINES_NM]
    hg = sorted(hg_each)[1]  # two of the three lines (an LED's violet pump at
    # 405 nm or its blue pump at 436 nm is at most one)
    yellow = h["Hg 578"] / max(h["Hg 546"], PROMINENCE_GUARD)
    single = _below(float(len(f.narrow_peaks)), LED_MAX_NARROW_PEAKS)
    lps = _above(f.na_core_fraction, LPS_MIN_CORE_FRACTION) * _below(
        f.main_fwhm_nm, LPS_MAX_FWHM_NM
    )
    na_blue = line("Na 498", NA_BLUE_MIN_PROMINENCE)
    if f.na_ir_prominence is not None:
        na_blue = max(na_blue, _above(f.na_ir_prominence, NA_IR_MIN_PROMINENCE))
    hps = (
        max(_above(f.hps_band_fraction, HPS_MIN_BAND_FRACTION), na_blue)
        * _below(f.blue_fraction, HPS_MAX_BLUE_FRACTION)
        * _above(f.line_fraction, SODIUM_MIN_LINE_FRACTION)
        * _below(f.na_core_fraction, LPS_MIN_CORE_FRACTION)
        * na_blue
        * (1.0 - hg)
    )
    incandescent = (
        _below(f.planck_residual, PLANCK_MAX_RESIDUAL)
        * _below(f.blue_fraction, INCANDESCENT_MAX_BLUE_FRACTION)
        * _below(f.line_fraction, MAX_LINE_FRACTION_SMOOTH)
    )
    mh_lines = _above(float(len(f.other_lines)), MH_MIN_OTHER_LINES)
    metal_halide = (
        _above(f.blue_fraction, HPS_MAX_BLUE_FRACTION)
        * (1.0 - lps)
        * max(mh_lines, line("Tl 535", TL_MIN_PROMINENCE) * (1.0 - hg))
    )
    mercury_like = _above(yellow, YELLOW_GREEN_MERCURY) * _above(
        f.line_fraction, MERCURY_MIN_LINE_FRACTION
    )
    return {
        "hps": hps,
        "lps": lps,
        "metal_halide": metal_halide,
        "mercury": hg * mercury_like * (1.0 - mh_lines),
        "fluorescent": hg * (1.0 - mercury_like) * (1.0 - mh_lines),
        "incandescent": incandescent,
        "led": (1.0 - hg)
        * single
        * (1.0 - lps)
        * (1.0 - incandescent)
        * (1.0 - hps)
        * (1.0 - metal_halide),
    }


def _evidence_text(f: SpectralFeatures) -> tuple[str, ...]:
    """Human-readable findings, strongest first."""
    out = []
    for name, c in {
        **HG_LINES_NM,
        "Hg 578": HG_YELLOW_NM,
        "Eu 611": EU_RED_NM,
        "Tl 535": TL_GREEN_NM,
    }.items():
        pr = f.line_prominence[name]
        if pr >= HG_MIN_PROMINENCE:
            out.append(f"{name.split()[0]} {c:.0f} nm line, prominence {pr:.1f}x")
    if f.na_core_fraction >= LPS_MIN_CORE_FRACTION / 2:
        out.append(
            f"{f.na_core_fraction:.0%} of visible power within "
            f"{NA_CORE_HALF_WIDTH_NM:g} nm of Na 589 nm"
        )
    out.append(
        f"{f.hps_band_fraction:.0%} of visible power in "
        f"{HPS_BAND_NM[0]:g}-{HPS_BAND_NM[1]:g} nm, {f.blue_fraction:.0%} in "
        f"{BLUE_NM[0]:g}-{BLUE_NM[1]:g} nm"
    )
    out.append(
        f"{len(f.narrow_peaks)} narrow lines (<= {NARROW_PEAK_MAX_FWHM_NM:g} nm), "
        f"{len(f.other_lines)} away from Hg/Na/phosphor lines"
    )
    out.append(f"highest band {f.main_fwhm_nm:.0f} nm wide")
    out.append(
        f"Planck fit {f.planck_temperature_k:.0f} K, median |log residual| "
        f"{f.planck_residual:.3f}"
    )
    if f.na_ir_prominence is not None:
        out.append(f"Na 819 nm line, prominence {f.na_ir_prominence:.1f}x")
    return tuple(out)


def identify_technology(wavelength_nm, values) -> TechnologyEvidence:
    """The technology (a key of `bandopt.datasets.nir.TECHNOLOGIES`) of a
    spectrum covering 380-780 nm, from `spectral_features`; ambiguous when the
    second-best score is at least `AMBIGUITY_RATIO` of the best.
    (`wavelength_nm` [nm], `values` any spectral unit.)"""
    f = spectral_features(wavelength_nm, values)
    raw = technology_scores(f)
    total = sum(raw.values())
    if not total > 0:  # nothing fits: every technology is as plausible
        raw = dict.fromkeys(raw, 1.0)
        total = float(len(raw))
    scores = {k: v / total for k, v in raw.items()}
    order = sorted(scores, key=scores.get, reverse=True)
    best = scores[order[0]]
    cands = tuple(k for k in order if scores[k] >= AMBIGUITY_RATIO * best)
    return TechnologyEvidence(
        technology=cands[0] if len(cands) == 1 else None,
        candidates=cands,
        scores=scores,
        evidence=_evidence_text(f),
        ambiguous=len(cands) > 1,
        features=f,
    )


NIR_CHOICES = CanonicalMapping(
    {**{t: t for t in nir_models.TECHNOLOGIES}, "auto": "auto", "none": "none"},
    what="NIR option",
)
"""The named `nir=` options of `extend_user_spectrum`: a technology of
`bandopt.datasets.nir.TECHNOLOGIES`, "auto" or "none" (case and separators ignored)."""


@dataclasses.dataclass(frozen=True)
class UserExtension:
    """A user's spectrum on the library grid, one row per NIR candidate.

    - `wavelength_nm`: `bandopt.spectra.GRID_1NM` (380-900 nm, 1 nm). [nm]
    - `spectra`: (n_candidates, w): measured values up to `measured_to_nm`,
      each candidate's extension beyond it. [unit of the input]
    - `technologies`: the technology of each row's extension (None: zeros,
      the user's own NIR, or nothing to extend).
    - `identification`: the `TechnologyEvidence` of the visible spectrum.
    - `measured_to_nm`: the last measured wavelength. [nm]
    - `nir`: how the NIR was chosen: "measured" (nothing to extend), "auto",
      a technology name, "none" or "user" (the user's own values).
    - `note`: JSON-ready summary of the above (None when nothing was
      extended).
    """

    wavelength_nm: np.ndarray
    spectra: np.ndarray
    technologies: tuple[str | None, ...]
    identification: TechnologyEvidence
    measured_to_nm: float
    nir: str
    note: dict | None

    @property
    def ambiguous(self) -> bool:
        """More than one candidate extension."""
        return self.spectra.shape[0] > 1


def _user_nir(nir_option, end_nm: float):
    """(wavelength, values) of the user's own NIR: an array pair or a file;
    must cover from the measured end to 900 nm."""
    if isinstance(nir_option, str | Path):
        label = str(nir_option)
        try:  # the one reader of spectral files (CSV, .prn, TM-27 XML)
            sp = read_spectrum(nir_option, require_range_nm=None)
        except (OSError, ValueError) as exc:
            raise ValueError(f"nir {label}: cannot read a spectrum ({exc})") from None
        w, v = sp.wavelength_nm, sp.values
    else:
        try:
            w, v = nir_option
        except (TypeError, ValueError):
            raise ValueError(
                "nir must be 'auto', 'none', a technology, a (wavelength, values) "
                "pair or a file."
            ) from None
        label = "(wavelength, values) arrays"
    w, v = np.asarray(w, float), np.asarray(v, float)
    if w.ndim != 1 or w.shape != v.shape or w.size < 2 or np.any(np.diff(w) <= 0):
        raise ValueError(
            f"nir {label}: need 1-d wavelength and values of one length >= 2, "
            "wavelengths strictly increasing."
        )
    top = float(GRID_1NM[-1])
    if w[0] > end_nm or w[-1] < top:
        raise ValueError(
            f"nir {label}: covers {w[0]:g}-{w[-1]:g} nm; the NIR must cover "
            f"{end_nm:g}-{top:g} nm (the measured end to the grid's end)."
        )
    if not np.all(np.isfinite(v)):
        raise ValueError(f"nir {label}: values must be finite.")
    return w, v, label


def extend_user_spectrum(wavelength_nm, values, nir="auto") -> UserExtension:
    """A spectrum measured from <= 380 nm to any end >= 780 nm, on the library
    grid `GRID_1NM` (to 900 nm), extended beyond its measured end.

    Every measured value up to the measured end is kept (linear
    interpolation onto the grid); grid points beyond it come from `nir`:

    - "auto": the technology `identify_technology` finds; when it is
      ambiguous, one row per candidate (best first);
    - a technology of `bandopt.datasets.nir.TECHNOLOGIES`: that technology's model
      (`bandopt.datasets.nir.extend_spectrum`);
    - "none": zeros beyond the measured end (the note says so);
    - a (wavelength [nm], values) pair or a spectrum file: the user's own
      NIR, interpolated linearly (it must cover the measured end to 900 nm).

    A spectrum measured to 900 nm or beyond is only resampled (`nir` is not
    used). Pure NumPy, no library loaded (the NIR line models are calibrated
    once per process). (`wavelength_nm` [nm] increasing; `values` any
    spectral unit, returned in it.)
    """
    w = np.asarray(wavelength_nm, float)
    s = np.asarray(values, float)
    ident = identify_technology(w, s)  # validates shapes and the 380-780 range
    if not np.all(np.isfinite(s)) or np.any(np.diff(w) <= 0):
        raise ValueError("values must be finite and wavelength_nm strictly increasing.")
    grid = np.asarray(GRID_1NM, float)
    end = float(w[-1])
    inside = grid <= end
    base = np.where(inside, np.interp(grid, w, s), 0.0)
    beyond = grid[~inside]
    if beyond.size == 0:
        return UserExtension(grid, base[None], (None,), ident, end, "measured", None)
    named = None
    if isinstance(nir, str) and not Path(nir).is_file():
        named = NIR_CHOICES.resolve(nir)  # ValueError listing the choices
    note = {"measured_to_nm": end, "identification": ident.to_json()}
    if named == "none":
        rows, techs = [base], (None,)
        note["nir_extension"] = "none"
        note["policy"] = f"zeros beyond the measured end ({end:g} nm), as asked"
    elif named is not None:
        techs = ident.candidates if named == "auto" else (named,)
        rows = [
            np.concatenate([base[inside], nir_models.extend_spectrum(w, s, t, beyond)])
            for t in techs
        ]
        note["nir_extension"] = techs[0] if len(techs) == 1 else list(techs)
        note["policy"] = (
            f"extended by the {' / '.join(techs)} NIR model"
            + (
                " (one extension per candidate: the features are ambiguous)"
                if len(techs) > 1
                else ""
            )
            + (" from the spectral features" if named == "auto" else ", as asked")
        )
    else:
        nw, nv, label = _user_nir(nir, end)
        rows, techs = (
            [np.concatenate([base[inside], np.interp(beyond, nw, nv)])],
            (None,),
        )
        note["nir_extension"] = "user"
        note["policy"] = f"the user's own NIR beyond {end:g} nm: {label}"
    return UserExtension(
        wavelength_nm=grid,
        spectra=np.asarray(rows),
        technologies=techs,
        identification=ident,
        measured_to_nm=end,
        nir=named if named is not None else "user",
        note=note,
    )
