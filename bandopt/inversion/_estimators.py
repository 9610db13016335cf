"""Names of the estimators `cross_validate` and `bandopt evaluate` know: the
inversion's variants (`DEFAULT_ESTIMATOR` and the steps that lead to it) and
the learned baselines."""

ESTIMATORS = ("inversion", "ridge", "kernel")
"""Estimators `cross_validate` and `bandopt evaluate` know (`cross_validate`
also `MODELLED_ESTIMATORS`)."""


MODELLED_ESTIMATORS = ("inversion+models", "ridge+models", "kernel+models")
"""`cross_validate` estimators that train on modelled lamps too: the inversion
with them in its prior, the ridge and kernel ridge with their scenes among
the training rows (`augment_with_modelled`)."""


MOON_ESTIMATOR = "inversion-moon"
"""`cross_validate` estimator: the inversion told each pixel's Moon brightness
(`context_moon`; known from the acquisition's time and place) instead of
fitting it."""


MOON_UNSEEN_ESTIMATOR = "inversion-moon-loco"
"""`cross_validate` estimator: `MOON_ESTIMATOR` with its 90 % intervals
calibrated on training classes held out in turn (leave one class out,
`fit_inversion(calibration="classes")`) instead of held-out lamps of known
classes: the same point estimates, intervals meant to hold for lamp types
the prior does not know."""


EVIDENCE_ESTIMATOR = "inversion-evidence"
"""`cross_validate` estimator: the inversion with `σ_rel` chosen by held-out
log evidence (`fit_inversion(sigma_rule="evidence")`) instead of metric error."""


MIX_ESTIMATOR = "inversion-moon-mix"
"""`cross_validate` estimator: `MOON_ESTIMATOR` with pairwise same-class
mixtures of its prior's lamps in every prior (`fit_inversion(mixtures=
MIX_PAIRS)`, `mixture_lamps`)."""


MIX_METRIC_ESTIMATOR = "inversion-moon-mix-metric"
"""`cross_validate` estimator: `MIX_ESTIMATOR` with each metric estimated
with its own band-error model, `σ_rel` and floor (`fit_inversion(
sigma_rule="per-metric", floor_grid=FLOOR_GRID)`)."""


NARROW_ESTIMATOR = "inversion-moon-mix-metric-narrow"
"""`cross_validate` estimator: `MIX_METRIC_ESTIMATOR` with each metric's
interval unit offset chosen for the narrowest calibrated intervals
(`fit_inversion(interval_offsets=INTERVAL_OFFSET_GRID)`): the same
estimates, other intervals. Asked for together with `MIX_METRIC_ESTIMATOR`,
both come from one fit (that one at offset 0, `Inversion.
with_interval_offset`)."""


SHIFT_ESTIMATOR = "inversion-moon-mix-metric-narrow-shift"
"""`NARROW_ESTIMATOR` with wavelength-shifted copies of the prior's
direct-emission LEDs in every prior (`fit_inversion(peak_shifts=
PEAK_SHIFTS_NM)`, `shifted_lamps`)."""


PLANCK_ESTIMATOR = "inversion-moon-mix-metric-narrow-planck"
"""`NARROW_ESTIMATOR` with the library's modelled incandescent spectra
(`planck_lamps`) in every prior, beside the never-scored measured lamps:
modelled spectra train, never score; its records say `modelled_in_prior`."""


DEFAULT_ESTIMATOR = "inversion-moon-mix-metric-narrow-shift-planck"
"""`NARROW_ESTIMATOR` with both `SHIFT_ESTIMATOR`'s shifted LEDs and
`PLANCK_ESTIMATOR`'s modelled incandescent spectra in every prior: what
`bandopt evaluate` does by default."""


TM30_ESTIMATOR = "inversion-moon-mix-metric-narrow-shift-planck-tm30"
"""`DEFAULT_ESTIMATOR` with the measured IES TM-30-15 lamps the library lacks
(`tm30_lamps`) in every prior, beside the never-scored measured lamps: they
train, never score; its records say `tm30_in_prior`."""
