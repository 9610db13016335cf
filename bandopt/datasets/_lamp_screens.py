"""Screens of a measured lamp spectrum's red and near-infrared end.

Where a spectrum's measurement really ends (`measured_end`), whether its
near-infrared can serve as evidence (`nir_quality`), a rising background to
subtract (`rising_component`, `contamination_start`), the mercury plateau
artefact (`plateau_start`), and the part the library keeps (`usable_range`);
with the near-infrared extension range they judge against. Pure functions of
one spectrum's arrays, apart from `_lamp_sources` (which reads, classifies and
deduplicates the spectra and re-exports every name here) so that each module
holds one concern.
"""

import dataclasses

import numpy as np


EDGE_HOLD_NM = 5.0

EXTENSION_START_NM = 780.0
EXTENSION_END_NM = 900.0
"""The near-infrared extension of `bandopt.datasets.nir` covers (780, 900] nm."""


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
