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

Modules: `_features` (the features and `spectral_features`), `_identify`
(the thresholds, `technology_scores` and `identify_technology`) and
`_extension` (`extend_user_spectrum`); every public name of the three is
re-exported here.
"""

from ._extension import (
    NIR_CHOICES as NIR_CHOICES,
    UserExtension as UserExtension,
    extend_user_spectrum as extend_user_spectrum,
)
from ._features import (
    BASELINE_WIDTH_NM as BASELINE_WIDTH_NM,
    BLUE_NM as BLUE_NM,
    COMMON_LINE_EXCLUSION_NM as COMMON_LINE_EXCLUSION_NM,
    COMMON_LINES_NM as COMMON_LINES_NM,
    EU_RED_NM as EU_RED_NM,
    HG_LINES_NM as HG_LINES_NM,
    HG_YELLOW_NM as HG_YELLOW_NM,
    HPS_BAND_NM as HPS_BAND_NM,
    LINE_TOLERANCE_NM as LINE_TOLERANCE_NM,
    MH_LINES_RANGE_NM as MH_LINES_RANGE_NM,
    NA_BLUE_NM as NA_BLUE_NM,
    NA_CORE_HALF_WIDTH_NM as NA_CORE_HALF_WIDTH_NM,
    NA_D_NM as NA_D_NM,
    NA_IR_NM as NA_IR_NM,
    NARROW_PEAK_MAX_FWHM_NM as NARROW_PEAK_MAX_FWHM_NM,
    NARROW_PEAK_MIN_PROMINENCE as NARROW_PEAK_MIN_PROMINENCE,
    PLANCK_RANGE_NM as PLANCK_RANGE_NM,
    PLANCK_TEMPERATURES_K as PLANCK_TEMPERATURES_K,
    PROMINENCE_GUARD as PROMINENCE_GUARD,
    SMOOTH_FWHM_NM as SMOOTH_FWHM_NM,
    TL_GREEN_NM as TL_GREEN_NM,
    VISIBLE_NM as VISIBLE_NM,
    SpectralFeatures as SpectralFeatures,
    spectral_features as spectral_features,
)
from ._identify import (
    AMBIGUITY_RATIO as AMBIGUITY_RATIO,
    EU_MIN_PROMINENCE as EU_MIN_PROMINENCE,
    HG_MIN_PROMINENCE as HG_MIN_PROMINENCE,
    HPS_MAX_BLUE_FRACTION as HPS_MAX_BLUE_FRACTION,
    HPS_MIN_BAND_FRACTION as HPS_MIN_BAND_FRACTION,
    INCANDESCENT_MAX_BLUE_FRACTION as INCANDESCENT_MAX_BLUE_FRACTION,
    LED_MAX_NARROW_PEAKS as LED_MAX_NARROW_PEAKS,
    LPS_MAX_FWHM_NM as LPS_MAX_FWHM_NM,
    LPS_MIN_CORE_FRACTION as LPS_MIN_CORE_FRACTION,
    MAX_LINE_FRACTION_SMOOTH as MAX_LINE_FRACTION_SMOOTH,
    MERCURY_MIN_LINE_FRACTION as MERCURY_MIN_LINE_FRACTION,
    MH_MIN_OTHER_LINES as MH_MIN_OTHER_LINES,
    NA_BLUE_MIN_PROMINENCE as NA_BLUE_MIN_PROMINENCE,
    NA_IR_MIN_PROMINENCE as NA_IR_MIN_PROMINENCE,
    PLANCK_MAX_RESIDUAL as PLANCK_MAX_RESIDUAL,
    SODIUM_MIN_LINE_FRACTION as SODIUM_MIN_LINE_FRACTION,
    SOFTNESS as SOFTNESS,
    TL_MIN_PROMINENCE as TL_MIN_PROMINENCE,
    YELLOW_GREEN_MERCURY as YELLOW_GREEN_MERCURY,
    TechnologyEvidence as TechnologyEvidence,
    identify_technology as identify_technology,
    technology_scores as technology_scores,
)
