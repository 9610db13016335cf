"""Physical lamp models: small parametric spectra calibrated on the measured lamps.

Each model family is a pure JAX function of a few bounded parameters that
returns a spectrum on any wavelength grid:

- `pc_led` (classes `led_warm`, `led_cool`, `led_amber`): a blue/violet pump,
  a split Gaussian in wavelength (centre 395-475 nm), plus two phosphor bands,
  each a split (skewed) Gaussian in photon energy (`Ohno2005` models LEDs by
  Gaussian bands). The pump may vanish (PC amber: phosphor only); over the
  parameter bounds the CCT spans 1800-6500 K (tested).
- `hps` (`hps`): the self-reversed, pressure-broadened Na D line
  (`DeGroot1986`): an optically thick core `1 - exp(-τ φ(λ))` with an
  asymmetric Lorentzian profile φ (red wing wider), times the absorption
  `exp(-τ_a g(λ))` of the cooler mantle, g Gaussians at the D lines; plus the
  Na lines 498.3, 515.3, 568.8, 615.4 nm, the pressure-broadened (Lorentzian)
  818.3/819.5 nm doublet, K 766.5/769.9 nm, Hg 435.8/546.1 nm (amalgam) and a
  weak Planckian continuum.
- `lps` (`lps`): Na D 589.0/589.6 nm and the weak Na lines 498.3, 515.3,
  568.8, 615.4 and 818.3/819.5 nm, pseudo-Voigt profiles (Lorentzian fraction
  η) with one width, and a weak continuum. Ne/Ar fill-gas lines are omitted.
- `mercury` (`mercury`): Hg 404.7, 435.8, 491.6, 546.1, 577.0, 579.1 nm with one
  Gaussian width, the red phosphor bands of colour-corrected lamps (centres
  free in 605-635 and 685-715 nm, the Eu³⁺ emission of YVO₄:Eu) and a
  Planckian continuum.
- `metal_halide` (`metal_halide`): the Hg lines, Tl 535.0, In 410.2/451.1,
  Li 670.8 nm, the HPS Na D profile with Na 568.8/615.4/818.3/819.5 and K
  766.5/769.9 nm, a Planckian continuum and one broad Gaussian hump for the
  Sc and rare-earth (Dy, Ho, Tm) line forests, which are not resolved line by
  line at the library's 1-5 nm resolution.

Line wavelengths are NIST ASD air wavelengths (`NISTASD`). Components of an
unresolved multiplet carry equal weights. Every component is normalised to unit
area on the grid, so amplitudes are power ratios to the family's reference
component (`REFERENCE`).

**Parametrisation.** Every parameter has bounds `lo < p < hi` built in:
`p = lo + (hi - lo) sigmoid(z)` with z unconstrained (amplitudes are natural
logarithms of power ratios, bounded the same way). `spectrum(family, z, λ)` is
jit/vmap/grad-able.

**Fitting** (`fit`): Levenberg-Marquardt (optimistix, float64) on the
spectrum normalised to unit visible power (`∫_380^780 S dλ = 1`), over the
lamp's measured range only (never its near-infrared extension). A spectrum
sampled coarser than 1 nm (the NIST and CIE sets, 5 nm, linearly interpolated
onto the library grid) is compared with the model seen through the same
instrument (`sampling_matrix`: triangular bandpass of the step's FWHM, sampling,
linear interpolation), which keeps each line's power; the residuals are taken
at the instrument's own samples. Four starts
(the default plus seeded perturbations), the best kept. A tiny pull of z towards
the default (weight `RIDGE`) keeps parameters that the data do not constrain
(e.g. the 819 nm doublet of a lamp measured to 780 nm) finite.

**Calibration** (`calibrate`): per level-2 class, the fitted z of its measured
lamps give a mean and a covariance shrunk halfway to its diagonal
(`SHRINKAGE`). Near-infrared parameters (`nir=True`) are calibrated only on
lamps measured beyond `NIR_MEASURED_NM`, independently of the others; a class
whose calibration lamps all stop at 780 nm gets samples that stop there too:
beyond it they are the library's near-infrared extension
(`bandopt.datasets.nir`, flag `extended`) or NaN (`extend_nir=False`),
exactly as a measured lamp of the same range.

**Use (inversion prior, training augmentation).**
`sample_library(classes, n_per_class, seed, train_lamps=ids)` calibrates ONLY
on the measured lamps listed in `train_lamps` (the training lamps of a
cross-validation fold, so no test lamp leaks into the prior), samples
parameters from the calibrated Gaussian and returns a `LampLibrary` in the
library's units (W nm⁻¹ lm⁻¹) and grid, every record `modelled=True`,
`source="bandopt lamp model <class>"`. Modelled spectra may TRAIN but must
never SCORE: `LampLibrary.is_scored` is False for them, and every result that
used them must say so. `log_prior(cal, z)` gives the calibrated Gaussian
log-density for use as an inversion prior.

**Validation** (`write_validation`, `make lamp-models`): fit quality and
leave-one-lamp-out per class, scored on measured lamps only.

Modules: `_families` (the line lists, the bounded parameters, the five
families and `spectrum`), `_fit` (the instrument's sampling and `fit`),
`_calibrate` (`Calibration`, `calibrate` and `sample_library` on the library)
and `_validation` (`validate_class`, `write_validation`); this package
re-exports their names.
"""

from ..spectra import GRID_1NM as GRID_1NM
from ._calibrate import (
    SHRINKAGE as SHRINKAGE,
    Z_CLIP as Z_CLIP,
    Calibration as Calibration,
    calibrate as calibrate,
    calibrate_fits as calibrate_fits,
    fit_library_lamp as fit_library_lamp,
    log_prior as log_prior,
    model_spectra as model_spectra,
    sample_library as sample_library,
    sample_z as sample_z,
)
from ._families import (
    FAMILIES as FAMILIES,
    FAMILY_OF_CLASS as FAMILY_OF_CLASS,
    HC_EV_NM as HC_EV_NM,
    HG_405 as HG_405,
    HG_436 as HG_436,
    HG_492 as HG_492,
    HG_546 as HG_546,
    HG_577 as HG_577,
    HG_579 as HG_579,
    HPS as HPS,
    IN_410 as IN_410,
    IN_451 as IN_451,
    K_767 as K_767,
    LI_671 as LI_671,
    LPS as LPS,
    MERCURY as MERCURY,
    METAL_HALIDE as METAL_HALIDE,
    NA_498 as NA_498,
    NA_515 as NA_515,
    NA_568 as NA_568,
    NA_615 as NA_615,
    NA_819 as NA_819,
    NA_D as NA_D,
    PC_LED as PC_LED,
    REFERENCE as REFERENCE,
    TL_535 as TL_535,
    Family as Family,
    Param as Param,
    _planck as _planck,
    family_of as family_of,
    per_lumen as per_lumen,
    spectrum as spectrum,
    to_values as to_values,
    to_z as to_z,
    visible_normalised as visible_normalised,
)
from ._fit import (
    MAX_STEPS as MAX_STEPS,
    N_STARTS as N_STARTS,
    NIR_MEASURED_NM as NIR_MEASURED_NM,
    RIDGE as RIDGE,
    Fit as Fit,
    fit as fit,
    native_step_nm as native_step_nm,
    sampling_matrix as sampling_matrix,
)
from ._validation import (
    VALIDATION_COLUMNS as VALIDATION_COLUMNS,
    VISIBLE_NM as VISIBLE_NM,
    nrms as nrms,
    summarise_validation as summarise_validation,
    unit_visible as unit_visible,
    validate_class as validate_class,
    validation_figure as validation_figure,
    write_validation as write_validation,
)


__all__ = [
    "FAMILIES",
    "FAMILY_OF_CLASS",
    "GRID_1NM",
    "Calibration",
    "Family",
    "Fit",
    "Param",
    "calibrate",
    "calibrate_fits",
    "family_of",
    "fit",
    "fit_library_lamp",
    "log_prior",
    "model_spectra",
    "native_step_nm",
    "per_lumen",
    "sample_library",
    "sample_z",
    "spectrum",
    "summarise_validation",
    "to_values",
    "to_z",
    "validate_class",
    "validation_figure",
    "write_validation",
]
