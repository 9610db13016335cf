"""The near-infrared models per technology, their calibration and the extension.

The line and continuum models of the discharge technologies, the Planck and
LED tails, their calibration on the library's lamps measured to 900 nm
(`calibration`) and `extend_spectrum`, which continues a spectrum beyond its
measured end; the package docstring (`bandopt.datasets.nir`) describes each
model. Apart from the leave-one-out check and the error ranges built on it
(`_validation`) so that each module holds one step; `bandopt.datasets.nir`
re-exports every public name here.
"""

import dataclasses
import functools

import numpy as np
from scipy.optimize import nnls

from ...spectra import planck_radiance
from .._lamp_sources import (
    CUT_MIN_NM,
    EXTENSION_END_NM,
    EXTENSION_START_NM,
    measured_nir_spectra,
)


# NIST ASD air wavelengths [nm] of the lines between 780 and 900 nm per technology.
NA_I = (818.33, 819.48)
NA_DOUBLET_WEIGHTS = (1.0 / 3.0, 2.0 / 3.0)
XE_I = (823.16, 828.01, 881.94, 895.22)
AR_I = (794.82, 800.62, 801.48, 810.37, 811.53, 826.45, 840.82, 842.46, 852.14, 866.79)
KR_I = (785.48, 805.95, 810.44, 811.29, 819.01, 826.32, 829.81, 850.89, 877.68, 892.87)

LINES_NM: dict[str, tuple[float, ...]] = {
    "hps": NA_I,
    "lps": NA_I,
    "metal_halide": NA_I + AR_I,
    "fluorescent": AR_I + KR_I,
    "mercury": (),
}
"""Lines modelled per technology: the Na I doublet (HPS, LPS, metal halide, as
one tied column), Ar I (fill gas of metal halide arc tubes and fluorescent
tubes) and Kr I (fluorescent tubes). Mercury: continuum only."""

BROADENED_NA = ("hps", "metal_halide")
"""Technologies whose Na doublet gets a Lorentzian wing column (high pressure)."""

FWHM_SCAN_NM = (1.0, 1.5, 2.0, 3.0, 4.0, 6.0, 8.0, 10.0)
LORENTZ_HWHM_SCAN_NM = (1.0, 2.0, 4.0, 8.0, 16.0)
LED_FIT_SPAN_NM = 40.0
LED_MIN_DECAY_PER_NM = 1.0 / 200.0
"""The LED tail decays at least this fast (a tail never rises; a 200 nm
e-folding is slower than any clean measured LED tail here, 25-45 nm). [nm⁻¹]"""

TECHNOLOGIES = (
    "hps",
    "lps",
    "metal_halide",
    "mercury",
    "fluorescent",
    "incandescent",
    "led",
)

VALIDATED = {
    "hps": True,
    "metal_halide": True,
    "fluorescent": True,
    "incandescent": True,
    "led": True,
    "lps": False,
    "mercury": False,
}
"""Technologies whose extension is validated leave-one-out against at least two
measured lamps (`validate_extension`); the counts are in
`results/library/nir_validation.json` and checked by `tests/test_nir.py`."""


UPPER_BOUND = ("mercury",)
"""Technologies whose extension is an upper bound, not a measurement: the one
measured mercury lamp's 780-930 nm level equals its instrument floor."""


def is_validated(technology: str | None) -> bool:
    """The extension of `technology` is validated against measured spectra."""
    return bool(VALIDATED.get(technology or "", False))


SINGLE_BAND_MIN_FWHM_NM = 10.0
"""A visible spectrum with one emission band at least this wide at half
maximum is an LED (direct or phosphor-converted), never a low-pressure sodium
lamp: the Na D doublet is 0.6 nm wide and reads 3-6 nm in the library's
measured LPS spectra (instrument width), while the narrowest measured amber
LED is 14 nm wide. HPS and other discharge lamps show several peaks."""

SINGLE_BAND_PROMINENCE = 0.01
"""Peaks with a prominence of at least 1 % of the maximum count as bands."""


def is_single_band_emitter(wavelength_nm, values) -> bool:
    """True when the visible spectrum has exactly one emission band
    (prominence >= `SINGLE_BAND_PROMINENCE` of the peak) whose half-maximum
    width is >= `SINGLE_BAND_MIN_FWHM_NM`: an LED, extended as `led` (no
    discharge lines) whatever library lamp it resembles. All 14 library
    spectra with a single band >= 10 nm wide are LEDs."""
    # start-up time: scipy.signal adds ~0.4 s to the import
    from scipy.signal import find_peaks, peak_widths

    w = np.asarray(wavelength_nm, float)
    s = np.nan_to_num(np.asarray(values, float))
    if s.size < 3 or not s.max() > 0:
        return False
    s = s / s.max()
    peaks, _ = find_peaks(s, prominence=SINGLE_BAND_PROMINENCE)  # never at an end
    if peaks.size != 1:
        return False
    width = peak_widths(s, peaks, rel_height=0.5)[0]
    step = float(np.median(np.diff(w)))
    return bool(width[0] * step >= SINGLE_BAND_MIN_FWHM_NM)


def _gauss(x_nm, centres_nm, fwhm_nm):
    sigma = fwhm_nm / (2.0 * np.sqrt(2.0 * np.log(2.0)))
    z = (x_nm[:, None] - np.asarray(centres_nm)[None, :]) / sigma
    return np.exp(-0.5 * z**2) / (sigma * np.sqrt(2.0 * np.pi))  # unit area [nm-1]


def _lorentz(x_nm, centres_nm, hwhm_nm):
    z = x_nm[:, None] - np.asarray(centres_nm)[None, :]
    return hwhm_nm / np.pi / (z**2 + hwhm_nm**2)  # unit area over the real line


def _design(x_nm, technology, fwhm_nm, hwhm_nm=None):
    """Columns: [Na doublet (Gaussian), Na doublet (Lorentzian wing)?, other lines
    (Gaussian), continuum c0, continuum c1 (900 - λ)/120]."""
    x_nm = np.asarray(x_nm, float)
    lines = LINES_NM[technology]
    cols = []
    rest = tuple(x for x in lines if x not in NA_I)
    if any(x in NA_I for x in lines):
        cols.append(_gauss(x_nm, NA_I, fwhm_nm) @ np.array(NA_DOUBLET_WEIGHTS))
        if technology in BROADENED_NA:
            cols.append(_lorentz(x_nm, NA_I, hwhm_nm) @ np.array(NA_DOUBLET_WEIGHTS))
    if rest:
        cols.extend(_gauss(x_nm, rest, fwhm_nm).T)
    span = EXTENSION_END_NM - EXTENSION_START_NM
    cols.append(np.ones_like(x_nm))
    cols.append((EXTENSION_END_NM - x_nm) / span)
    return np.stack(cols, axis=1)


def column_names(technology: str) -> list[str]:
    """Names of the columns of the line model of `technology`."""
    lines = LINES_NM[technology]
    names = []
    if any(x in NA_I for x in lines):
        names.append("Na I 818.33+819.48 (1:2)")
        if technology in BROADENED_NA:
            names.append("Na I doublet Lorentzian wing")
    names += [f"{x:.2f}" for x in lines if x not in NA_I]
    return [*names, "continuum c0", "continuum c1"]


def _visible_power(w, s):
    m = (w >= 380.0) & (w <= 780.0)
    return np.trapezoid(s[m], w[m])


@dataclasses.dataclass(frozen=True)
class LineCalibration:
    """Line and continuum coefficients per unit visible power for a technology.

    - `technology`: the technology.
    - `coef`: one coefficient per column of `column_names(technology)`: line
      powers / P_vis [1], continuum per P_vis [nm⁻¹].
    - `fwhm_nm`: Gaussian line FWHM. [nm]
    - `hwhm_nm`: Lorentzian half width of the broadened Na doublet (or None). [nm]
    - `files`: ids of the calibration spectra.
    """

    technology: str
    coef: np.ndarray
    fwhm_nm: float
    hwhm_nm: float | None
    files: tuple[str, ...]

    @property
    def lines_nm(self) -> tuple[float, ...]:
        return LINES_NM[self.technology]

    @property
    def strength(self) -> np.ndarray:
        """Line-column coefficients (everything but the continuum). [1]"""
        return self.coef[:-2]

    @property
    def continuum(self) -> np.ndarray:
        return self.coef[-2:]

    def evaluate(self, wavelength_nm: np.ndarray, visible_power: float) -> np.ndarray:
        d = _design(wavelength_nm, self.technology, self.fwhm_nm, self.hwhm_nm)
        return visible_power * d @ self.coef


def calibration_spectra(technology: str, lspdd: bool = True) -> list[tuple]:
    """(id, wavelength [nm], values) of the library's lamps of `technology`
    measured to 900 nm (White SON, excluded lamps and spectra failing
    `lamps.nir_quality` left out)."""
    return [
        (m["id"], m["wavelength_nm"], m["values"])
        for m in measured_nir_spectra(lspdd)
        if m["technology"] == technology
        and m["subtype"] != "white_son"
        and m["nir_quality"] is None
    ]


@functools.cache
def _per_lamp_fits(technology: str, lspdd: bool) -> tuple:
    """NNLS fits of every calibration spectrum at every profile width.

    Returns (ids, widths, coefs [n_width, n_lamp, n_col], relative residuals
    [n_width, n_lamp], measured 780-900 nm power per visible power [n_lamp])."""
    spectra = calibration_spectra(technology, lspdd)
    if not spectra:
        raise ValueError(f"No measured NIR spectrum for technology {technology!r}.")
    hw = LORENTZ_HWHM_SCAN_NM if technology in BROADENED_NA else (None,)
    widths = [(f, h) for f in FWHM_SCAN_NM for h in hw]
    coefs, resid = [], []
    ratio = []
    for _, w, s in spectra:
        m = (w >= EXTENSION_START_NM) & (w <= EXTENSION_END_NM)
        ratio.append(np.trapezoid(s[m], w[m]) / _visible_power(w, s))
    for fwhm, hwhm in widths:
        c_row, r_row = [], []
        for _, w, s in spectra:
            m = (w > EXTENSION_START_NM) & (w <= EXTENSION_END_NM)
            y = s[m] / _visible_power(w, s)
            coef, r = nnls(_design(w[m], technology, fwhm, hwhm), y)
            c_row.append(coef)
            r_row.append(r**2 / max(float(y @ y), 1e-300))
        coefs.append(c_row)
        resid.append(r_row)
    ids = tuple(x[0] for x in spectra)
    return ids, widths, np.array(coefs), np.array(resid), np.array(ratio)


@functools.cache
def calibration(
    technology: str, exclude: tuple[str, ...] = (), lspdd: bool = True
) -> LineCalibration:
    """The line model of a discharge technology (or mercury's continuum),
    calibrated on the library's lamps measured to 900 nm.

    The profile widths minimise the summed relative residual over the
    calibration lamps; the coefficients are their mean (the fit of the mean
    spectrum per visible power: the median of sparse line coefficients was
    near zero for fluorescents, whose lamps put power on different lines),
    scaled by median / mean of the lamps' measured 780-900 nm power per visible
    power, so the level is the median lamp's. `exclude` leaves lamp
    ids out (leave-one-out validation); `lspdd=False` calibrates without the
    LSPDD set.
    """
    if technology not in LINES_NM:
        raise ValueError(
            f"No line model for technology {technology!r}; expected one of "
            f"{sorted(LINES_NM)}."
        )
    ids, widths, coefs, resid, ratio = _per_lamp_fits(technology, lspdd)
    keep = np.array([i not in exclude for i in ids])
    if not keep.any():
        raise ValueError(f"No calibration spectrum left for {technology!r}.")
    k = int(np.argmin(resid[:, keep].sum(axis=1)))
    fwhm, hwhm = widths[k]
    coef = np.mean(coefs[k][keep], axis=0)
    # Level: the median lamp's NIR/visible, not the mean (one warming-up CFL
    # with argon lines at 0.6 of peak would set the mean).
    coef = coef * np.median(ratio[keep]) / np.mean(ratio[keep])
    files = tuple(i for i, m in zip(ids, keep, strict=True) if m)
    return LineCalibration(technology, coef, float(fwhm), hwhm, files)


def _planck(wavelength_nm, temperature_k):
    return planck_radiance(wavelength_nm, temperature_k)


def _extend_planck(w, s, w_new):
    end = w[-1]
    m = (w >= 600.0) & (w <= end) & (s > 0)
    temps = np.arange(1500.0, 4000.1, 10.0)
    logs = np.log(s[m])
    errs = [np.var(logs - np.log(_planck(w[m], t))) for t in temps]
    t_fit = temps[int(np.argmin(errs))]
    tail = (w >= end - 20.0) & (w <= end)
    scale = np.mean(s[tail]) / np.mean(_planck(w[tail], t_fit))
    return scale * _planck(w_new, t_fit)


def _extend_led(w, s, w_new):
    """Exponential tail anchored at the measured end w[-1]: continuous there."""
    end = w[-1]
    m = (w >= end - LED_FIT_SPAN_NM) & (w <= end) & (s > 0)
    anchor = float(np.interp(end, w, s))
    if m.sum() < 3 or anchor <= 0.0:
        return np.zeros_like(w_new)
    slope = float(np.polyfit(w[m] - end, np.log(s[m]), 1)[0])
    slope = min(slope, -LED_MIN_DECAY_PER_NM)
    return anchor * np.exp(slope * (w_new - end))


def extend_spectrum(
    wavelength_nm: np.ndarray,
    values: np.ndarray,
    technology: str,
    new_wavelength_nm: np.ndarray,
    *,
    exclude: tuple[str, ...] = (),
    lspdd: bool = True,
) -> np.ndarray:
    """Model a spectrum at `new_wavelength_nm` (all beyond the measured end,
    up to 900 nm) from its measured part, which must reach `CUT_MIN_NM`.

    The visible power of the line and continuum models is the measured
    380-780 nm integral; for a spectrum ending before 780 nm it is completed
    by the model's own part between the end and 780 nm (the model is linear
    in it: P = P_measured / (1 - model power per unit P over the gap)).
    `technology` is one of `TECHNOLOGIES` (see `technology_of`). `exclude` and
    `lspdd` select the calibration lamps (see `calibration`). [unit of `values`]
    """
    w = np.asarray(wavelength_nm, float)
    s = np.asarray(values, float)
    w_new = np.asarray(new_wavelength_nm, float)
    if np.any(w_new > EXTENSION_END_NM):
        raise ValueError("new_wavelength_nm must lie at or below 900 nm.")
    if w[-1] < CUT_MIN_NM or np.any(w_new <= w[-1]):
        raise ValueError(
            f"the measured spectrum ({w[0]:g}-{w[-1]:g} nm) must reach "
            f"{CUT_MIN_NM:g} nm and end before new_wavelength_nm."
        )
    if technology in LINES_NM:
        cal = calibration(technology, tuple(exclude), lspdd)
        p_vis = _visible_power(w, s)
        end = float(w[-1])
        if end < EXTENSION_START_NM:
            gap = np.linspace(
                end, EXTENSION_START_NM, 4 * int(EXTENSION_START_NM - end) + 2
            )
            p_vis /= 1.0 - float(np.trapezoid(cal.evaluate(gap, 1.0), gap))
        return cal.evaluate(w_new, p_vis)
    if technology == "incandescent":
        return _extend_planck(w, s, w_new)
    if technology == "led":
        return _extend_led(w, s, w_new)
    raise ValueError(
        f"Unknown technology {technology!r}; expected one of {sorted(TECHNOLOGIES)}."
    )
