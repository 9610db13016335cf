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

Modules: `_model` (the line, continuum, Planck and LED models, their
calibration and `extend_spectrum`) and `_validation` (`validate_extension`
and `extension_error`); every public name of both is re-exported here.
"""

# The calibration spectra; the extension range and `technology_of` are defined
# with them (they select and label them) and re-exported here.
from .._lamp_sources import (
    CUT_MIN_NM as CUT_MIN_NM,
    EXTENSION_END_NM as EXTENSION_END_NM,
    EXTENSION_START_NM as EXTENSION_START_NM,
    classes_with_measured_nir as classes_with_measured_nir,
    lspdd_enabled as lspdd_enabled,
    measured_nir_spectra as measured_nir_spectra,
    technology_of as technology_of,
)
from ._model import (
    AR_I as AR_I,
    BROADENED_NA as BROADENED_NA,
    FWHM_SCAN_NM as FWHM_SCAN_NM,
    KR_I as KR_I,
    LED_FIT_SPAN_NM as LED_FIT_SPAN_NM,
    LED_MIN_DECAY_PER_NM as LED_MIN_DECAY_PER_NM,
    LINES_NM as LINES_NM,
    LORENTZ_HWHM_SCAN_NM as LORENTZ_HWHM_SCAN_NM,
    NA_DOUBLET_WEIGHTS as NA_DOUBLET_WEIGHTS,
    NA_I as NA_I,
    SINGLE_BAND_MIN_FWHM_NM as SINGLE_BAND_MIN_FWHM_NM,
    SINGLE_BAND_PROMINENCE as SINGLE_BAND_PROMINENCE,
    TECHNOLOGIES as TECHNOLOGIES,
    UPPER_BOUND as UPPER_BOUND,
    VALIDATED as VALIDATED,
    XE_I as XE_I,
    LineCalibration as LineCalibration,
    _gauss as _gauss,
    _planck as _planck,
    calibration as calibration,
    calibration_spectra as calibration_spectra,
    column_names as column_names,
    extend_spectrum as extend_spectrum,
    is_single_band_emitter as is_single_band_emitter,
    is_validated as is_validated,
)
from ._validation import (
    ERROR_BAND as ERROR_BAND,
    ERROR_QUANTILES as ERROR_QUANTILES,
    MIN_CLASS_LAMPS as MIN_CLASS_LAMPS,
    UPPER_BOUND_ERROR as UPPER_BOUND_ERROR,
    VALIDATION_BANDS_NM as VALIDATION_BANDS_NM,
    NirError as NirError,
    extension_error as extension_error,
    validate_extension as validate_extension,
)
