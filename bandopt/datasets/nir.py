"""Near-infrared extension of lamp spectra measured only to 780-850 nm, up to 900 nm.

colour-science's lamp spectra stop at 780 nm, yet sodium and metal halide lamps
emit strongly at 819 nm, fluorescent tubes have argon/krypton lines there, and
satellite bands reach 900 nm. This module extends a spectrum beyond its
measured end by its technology, with a physical model per technology, and
calibrates and validates each model on the lamps of the library that *are*
measured to 900 nm (LI-1800 `Aphalo2023`, LSPDD `LSPDD2016`, photobiology
`Aphalo2025lamps`/`Aphalo2025leds`, color-pollution `Robinson2016`; see
`bandopt.datasets.lamps.measured_nir_spectra`):

- **Discharge lamps** (`hps`, `lps`, `metal_halide`, `fluorescent`): emission
  lines at their NIST air wavelengths (`NISTASD`) with a Gaussian profile of
  fitted FWHM, plus a linear continuum. The Na I 818.33/819.48 nm doublet is
  one column with the LS-coupling multiplet strengths 1 : 2 (3p 2P - 3d 2D,
  strengths 5 : 9 + 1), so the fit cannot move its power to one line or to a
  neighbouring line; in high-pressure lamps (`hps`, `metal_halide`) the
  pressure-broadened doublet has a second, Lorentzian column (its wings), with
  the half width fitted. No Xe line is modelled for HPS: none is resolved above
  the broadened Na wing in the two measured HPS spectra (the former "Xe 823.2
  nm" line absorbed that wing). Line strengths and continuum are *per unit
  visible power* `P_vis = ∫_380^780 S dλ` and are the median over the
  calibration lamps of their non-negative least-squares fits.
- **Mercury**: continuum only (no Hg I line lies in 780-900 nm), per unit
  visible power, calibrated on the one measured mercury lamp (color-pollution
  HgV, to 930 nm: NIR/visible 0.057). Its 780-930 nm level is flat at its
  instrument floor, so the calibration is an **upper bound** on a mercury
  lamp's near-infrared, not a measurement of it (`UPPER_BOUND`; its error
  bound in `extension_error` is -100 % to 0 %). The 765-780 nm plateau of two
  NIST Philips mercury spectra is a data artefact, cut before it by the
  library (`bandopt.datasets.lamps.usable_range`).
- **Incandescent**: Planck's law (`Planck1901`) with the temperature fitted to
  the lamp's own 600 nm-to-end shape, scaled to its last 20 nm.
- **LED**: the phosphor tail continued as the exponential fitted to the last
  40 nm, *anchored at the measured end* (continuous there), with the decay
  rate at least `LED_MIN_DECAY_PER_NM`. Direct (phosphor-free) amber LEDs have
  ~0 there and get ~0. The former version kept the intercept fitted at λ = 0
  with a clamped slope, which dropped 11 of 24 LED tails to 0 at 781 nm.

`VALIDATED`: a technology's extension is validated when it has at least two
measured lamps, so that it can be checked leave-one-out (`validate_extension`,
published in `results/library/nir_validation.json`). LPS and mercury have one
measured lamp each (calibrated in-sample, not validated); White SON (high-CRI
HPS) has none (the library never flags it validated). `extension_error` gives
the measured error of the extension per class from that check, and a stated
bound where there is none.

A spectrum cut below 780 nm (at most down to `CUT_MIN_NM`: truncated or
contaminated data, see `bandopt.datasets.lamps.usable_range`) is continued by
the same models from its cut: the LED and Planck tails from the cut, the line
and continuum models with the visible power completed by the model's own
part between the cut and 780 nm.
"""

import dataclasses
import functools

import numpy as np
from scipy.optimize import nnls

from ..spectra import planck_radiance

# The calibration spectra; the extension range and `technology_of` are defined
# with them (they select and label them) and re-exported here.
from ._lamp_sources import (
    CUT_MIN_NM,
    EXTENSION_END_NM,
    EXTENSION_START_NM,
    classes_with_measured_nir,
    lspdd_enabled,
    measured_nir_spectra,
    technology_of as technology_of,
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


VALIDATION_BANDS_NM: dict[str, tuple[float, float]] = {
    "780-900": (780.0, 900.0),
    "780-800": (780.0, 800.0),
    "800-840": (800.0, 840.0),
    "840-900": (840.0, 900.0),
    "500-900": (500.0, 900.0),
}
"""Boxcar bands used to validate the extension (band-integrated power)."""


def validate_extension(lspdd: bool = True) -> list[dict]:
    """Leave-one-out check on every lamp of the library measured to 900 nm.

    Spectra failing `lamps.nir_quality` (clipped or edge-artefact NIR) are
    skipped. Each spectrum is cut at 780 nm and extended by its technology, calibrated
    without it (the line models and mercury; LED and incandescent tails use the
    lamp's own visible part only), and the band powers beyond 780 nm are
    compared with the measurement. Each row: id, level 2, subtype, technology,
    source set, whether the check is leave-one-out (False when the technology
    has a single measured lamp: then the check is in-sample), and per band the
    measured and extended band-integrated power and their relative error.
    """
    grid = np.arange(380.0, 900.01, 1.0)
    vis = grid <= EXTENSION_START_NM
    rows = []
    for m in measured_nir_spectra(lspdd):
        tech = m["technology"]
        if tech is None or m["subtype"] == "white_son" or m["nir_quality"]:
            continue
        s1 = np.interp(grid, m["wavelength_nm"], m["values"])
        exclude = ()
        loo = True
        if tech in LINES_NM:
            ids = _per_lamp_fits(tech, lspdd)[0]
            loo = len(ids) > 1
            exclude = (m["id"],) if loo else ()
        ext = s1.copy()
        ext[~vis] = extend_spectrum(
            grid[vis], s1[vis], tech, grid[~vis], exclude=exclude, lspdd=lspdd
        )
        p_vis = float(np.trapezoid(s1[vis], grid[vis]))
        bands = {}
        for name, (lo, hi) in VALIDATION_BANDS_NM.items():
            b = (grid >= lo) & (grid <= hi)
            true = float(np.trapezoid(s1[b], grid[b]))
            est = float(np.trapezoid(ext[b], grid[b]))
            bands[name] = {
                "measured": true / p_vis,
                "extended": est / p_vis,
                "rel_error": est / true - 1 if true > 0 else None,
            }
        rows.append(
            {
                "id": m["id"],
                "level2": m["level2"],
                "subtype": m["subtype"],
                "technology": tech,
                "source_set": m["source_set"],
                "leave_one_out": loo,
                "bands": bands,
            }
        )
    return rows


ERROR_QUANTILES = (0.05, 0.95)
"""The quantiles of the leave-one-out error that `extension_error` reports: a
90 % range, the interval level of bandopt's estimates."""

MIN_CLASS_LAMPS = 5
"""A class with fewer validated lamps than this takes the error of its
technology's pooled lamps: four points give no 5 % or 95 % quantile worth the
name."""

UPPER_BOUND_ERROR = (-1.0, 0.0)
"""The error range of an upper-bound extension (`UPPER_BOUND`): the true
near-infrared lies between none and the modelled level."""

ERROR_BAND = "780-900"
"""The `VALIDATION_BANDS_NM` band whose power `extension_error` is about."""


@dataclasses.dataclass(frozen=True)
class NirError:
    """The relative error of the near-infrared extension's 780-900 nm band
    power: measured / modelled - 1, so the true power is the modelled one times
    (1 + e) with e in [`low`, `high`].

    - `low`, `high`: the `ERROR_QUANTILES` (5 % and 95 %) of that error over
      the lamps of `basis`, or a stated bound when there is no validation. [1]
    - `n_lamps`: lamps the quantiles come from (0 for a stated bound).
    - `validated`: the range comes from the leave-one-out validation.
    - `basis`: where the range comes from, in words.
    """

    low: float
    high: float
    n_lamps: int
    validated: bool
    basis: str


@functools.cache
def _validated_errors(lspdd: bool) -> tuple[dict, dict]:
    """Leave-one-out errors (measured / modelled - 1 of the `ERROR_BAND` power)
    per level-2 class and per technology, each as (errors, number of lamps left
    out because their extension is 0 there: the ratio is undefined)."""
    by_class: dict[str, list] = {}
    by_tech: dict[str, list] = {}
    for row in validate_extension(lspdd):
        if not row["leave_one_out"]:
            continue
        band = row["bands"][ERROR_BAND]
        for d, key in ((by_class, row["level2"]), (by_tech, row["technology"])):
            errors, zero = d.setdefault(key, [[], 0])
            if band["extended"] > 0.0:
                errors.append(band["measured"] / band["extended"] - 1.0)
            else:
                d[key][1] = zero + 1
    pack = lambda d: {k: (np.array(e), z) for k, (e, z) in d.items()}  # noqa: E731
    return pack(by_class), pack(by_tech)


def _quantile_error(errors: np.ndarray, basis: str) -> NirError:
    lo, hi = np.quantile(errors, ERROR_QUANTILES)
    return NirError(float(lo), float(hi), int(errors.size), True, basis)


def extension_error(
    level2: str | None,
    technology: str | None,
    *,
    subtype: str | None = None,
    lspdd: bool | None = None,
) -> NirError:
    """The measured error of the near-infrared extension of a lamp of class
    `level2` extended as `technology` (None: `technology_of(level2)`), as a
    `NirError` on its 780-900 nm band power.

    - a validated technology and a class with measured near-infrared: the 5 %
      and 95 % quantiles of the leave-one-out error of the class's lamps
      (`validate_extension`), or of the technology's pooled lamps when the
      class has fewer than `MIN_CLASS_LAMPS`;
    - an upper-bound technology (`UPPER_BOUND`, mercury): `UPPER_BOUND_ERROR`;
    - anything else (LPS, calibrated on one lamp; White SON, `subtype`
      "white_son"; classes without measured near-infrared; no technology):
      not validated, and the envelope of the validated technologies' ranges
      (the widest low and high among them): an unvalidated extension is taken
      to be as wrong as the worst validated one.

    Lamps whose extension is 0 in the band (the ratio is undefined) are left
    out of the quantiles, and `basis` counts them. Computed from the
    validation once per `lspdd` setting (a few seconds) and cached.
    """
    use_lspdd = lspdd_enabled(lspdd)
    tech = technology if technology is not None else technology_of(level2)
    by_class, by_tech = _validated_errors(use_lspdd)

    def left_out(zero):
        return (
            f"; {zero} lamps whose extension is 0 in {ERROR_BAND} nm left out "
            "(ratio undefined)"
            if zero
            else ""
        )

    if tech in UPPER_BOUND:
        lo, hi = UPPER_BOUND_ERROR
        return NirError(
            lo,
            hi,
            0,
            False,
            f"{tech}: the extension is an upper bound (the one measured lamp's "
            "780-930 nm level equals its instrument floor): the true power lies "
            "between 0 and the modelled one",
        )
    reason = None
    if tech is None:
        reason = "no extension technology"
    elif not is_validated(tech):
        reason = f"{tech}: calibrated in-sample on a single measured lamp"
    elif subtype == "white_son":
        reason = (
            "White SON (high-CRI HPS): no measured lamp; the HPS calibration "
            "is standard HPS"
        )
    elif level2 is not None and level2 not in classes_with_measured_nir(use_lspdd):
        reason = f"no measured near-infrared for class {level2}"
    if reason is None:
        errors, zero = by_class.get(level2, (np.array([]), 0))
        if errors.size >= MIN_CLASS_LAMPS:
            return _quantile_error(
                errors,
                f"leave-one-out validation of {level2} ({errors.size} lamps, "
                f"{tech} extension, {ERROR_BAND} nm band power){left_out(zero)}",
            )
        few = errors.size
        errors, zero = by_tech[tech]
        return _quantile_error(
            errors,
            f"leave-one-out validation of the {tech} technology's pooled lamps "
            f"({errors.size} lamps; class {level2} has {few} < {MIN_CLASS_LAMPS}; "
            f"{ERROR_BAND} nm band power){left_out(zero)}",
        )
    ranges = [_quantile_error(e, "") for e, _ in by_tech.values()]
    return NirError(
        min(r.low for r in ranges),
        max(r.high for r in ranges),
        0,
        False,
        f"no leave-one-out validation ({reason}): the envelope of the validated "
        f"technologies' 5-95 % ranges ({', '.join(sorted(by_tech))})",
    )
