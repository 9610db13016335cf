"""The robust features of a visible lamp spectrum that the identification scores.

`spectral_features` puts a spectrum on the 1 nm visible grid in units of its
mean, smooths it and measures what `SpectralFeatures` holds: line heights and
prominences over the grey-opening baseline, power fractions, the width of the
highest band, the narrow lines and the Planck fit, with the wavelengths and
widths those use. Apart from the scoring (`_identify`) so that measuring a
spectrum and judging it are separate steps; `bandopt.datasets.technology`
describes the features and re-exports every public name here.
"""

import dataclasses

import numpy as np
from scipy.ndimage import gaussian_filter1d, grey_opening
from scipy.signal import find_peaks, peak_widths

from ...spectra import planck_radiance


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

NA_CORE_HALF_WIDTH_NM = 8.0
"""Half width of the Na D core window (holds 94 % of a line read at 10 nm
resolution). [nm]"""

HPS_BAND_NM = (555.0, 630.0)
"""The self-reversed, pressure-broadened Na band of high-pressure sodium. [nm]"""

BLUE_NM = (380.0, 500.0)
"""The blue range whose power fraction separates sodium and filament lamps
(little blue) from mercury, metal halide and white LEDs. [nm]"""

PLANCK_RANGE_NM = (450.0, 760.0)
"""Range of the Planck fit: blue enough to see a filament's steep rise,
clear of the weak 380-450 nm end where noise dominates. [nm]"""

PLANCK_TEMPERATURES_K = np.arange(1500.0, 4001.0, 50.0)
"""Temperatures tried by the Planck fit (every filament lamp lies in it). [K]"""

MH_LINES_RANGE_NM = (380.0, 560.0)
"""Where metal halide lines are counted: the blue-green, where a fluorescent
lamp has only Hg and Tb lines (its Eu phosphor lines and the Ar/Kr lines of
a warming-up tube lie beyond 580 nm). [nm]"""

COMMON_LINES_NM = (404.7, 435.8, 487.7, 491.0, 546.1)
"""Lines that a fluorescent or mercury lamp shows in `MH_LINES_RANGE_NM` (Hg;
Tb 488/491). Metal halide lines are counted away from them. [nm]"""

NA_BLUE_NM = 498.2
"""The Na I 498.1/498.3 nm line, present in every high-pressure sodium
spectrum of the library, white SON included. [nm]"""

COMMON_LINE_EXCLUSION_NM = 6.0
"""A line within this distance of `COMMON_LINES_NM` is not counted as a metal
halide line. [nm]"""

NA_IR_NM = 819.0
"""Centre of the Na I 818.3/819.5 nm doublet, read where the spectrum reaches
`NA_IR_NM + 6` nm. [nm]"""


@dataclasses.dataclass(frozen=True)
class SpectralFeatures:
    """Robust features of a visible spectrum (see the `bandopt.datasets.technology`
    docstring).

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
