"""Near-infrared extension of lamp spectra from 780 nm to 900 nm.

colour-science's lamp spectra stop at 780 nm, yet sodium and metal halide lamps
emit strongly at 819 nm, fluorescent tubes have argon/krypton lines there, and
satellite bands reach 900 nm. This module extends a spectrum by its technology,
with a physical model per technology:

- **Discharge lamps** (`hps`, `metal_halide`, `fluorescent_*`, `lps`):
  emission lines at their NIST air wavelengths (`NISTASD`) with a Gaussian
  instrument profile, plus a linear continuum. Line strengths and continuum are
  stored *per unit visible power* `P_vis = ∫_380^780 S dλ` and calibrated by
  non-negative least squares on the LI-1800 spectra of the same technology
  (`Aphalo2023`), which are measured to 900 nm.
- **Incandescent**: Planck's law (`Planck1901`) with the temperature fitted to
  the lamp's own 600-780 nm shape, scaled to its 760-780 nm level.
- **LED**: the phosphor tail continued as the exponential fitted to 740-780 nm,
  set to zero below 1e-4 of the peak ("zero beyond the phosphor tail").
- **Mercury**: flat continuation of the 770-780 nm continuum (no measured
  mercury lamp reaches 900 nm here).

Validation (`validate_extension`): cut each LI-1800 spectrum at 780 nm, extend
it, and compare band radiances beyond 780 nm with the measurement. Fluorescents
are calibrated leave-one-out; HPS, metal halide and incandescent have one
measured lamp each, so their check is in-sample (it tests the model's form, not
its transfer to other lamps). Low-pressure sodium, mercury and LEDs have no
measurement beyond 780 nm here: their extensions are marked unvalidated.
"""

import dataclasses
import functools
from pathlib import Path

import numpy as np
from scipy.optimize import nnls

from .loaders import read_prn


_DATA = Path(__file__).parent / "data" / "lamps_li1800"
EXTENSION_START_NM = 780.0
EXTENSION_END_NM = 900.0

# NIST ASD air wavelengths [nm] of the lines between 780 and 900 nm per technology.
NA_I = (818.33, 819.48)
XE_I = (823.16, 828.01, 881.94, 895.22)
AR_I = (794.82, 800.62, 801.48, 810.37, 811.53, 826.45, 840.82, 842.46, 852.14, 866.79)
KR_I = (785.48, 805.95, 810.44, 811.29, 819.01, 826.32, 829.81, 850.89, 877.68, 892.87)

LINES_NM: dict[str, tuple[float, ...]] = {
    "hps": NA_I + XE_I,
    "lps": NA_I,
    "metal_halide": NA_I + AR_I,
    "fluorescent": AR_I + KR_I,
}
"""Lines modelled per technology: Na I doublet (HPS, LPS, metal halide), Xe I
(HPS starting gas), Ar I and Kr I (fill gases of fluorescent tubes and metal
halide arc tubes)."""

CALIBRATION_FILES: dict[str, tuple[str, ...]] = {
    "hps": ("Osram.Super.Vialox",),
    "metal_halide": ("Osram.HQIT.400W",),
    "fluorescent": (
        "Osram.36W.25",
        "Philips.PLS11W.827",
        "Philips.TLD36W.83",
        "Philips.TLD36W.865",
        "Philips.TLD36W.89",
        "Philips.TLD36W.92",
        "Philips.TLL36W.950",
        "Sylvania.215W.VHO",
    ),
    "incandescent": ("Incandescent.60W",),
}
"""LI-1800 files used to calibrate each technology. The coloured tubes
(TLD 36W/15 red, /18 blue) are left out: their phosphors are not typical."""

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

VALIDATED = {
    "hps": True,
    "metal_halide": True,
    "fluorescent": True,
    "incandescent": True,
}
"""Technologies whose extension is checked against a measurement here."""


def is_validated(technology: str | None) -> bool:
    """The extension of `technology` is validated against measured spectra."""
    return bool(VALIDATED.get(technology or "", False))


def technology_of(level2: str | None, level1: str | None = None) -> str | None:
    """The extension technology for a level-2 class (None: no extension)."""
    if level2 in _TECHNOLOGY:
        return _TECHNOLOGY[level2]
    return {
        "fluorescent": "fluorescent",
        "led": "led",
        "incandescent": "incandescent",
    }.get(level1 or "")


def _gauss(x_nm, centres_nm, fwhm_nm):
    sigma = fwhm_nm / (2.0 * np.sqrt(2.0 * np.log(2.0)))
    z = (x_nm[:, None] - np.asarray(centres_nm)[None, :]) / sigma
    return np.exp(-0.5 * z**2) / (sigma * np.sqrt(2.0 * np.pi))  # unit area [nm-1]


def _design(x_nm, lines_nm, fwhm_nm):
    span = EXTENSION_END_NM - EXTENSION_START_NM
    cont = np.stack([np.ones_like(x_nm), (EXTENSION_END_NM - x_nm) / span], axis=1)
    if not lines_nm:
        return cont
    return np.concatenate([_gauss(x_nm, lines_nm, fwhm_nm), cont], axis=1)


def _visible_power(w, s):
    m = (w >= 380.0) & (w <= 780.0)
    return np.trapezoid(s[m], w[m])


@dataclasses.dataclass(frozen=True)
class LineCalibration:
    """Line and continuum coefficients per unit visible power for a technology.

    - `lines_nm`: line wavelengths. [nm]
    - `strength`: integrated line power / P_vis, per line. [1]
    - `continuum`: (c0, c1) of `c0 + c1 (900 - λ)/120`, per P_vis. [nm⁻¹]
    - `fwhm_nm`: Gaussian instrument profile fitted to the LI-1800 data. [nm]
    - `files`: calibration spectra.
    """

    lines_nm: tuple[float, ...]
    strength: np.ndarray
    continuum: np.ndarray
    fwhm_nm: float
    files: tuple[str, ...]

    def evaluate(self, wavelength_nm: np.ndarray, visible_power: float) -> np.ndarray:
        coef = np.concatenate([self.strength, self.continuum])
        return (
            visible_power * _design(wavelength_nm, self.lines_nm, self.fwhm_nm) @ coef
        )


def _fit_lines(spectra, lines_nm):
    """NNLS fit of lines + continuum over 780-900 nm, scanning the profile FWHM."""
    best = None
    for fwhm in np.arange(3.0, 12.01, 0.5):
        coefs, resid = [], 0.0
        for w, s in spectra:
            m = (w > EXTENSION_START_NM) & (w <= EXTENSION_END_NM)
            p_vis = _visible_power(w, s)
            coef, r = nnls(_design(w[m], lines_nm, fwhm), s[m] / p_vis)
            coefs.append(coef)
            resid += r**2
        if best is None or resid < best[0]:
            best = (resid, fwhm, np.mean(coefs, axis=0))
    _, fwhm, coef = best
    n = len(lines_nm)
    return float(fwhm), coef[:n], coef[n:]


def _li1800(name):
    s = read_prn(_DATA / f"{name}.PRN")
    return s.wavelength_nm, s.values


@functools.cache
def calibration(technology: str, exclude: tuple[str, ...] = ()) -> LineCalibration:
    """Fit the line model of a discharge technology on its LI-1800 spectra.

    `lps` borrows the Na I doublet strength of `hps` (no measured LPS spectrum
    reaches 900 nm here: unvalidated). `exclude` leaves files out (for
    leave-one-out validation).
    """
    if technology == "lps":
        hps = calibration("hps", exclude)
        na = np.array([hps.lines_nm.index(x) for x in NA_I])
        return LineCalibration(
            NA_I, hps.strength[na], np.zeros(2), hps.fwhm_nm, hps.files
        )
    if technology not in LINES_NM:
        raise ValueError(
            f"No line model for technology {technology!r}; expected one of "
            f"{sorted([*LINES_NM])}."
        )
    files = tuple(f for f in CALIBRATION_FILES[technology] if f not in exclude)
    if not files:
        raise ValueError(f"No calibration spectrum left for {technology!r}.")
    spectra = [_li1800(f) for f in files]
    fwhm, strength, cont = _fit_lines(spectra, LINES_NM[technology])
    return LineCalibration(LINES_NM[technology], strength, cont, fwhm, files)


def _planck(wavelength_nm, temperature_k):
    c2 = 1.438776877e7  # [nm K], second radiation constant (CODATA 2018)
    return wavelength_nm**-5.0 / np.expm1(c2 / (wavelength_nm * temperature_k))


def _extend_planck(w, s, w_new):
    m = (w >= 600.0) & (w <= 780.0) & (s > 0)
    temps = np.arange(1500.0, 4000.1, 10.0)
    logs = np.log(s[m])
    errs = []
    for t in temps:
        r = logs - np.log(_planck(w[m], t))
        errs.append(np.var(r))
    t_fit = temps[int(np.argmin(errs))]
    tail = (w >= 760.0) & (w <= 780.0)
    scale = np.mean(s[tail]) / np.mean(_planck(w[tail], t_fit))
    return scale * _planck(w_new, t_fit)


def _extend_led(w, s, w_new):
    m = (w >= 740.0) & (w <= 780.0) & (s > 0)
    peak = float(s.max())
    if m.sum() < 3:
        return np.zeros_like(w_new)
    slope, intercept = np.polyfit(w[m], np.log(s[m]), 1)
    slope = min(slope, -1.0 / 20.0)  # a tail never rises: at most a 20 nm e-fold
    out = np.exp(intercept + slope * w_new)
    return np.where(out >= 1e-4 * peak, out, 0.0)


def _extend_flat(w, s, w_new):
    m = (w >= 770.0) & (w <= 780.0)
    return np.full_like(w_new, float(np.min(s[m])))


def extend_spectrum(
    wavelength_nm: np.ndarray,
    values: np.ndarray,
    technology: str,
    new_wavelength_nm: np.ndarray,
    *,
    exclude: tuple[str, ...] = (),
) -> np.ndarray:
    """Model a spectrum at `new_wavelength_nm` (all > 780 nm) from its 380-780 nm part.

    `technology` is one of `hps`, `lps`, `metal_halide`, `fluorescent`,
    `incandescent`, `led`, `mercury` (see `technology_of`). [unit of `values`]
    """
    w = np.asarray(wavelength_nm, float)
    s = np.asarray(values, float)
    w_new = np.asarray(new_wavelength_nm, float)
    if np.any(w_new <= EXTENSION_START_NM) or np.any(w_new > EXTENSION_END_NM):
        raise ValueError("new_wavelength_nm must lie in (780, 900] nm.")
    if technology in LINES_NM or technology == "lps":
        return calibration(technology, exclude).evaluate(w_new, _visible_power(w, s))
    if technology == "incandescent":
        return _extend_planck(w, s, w_new)
    if technology == "led":
        return _extend_led(w, s, w_new)
    if technology == "mercury":
        return _extend_flat(w, s, w_new)
    raise ValueError(
        f"Unknown technology {technology!r}; expected one of "
        "['fluorescent', 'hps', 'incandescent', 'led', 'lps', 'mercury', "
        "'metal_halide']."
    )


VALIDATION_BANDS_NM: dict[str, tuple[float, float]] = {
    "780-900": (780.0, 900.0),
    "800-840": (800.0, 840.0),
    "840-900": (840.0, 900.0),
    "500-900": (500.0, 900.0),
}
"""Boxcar bands used to validate the extension (band-integrated power)."""


def validate_extension() -> list[dict]:
    """Compare extended and measured band powers for every calibration spectrum.

    Each row: file, technology, whether the check is leave-one-out, and per band
    the measured and extended band-integrated power and their relative error.
    """
    rows = []
    for tech, files in CALIBRATION_FILES.items():
        for f in files:
            w, s = _li1800(f)
            loo = tech == "fluorescent"
            exclude = (f,) if loo else ()
            grid = np.arange(380.0, 900.01, 1.0)
            s1 = np.interp(grid, w, s)
            vis = grid <= EXTENSION_START_NM
            ext = s1.copy()
            ext[~vis] = extend_spectrum(
                grid[vis], s1[vis], tech, grid[~vis], exclude=exclude
            )
            bands = {}
            for name, (lo, hi) in VALIDATION_BANDS_NM.items():
                m = (grid >= lo) & (grid <= hi)
                true = float(np.trapezoid(s1[m], grid[m]))
                est = float(np.trapezoid(ext[m], grid[m]))
                bands[name] = {
                    "measured": true,
                    "extended": est,
                    "rel_error": est / true - 1,
                }
            rows.append(
                {"file": f, "technology": tech, "leave_one_out": loo, "bands": bands}
            )
    return rows
