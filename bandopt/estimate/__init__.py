"""Brightness-free estimators of LER, the G index and CCT from band radiances.

The satellite does not know a lamp's power or the albedo under it, so every
estimator here reads only *ratios* of band radiances; scaling a pixel's
radiance by any positive factor leaves the estimate unchanged.

Two families:

(a) **Thesis-style ratio estimators** (`DeMeester2019`, chapter 4): one ratio
    with fitted constants, `y = a + b·r`. LER from a band approximating V(λ)
    over a panchromatic band (`r = L_V / L_pan`), G from a blue band over the
    V band (`r = log(L_blue / L_V)`), CCT (as mired, `10⁶/CCT`) from a blue
    over a red band (`r = log(L_blue / L_red)`). `ratio_features`.

(b) **Ridge regression on log band ratios** (`Hoerl1970`): the features are the
    centred log radiances `x_j = log(L_j/L̄ + δ) - mean_k log(L_k/L̄ + δ)` (the
    centred log-ratio transform, symmetric in the bands; `L̄` the mean band
    radiance of the pixel, `δ = LOG_FLOOR`), optionally with their pairwise
    products (`degree=2`). Features are standardised with the (weighted)
    training mean and spread and the ridge weights solved in closed form, so a
    band search can fit the estimator inside its loss (variable projection:
    band parameters are the only free variables). CCT is modelled in mired.

Losses and errors are **class-balanced**: each scored level-2 class weighs
the same, and within a class each lamp the same (`bandopt.folds`). A single
band (no pan) has no ratio: its estimate is the training mean of the metric.

**Modules** (each imports only from those above it):

- `_truth`: `METRICS`, `TARGETS`, `lamp_truth`, `truth_with_reasons`, the
  model space (`to_model_space`, `MIRED`) and its range (`MODEL_BOUNDS`);
- `_ridge`: the features (`log_ratio_features`, `ratio_features`) and the
  closed-form ridge (`ridge_solve`, `fit_ridge`, `RidgeFit`);
- `_table`: `LampTable`, `cv_residuals`, `cv_loss`, `lamp_abs_errors`;
- `_fitted`: `Estimator`, `fit_estimator`, `training_bounds`;
- `_kernel`: `KernelEstimator`, `fit_kernel_estimator`.

Besides the public names, the private ones of the former single module
(`_inner_scores`, `_fit_jit`, `_sqdist`, `_krr_all`) are re-exported here.
"""

from ._fitted import (
    DEGREES as DEGREES,
    Estimator as Estimator,
    _fit_jit as _fit_jit,
    _inner_scores as _inner_scores,
    fit_estimator as fit_estimator,
    training_bounds as training_bounds,
)
from ._kernel import (
    KERNEL_GAMMAS as KERNEL_GAMMAS,
    KERNEL_LAMBDAS as KERNEL_LAMBDAS,
    KERNEL_MAX_ROWS as KERNEL_MAX_ROWS,
    KernelEstimator as KernelEstimator,
    _krr_all as _krr_all,
    _sqdist as _sqdist,
    fit_kernel_estimator as fit_kernel_estimator,
)
from ._ridge import (
    LAMBDA_GRID as LAMBDA_GRID,
    LOG_FLOOR as LOG_FLOOR,
    SEARCH_LAMBDA as SEARCH_LAMBDA,
    RidgeFit as RidgeFit,
    fit_ratio_estimator as fit_ratio_estimator,
    fit_ridge as fit_ridge,
    log_ratio_features as log_ratio_features,
    ratio_features as ratio_features,
    ridge_solve as ridge_solve,
    weighted_standardisation as weighted_standardisation,
)
from ._table import (
    LampTable as LampTable,
    cv_loss as cv_loss,
    cv_residuals as cv_residuals,
    lamp_abs_errors as lamp_abs_errors,
)
from ._truth import (
    CCT_RANGE_K as CCT_RANGE_K,
    METRICS as METRICS,
    MIRED as MIRED,
    MODEL_BOUNDS as MODEL_BOUNDS,
    NO_VISIBLE_LIGHT as NO_VISIBLE_LIGHT,
    TARGETS as TARGETS,
    UNITS as UNITS,
    bound_model_space as bound_model_space,
    from_model_space as from_model_space,
    lamp_truth as lamp_truth,
    metric_mask as metric_mask,
    resolve_target as resolve_target,
    to_model_space as to_model_space,
    truth_with_reasons as truth_with_reasons,
)


__all__ = [
    "LAMBDA_GRID",
    "LOG_FLOOR",
    "METRICS",
    "SEARCH_LAMBDA",
    "TARGETS",
    "Estimator",
    "KernelEstimator",
    "LampTable",
    "RidgeFit",
    "cv_loss",
    "cv_residuals",
    "fit_estimator",
    "fit_kernel_estimator",
    "fit_ratio_estimator",
    "fit_ridge",
    "from_model_space",
    "lamp_abs_errors",
    "lamp_truth",
    "log_ratio_features",
    "metric_mask",
    "ratio_features",
    "resolve_target",
    "ridge_solve",
    "to_model_space",
    "truth_with_reasons",
    "weighted_standardisation",
]
