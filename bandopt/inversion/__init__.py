"""Physics-based inversion: band radiances -> lamp spectrum, surface, metrics.

A pixel's band radiance is modelled as the forward model builds it
(`bandopt.scene`): lamp spectrum x surface reflectance x upward transmittance,
plus moonlight on the same surface and the Moon's path radiance,

    y_b = α Σ_λ W_bλ T_e(λ) ρ(λ) S(λ)/π + β Σ_λ W_bλ [T ρ M/π + P](λ),  α, β ≥ 0,

with `W` the band weights (`scene.band_weights`), `T` the upward transmittance,
`T_e = T_dir + k T_dif` the lamp light's transmittance in the scenes'
neighbourhood (`scene.Factors.emission_transmittance`; `T_e = T` for a uniform
neighbourhood), `S` a lamp spectrum per
lumen, `M`, `P` the Moon's ground irradiance and path radiance, `α` the
illuminance and `β` the Moon's brightness. Nothing is assumed about the
pixel's brightness: `α` and `β` are solved for in closed form.

**Priors (learned from training lamps and surfaces only).**

- Lamp: a class-balanced mixture over the training lamps (each level-2 class
  the same prior mass, each lamp the same within its class) — a sparse
  non-negative mixture in its one-component limit, so the posterior
  is a weighted set of real, measured spectra. Measured lamps of classes too
  small to be scored (e.g. low-pressure sodium) always belong to the prior:
  they are never scored, so they cannot leak. Optionally
  (`modelled_per_class > 0`, default 0: measured lamps only) the prior also
  holds modelled lamps of rare classes (`modelled_lamps`): spectra of the
  physical lamp models (`bandopt.lampmodels`) calibrated on that fit's
  measured training lamps only, labelled with their class, in the prior and
  the type posteriors but never scored. Optionally (`mixtures > 0`; the
  default of `bandopt evaluate`, estimator `inversion-moon-mix`) the prior
  also holds pairwise blends of two of its own lamps of one class
  (`mixture_lamps`): a new lamp usually lies between the library's lamps,
  and with the test lamp itself in the prior the error is ~0, so the
  prior's coverage of lamp space, not the scene, is what limits it.
- Surface: a low-rank basis (weighted PCA, each surface type the same weight)
  of the library reflectances (`bandopt.datasets.surfaces`), with candidate
  surfaces given by what is known (`SURFACE_MODES`): nothing (the mean of
  every road-scene surface type), the surface class (its mean and measured
  samples), or a daytime Sentinel-2 MSI measurement (`ESA2017`) with the
  L2A accuracy specification `σ = 0.05 ρ + 0.005` (`Doxani2018`) inverted to
  basis coefficients by regularised least squares.
- Atmosphere: the training atmospheres, equally likely.

**Estimates.** Each candidate (lamp, surface, atmosphere) is scored by its
weighted least-squares misfit χ² with the relative band error `σ_rel`
(chosen on inner folds); the posterior over lamps is `∝ prior · Σ exp(-χ²/2)`.
LER, G and CCT are posterior means of the candidates' metrics, computed from
their measured spectra with `bandopt.photometry` — physical by construction
(a convex combination of real lamps' values). CCT is averaged in mired over
lamps where a CCT is meaningful and is `None` when the posterior says the lamp
most likely has none (|Duv| > 0.05).

**Why no continuous refinement.** We also tried refining the three best
candidates per pixel with `optimistix.LevenbergMarquardt` (a smooth
multiplicative change of the lamp spectrum, `S_k exp(Σ c_j P_j)` with Legendre
`P_1..P_4` and a Gaussian prior, plus the surface coefficients). On the
'quick' preset's three outer folds (recommended bands) it raised the
class-balanced LER error from 14.3 / 16.5 / 15.4 to 20.3 / 20.6 / 15.4 lm/W and
the CCT error on every fold, at ~200x the run time: with a handful of bands the
data cannot tell a lamp's tilt from its surface's, so the extra freedom fits
noise. The discrete posterior is exact for its prior, fast and physical.

**Intervals and reject.** The 90 % interval is the posterior's 5-95 %
range widened by a split-conformal factor (`Romano2019`) calibrated on the
inner folds' held-out lamps (class-balanced), then clipped to the physical
range. A pixel whose best reduced χ² at the sharp band error `FLAG_NOISE`,
under each inner fold's prior, ranks above the 95th percentile of that
fold's held-out lamps of the type it is called (a cross-conformal,
class-conditional test at 5 %, `Inversion.known_type_p_value`, `Vovk2015`)
is flagged `unexplained` (and its type is not guessed).

**Type probabilities and modelled near-infrared.** Optionally
(`calibrate_probabilities`) the level-1/-2 probabilities are tempered with a
temperature that grows with the pixel's misfit, fitted on held-out lamps of
the types the prior knows (`bandopt.calibration`); lamps of a type it lacks
are left to the `unexplained` flag, and both groups' calibration is
reported. Optionally (`nir_error`) every lamp
whose 780-900 nm part is modelled enters the prior with two copies at the
low and high end of that model's measured error (`nir_variants`), sharing its
prior mass. `bandopt.estimators.InversionConfig` turns both on.

**Modules** (each imports only from those above it):

- `_conditions`: `Conditions`, what is known of the scene;
- `_surfaces`: the surface prior (`SurfaceBasis`, `surface_basis`,
  `surface_candidates`) and the simulated Sentinel-2 measurement;
- `_lamps`: lamp sets (`LampSet`, `library_lamps`, `own_lamps`,
  `planck_lamps`, `tm30_lamps`, `modelled_lamps`);
- `_variants`: lamps derived from a prior's own (`mixture_lamps`,
  `shifted_lamps`, `nir_variants`, `variant_base`);
- `_prior`: the class-balanced lamp prior (`LampPrior`, `lamp_prior`);
- `_scoring`: candidates, χ², the compiled scoring and the band-error model;
- `_prune`: scoring only the lamps that can matter, with a bounded error;
- `_metrics`: posterior means and ranges of LER, G and CCT, `PHYSICAL_RANGE`;
- `_model`: `Inversion` (its `predict` in chunks of bounded memory),
  `build_inversion`;
- `_result`: `InversionResult`, `top_two`;
- `_calibrate`: conformal factors, interval units, probability temperatures;
- `_fit`: `fit_inversion`;
- `_estimators`: `InversionOptions` and the named variants of `cross_validate`;
- `_context`: the inversion on a `search.Context` (`context_setup`,
  `context_moon`, `fit_for_context`, `augment_with_modelled`);
- `_crossval`: `cross_validate` and its records;
- `_leave_class_out`: `leave_one_class_out`;
- `_summary`: `summarise`, `paired_differences`, `estimator_differences`.

Besides the public names, the private ones that tests and experiments reach
(`_basis`, `_score`, `_posterior_metrics`, ...) are re-exported here.
"""

from ._calibrate import (
    FLAG_NOISE as FLAG_NOISE,
    GLOBAL_LEVEL2 as GLOBAL_LEVEL2,
    INTERVAL_OFFSET_GRID as INTERVAL_OFFSET_GRID,
    UNEXPLAINED_QUANTILE as UNEXPLAINED_QUANTILE,
    _conformal_factors as _conformal_factors,
    _narrowest_intervals as _narrowest_intervals,
    _row_weights as _row_weights,
)
from ._conditions import (
    Conditions as Conditions,
)
from ._context import (
    MODEL_NOISE_SEED_OFFSET as MODEL_NOISE_SEED_OFFSET,
    Augmented as Augmented,
    _basis as _basis,
    augment_with_modelled as augment_with_modelled,
    band_weights_on as band_weights_on,
    context_moon as context_moon,
    context_scenarios as context_scenarios,
    context_setup as context_setup,
    fit_for_context as fit_for_context,
    moon_amplitudes as moon_amplitudes,
)
from ._crossval import (
    _check_never_scored as _check_never_scored,
    _out_of_range as _out_of_range,
    _smaller_library as _smaller_library,
    cross_validate as cross_validate,
)
from ._estimators import (
    DEFAULT_ESTIMATOR as DEFAULT_ESTIMATOR,
    ESTIMATORS as ESTIMATORS,
    EVIDENCE_ESTIMATOR as EVIDENCE_ESTIMATOR,
    LABELLED as LABELLED,
    MIX_ESTIMATOR as MIX_ESTIMATOR,
    MIX_METRIC_ESTIMATOR as MIX_METRIC_ESTIMATOR,
    MODELLED_ESTIMATORS as MODELLED_ESTIMATORS,
    MOON_ESTIMATOR as MOON_ESTIMATOR,
    MOON_UNSEEN_ESTIMATOR as MOON_UNSEEN_ESTIMATOR,
    NARROW_ESTIMATOR as NARROW_ESTIMATOR,
    PLAIN as PLAIN,
    PLANCK_ESTIMATOR as PLANCK_ESTIMATOR,
    SHIFT_ESTIMATOR as SHIFT_ESTIMATOR,
    TM30_ESTIMATOR as TM30_ESTIMATOR,
    InversionOptions as InversionOptions,
    options_of as options_of,
)
from ._fit import (
    CALIBRATIONS as CALIBRATIONS,
    SIGMA_RULES as SIGMA_RULES,
    fit_inversion as fit_inversion,
)
from ._lamps import (
    MIN_CALIBRATION_LAMPS as MIN_CALIBRATION_LAMPS,
    MODELLED_CLASSES as MODELLED_CLASSES,
    MODELLED_SEED_STRIDE as MODELLED_SEED_STRIDE,
    LampSet as LampSet,
    library_lamps as library_lamps,
    modelled_lamps as modelled_lamps,
    own_lamps as own_lamps,
    planck_lamps as planck_lamps,
    tm30_lamps as tm30_lamps,
    with_planck_lamps as with_planck_lamps,
    with_tm30_lamps as with_tm30_lamps,
)
from ._leave_class_out import (
    leave_one_class_out as leave_one_class_out,
)
from ._metrics import (
    COVERAGE as COVERAGE,
    INTERVAL_FLOOR as INTERVAL_FLOOR,
    METRIC_ROWS as METRIC_ROWS,
    PHYSICAL_RANGE as PHYSICAL_RANGE,
    _posterior_metrics as _posterior_metrics,
    _to_model as _to_model,
    _widened as _widened,
    weighted_quantile as weighted_quantile,
)
from ._model import (
    FlagFold as FlagFold,
    Inversion as Inversion,
    _result as _result,
    build_inversion as build_inversion,
)
from ._prior import (
    LampPrior as LampPrior,
    lamp_prior as lamp_prior,
)
from ._prune import (
    PRUNE_TOLERANCE as PRUNE_TOLERANCE,
    _score_pruned as _score_pruned,
    prune_margin as prune_margin,
    score_pruned as score_pruned,
)
from ._records import (
    LampScore as LampScore,
    interval_fields as interval_fields,
    record_errors as record_errors,
)
from ._result import (
    CLOSE_CALL_RATIO as CLOSE_CALL_RATIO,
    InversionResult as InversionResult,
    top_two as top_two,
)
from ._scoring import (
    CHUNK as CHUNK,
    CHUNK_PRIOR as CHUNK_PRIOR,
    FLOAT32_TOLERANCE as FLOAT32_TOLERANCE,
    FLOOR_GRID as FLOOR_GRID,
    K_BUCKET as K_BUCKET,
    PREDICT_MEMORY_BYTES as PREDICT_MEMORY_BYTES,
    SCORE_DTYPES as SCORE_DTYPES,
    SHARED_CHUNK as SHARED_CHUNK,
    SIGMA_FLOOR as SIGMA_FLOOR,
    SIGMA_REL_GRID as SIGMA_REL_GRID,
    _chi2 as _chi2,
    _chunk as _chunk,
    _design as _design,
    _log_sum_chi as _log_sum_chi,
    _score as _score,
    _score_chunk as _score_chunk,
    log_evidence as log_evidence,
    predict_chunk_bytes as predict_chunk_bytes,
    predict_chunk_pixels as predict_chunk_pixels,
)
from ._summary import (
    ESTIMATOR_PAIRS as ESTIMATOR_PAIRS,
    PAIRED_COLUMNS as PAIRED_COLUMNS,
    SUMMARY_COLUMNS as SUMMARY_COLUMNS,
    estimator_differences as estimator_differences,
    paired_differences as paired_differences,
    summarise as summarise,
)
from ._surfaces import (
    PRIOR_SURFACES as PRIOR_SURFACES,
    S2_FILE as S2_FILE,
    S2_MIN_INSIDE as S2_MIN_INSIDE,
    S2_SIGMA as S2_SIGMA,
    SURFACE_MODES as SURFACE_MODES,
    SURFACE_RANK as SURFACE_RANK,
    SurfaceBasis as SurfaceBasis,
    measured_surfaces as measured_surfaces,
    observe_sentinel2 as observe_sentinel2,
    sentinel2_response as sentinel2_response,
    surface_basis as surface_basis,
    surface_candidates as surface_candidates,
    surface_from_sentinel2 as surface_from_sentinel2,
)
from ._variants import (
    CROSS_MIX_PAIRS as CROSS_MIX_PAIRS,
    CROSS_MIX_SHARES as CROSS_MIX_SHARES,
    DIRECT_LED_MAX_FWHM_NM as DIRECT_LED_MAX_FWHM_NM,
    MIX_FRACTIONS as MIX_FRACTIONS,
    MIX_PAIRS as MIX_PAIRS,
    NIR_VARIANT_TAGS as NIR_VARIANT_TAGS,
    PEAK_SHIFTS_NM as PEAK_SHIFTS_NM,
    cross_mixture_lamps as cross_mixture_lamps,
    direct_emitters as direct_emitters,
    mixture_lamps as mixture_lamps,
    nir_variants as nir_variants,
    shifted_lamps as shifted_lamps,
    variant_base as variant_base,
)
