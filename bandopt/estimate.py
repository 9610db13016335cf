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
"""

import dataclasses
from collections.abc import Sequence

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike, Bool, Float

from .folds import class_balanced_weights
from .names import CanonicalMapping
from .photometry import (
    CCT_MAX_K,
    CCT_MIN_K,
    DUV_MAX,
    G_CAP,
    K_M_LM_PER_W,
    metrics as photometric_metrics,
)


METRICS: tuple[str, ...] = ("LER", "G", "CCT")
"""Estimated metrics, in the order of every `(..., 3)` array here."""

UNITS = {"LER": "lm/W", "G": "1", "CCT": "K"}

TARGETS: dict[str, tuple[str, ...]] = {
    "ler": ("LER",),
    "g": ("G",),
    "cct": ("CCT",),
    "all": METRICS,
}
"""Search targets and the metrics each one scores."""

LOG_FLOOR = 1e-6
"""δ added to relative band radiance before the logarithm (a band that sees no
light gives log δ, not -inf). [1]"""

LAMBDA_GRID: tuple[float, ...] = (1e-6, 1e-4, 1e-3, 1e-2, 1e-1, 1.0)
"""Ridge strengths (on standardised features, weights summing to 1) chosen
from by inner cross-validation."""

SEARCH_LAMBDA = 1e-3
"""Ridge strength used inside band-search losses (keeps overlapping bands
well conditioned; the reported models re-choose it from `LAMBDA_GRID`)."""

MIRED = 1e6
"""`mired = MIRED / CCT[K]`."""

CCT_RANGE_K = (CCT_MIN_K, CCT_MAX_K)
"""Predicted CCTs are clipped to the range where a CCT is meaningful
(`photometry.CCT_MIN_K`-`CCT_MAX_K`), i.e. mired to 40-1000. [K]"""


def resolve_target(name: str) -> str:
    """Canonical target name (`ler`, `g`, `cct`, `all`; case and separators
    ignored, the `bandopt.names` rule)."""
    targets = CanonicalMapping({k: k for k in TARGETS})
    if name not in targets:
        raise ValueError(f"Unknown target {name!r}; expected one of {list(TARGETS)}.")
    return targets[name]


def metric_mask(target: str) -> np.ndarray:
    """Boolean (3,) mask of the metrics a target scores."""
    used = TARGETS[resolve_target(target)]
    return np.array([m in used for m in METRICS])


# ------------------------------------------------------------------------------
# Ground truth


def lamp_truth(
    spectra: Float[ArrayLike, "l w"], wavelength_nm: Float[ArrayLike, " w"]
) -> tuple[np.ndarray, np.ndarray]:
    """Photometric truth per lamp from its full spectrum.

    Returns `(values, valid)`, both `(l, 3)` in `METRICS` order: LER [lm W⁻¹]
    (380-780 nm), G [1] (capped at `photometry.G_CAP` where flagged; the cap is
    kept as a valid value) and CCT [K] (valid only where meaningful, i.e.
    `CCT_flag` False). A metric is invalid (NaN) by the rule of
    `truth_with_reasons`. Spectra must cover 380-780 nm on a 1 nm grid.
    """
    values, _ = truth_with_reasons(spectra, wavelength_nm)
    return values, np.isfinite(values)


NO_VISIBLE_LIGHT = "no light in 380-780 nm (visible power 0): undefined"


def truth_with_reasons(
    spectra: Float[ArrayLike, "l w"], wavelength_nm: Float[ArrayLike, " w"]
) -> tuple[np.ndarray, list[dict[str, str]]]:
    """The one rule for an undefined photometric truth, with its reason.

    Returns `(values, reasons)`: values `(l, 3)` in `METRICS` order, NaN where
    undefined, and per lamp a dict metric -> why it is undefined:

    - LER: no light in 380-780 nm (0/0);
    - G: no light the eye sees (∫ V S = 0 over 380-780 nm: G compares the
      blue light with it); without blue light but with visible light G is
      `G_CAP`, flagged, and valid (low-pressure sodium);
    - CCT: no light, or not meaningful: outside `CCT_MIN_K`-`CCT_MAX_K` or
      |Duv| > `DUV_MAX` (the reason gives the number).

    `bandopt metrics` and `bandopt evaluate` both report truth by this rule.
    Spectra must cover 380-780 nm on a 1 nm grid.
    """
    w = np.asarray(wavelength_nm, float)
    vis = (w >= 380.0) & (w <= 780.0)
    m = photometric_metrics(np.asarray(spectra, float)[:, vis], w[vis])
    ler, g, cct, duv = (np.asarray(m[k], float) for k in ("LER", "G", "CCT", "Duv"))
    flag = np.asarray(m["CCT_flag"], bool)
    values = np.stack([ler, g, cct], 1)
    reasons: list[dict[str, str]] = []
    for i in range(values.shape[0]):
        why: dict[str, str] = {}
        if not np.isfinite(ler[i]):
            why["LER"] = NO_VISIBLE_LIGHT
        if not ler[i] > 0:
            why["G"] = why.get("LER") or (
                "no light the eye sees (V-weighted power 0 in 380-780 nm): undefined"
            )
        if "LER" in why:
            why["CCT"] = NO_VISIBLE_LIGHT
        elif not np.isfinite(cct[i]):
            why["CCT"] = "no chromaticity for this spectrum (computation gave NaN)"
        elif flag[i] and not CCT_MIN_K <= cct[i] <= CCT_MAX_K:
            why["CCT"] = (
                f"not meaningful: {cct[i]:.0f} K lies outside {CCT_MIN_K:g}-"
                f"{CCT_MAX_K:g} K"
            )
        elif flag[i]:
            why["CCT"] = (
                f"not meaningful: |Duv| {abs(duv[i]):.3f} > {DUV_MAX:g} (too far "
                "from the Planckian locus)"
            )
        for k, name in enumerate(METRICS):
            if name in why:
                values[i, k] = np.nan
        reasons.append(why)
    return values, reasons


def to_model_space(values: ArrayLike) -> Array:
    """(…, 3) metric values -> the space models are fitted in (CCT as mired)."""
    v = jnp.asarray(values)
    cct = v[..., 2]
    ok = cct > 0
    mired = jnp.where(ok, MIRED / jnp.where(ok, cct, 1.0), jnp.nan)
    return v.at[..., 2].set(mired)


def from_model_space(values: ArrayLike) -> Array:
    """Inverse of `to_model_space` (mired -> K; a non-positive mired is NaN)."""
    return to_model_space(values)  # 10⁶/x is its own inverse


# ------------------------------------------------------------------------------
# Features


def log_ratio_features(
    radiance: Float[ArrayLike, "*batch b"], degree: int = 1
) -> Float[Array, "*batch p"]:
    """Centred log band ratios (and their pairwise products for `degree=2`).

    Scale-free: `radiance` times any positive factor gives the same features.
    A non-positive band radiance (noise) counts as 0, i.e. `log δ`. [1]
    """
    if degree not in (1, 2):
        raise ValueError(f"degree must be 1 or 2, got {degree!r}.")
    r = jnp.asarray(radiance)
    r = jnp.maximum(r, 0.0)
    scale = jnp.mean(r, axis=-1, keepdims=True)
    ok = scale > 0
    rel = jnp.where(ok, r / jnp.where(ok, scale, 1.0), 1.0)
    x = jnp.log(rel + LOG_FLOOR)
    x = x - jnp.mean(x, axis=-1, keepdims=True)
    if degree == 1:
        return x
    b = x.shape[-1]
    i, j = np.triu_indices(b)
    return jnp.concatenate([x, x[..., i] * x[..., j]], axis=-1)


def ratio_features(
    radiance: Float[ArrayLike, "*batch b"],
    numerator: int,
    denominator: int,
    *,
    log: bool,
) -> Float[Array, "*batch 1"]:
    """One band ratio `L_num / L_den` (or its log) as a feature: the thesis-style
    estimator (a). Double-where: a dark denominator gives ratio 0 / log δ. [1]"""
    r = jnp.maximum(jnp.asarray(radiance), 0.0)
    num, den = r[..., numerator], r[..., denominator]
    ok = den > 0
    q = jnp.where(ok, num / jnp.where(ok, den, 1.0), 0.0)
    return (jnp.log(q + LOG_FLOOR) if log else q)[..., None]


# ------------------------------------------------------------------------------
# Ridge regression, closed form


def ridge_solve(
    x: Float[ArrayLike, "n p"],
    y: Float[ArrayLike, " n"],
    weight: Float[ArrayLike, " n"],
    lam: float | Float[ArrayLike, ""],
) -> tuple[Float[Array, " p"], Float[Array, ""]]:
    """Weighted ridge with an unpenalised intercept, in closed form.

    Minimises `Σ wᵢ (yᵢ - xᵢ·β - β₀)² + λ |β|²` (the objective of scikit-learn's
    `Ridge(alpha=λ)` with `sample_weight=w`): centre `x` and `y` at their
    weighted means, solve `(Xᶜᵀ W Xᶜ + λ I) β = Xᶜᵀ W yᶜ`. Returns `(β, β₀)`.
    Rows with zero weight do not count (their `y` may be anything finite).
    """
    x, y, w = jnp.asarray(x), jnp.asarray(y), jnp.asarray(weight)
    sw = jnp.sum(w)
    ok = sw > 0
    sw = jnp.where(ok, sw, 1.0)
    mx = jnp.sum(w[:, None] * x, 0) / sw
    my = jnp.sum(w * y) / sw
    xc, yc = x - mx[None, :], y - my
    xw = xc * w[:, None]
    gram = jnp.matmul(xw.T, xc, precision=jax.lax.Precision.HIGHEST)
    rhs = jnp.matmul(xw.T, yc, precision=jax.lax.Precision.HIGHEST)
    beta = jnp.linalg.solve(gram + lam * jnp.eye(x.shape[1], dtype=gram.dtype), rhs)
    return beta, my - jnp.dot(mx, beta)


class RidgeFit(eqx.Module):
    """A fitted ridge model on standardised features: `ŷ = ((x - μ)/σ)·β + β₀`."""

    mean: Float[Array, " p"]
    scale: Float[Array, " p"]
    coef: Float[Array, " p"]
    intercept: Float[Array, ""]

    def predict(self, x: Float[ArrayLike, "*batch p"]) -> Float[Array, " *batch"]:
        x = jnp.asarray(x)
        lead = (1,) * (x.ndim - 1)
        z = (x - self.mean.reshape(*lead, -1)) / self.scale.reshape(*lead, -1)
        return z @ self.coef + self.intercept


def fit_ridge(
    x: Float[ArrayLike, "n p"],
    y: Float[ArrayLike, " n"],
    weight: Float[ArrayLike, " n"],
    lam: float | Float[ArrayLike, ""],
) -> RidgeFit:
    """Standardise `x` with its weighted mean and standard deviation (a constant
    feature keeps scale 1, double-where), then `ridge_solve`. Rows with zero
    weight are ignored; NaN targets must carry zero weight (they are zeroed)."""
    x, w = jnp.asarray(x), jnp.asarray(weight)
    y = jnp.asarray(y)
    y = jnp.where(w > 0, y, 0.0)
    y = jnp.where(jnp.isfinite(y), y, 0.0)
    mu, sd = weighted_standardisation(x, w)
    beta, b0 = ridge_solve((x - mu[None, :]) / sd[None, :], y, w, lam)
    return RidgeFit(mu, sd, beta, b0)


def weighted_standardisation(
    x: Float[ArrayLike, "n p"], weight: Float[ArrayLike, " n"]
) -> tuple[Float[Array, " p"], Float[Array, " p"]]:
    """Weighted mean and standard deviation of each feature; a constant feature
    (variance <= 1e-24) keeps scale 1 (double-where, finite gradients). [units of x]"""
    x, w = jnp.asarray(x), jnp.asarray(weight)
    sw = jnp.sum(w)
    sw = jnp.where(sw > 0, sw, 1.0)
    mu = jnp.sum(w[:, None] * x, 0) / sw
    var = jnp.sum(w[:, None] * (x - mu[None, :]) ** 2, 0) / sw
    pos = var > 1e-24
    return mu, jnp.where(pos, jnp.sqrt(jnp.where(pos, var, 1.0)), 1.0)


# ------------------------------------------------------------------------------
# Class-balanced split weights and the cross-validated loss


@dataclasses.dataclass(frozen=True)
class LampTable:
    """Per-scenario bookkeeping for lamp-grouped fits.

    - `lamp_of`: lamp index of each scenario, `(N,)`.
    - `classes`: level-2 class of each lamp, `(l,)`.
    - `truth`, `valid`: per-lamp metric values and validity, `(l, 3)`.
    """

    lamp_of: np.ndarray
    classes: np.ndarray
    truth: np.ndarray
    valid: np.ndarray

    @property
    def n_lamps(self) -> int:
        return len(self.classes)

    def scenario_weights(self, lamps: Sequence[int] | np.ndarray) -> np.ndarray:
        """Class-balanced scenario weights over `lamps` (sum 1): each class the
        same, each lamp of a class the same, each scenario of a lamp the same."""
        lamps = np.asarray(lamps, int)

        lamp_w = np.zeros(self.n_lamps)
        lamp_w[lamps] = class_balanced_weights(self.classes[lamps])
        per_lamp = np.bincount(self.lamp_of, minlength=self.n_lamps)
        return lamp_w[self.lamp_of] / per_lamp[self.lamp_of]

    def split_weights(self, splits) -> tuple[np.ndarray, np.ndarray]:
        """`(train, validation)` weight arrays `(S, N)` for (train, val) lamp splits."""
        tr = np.stack([self.scenario_weights(t) for t, _ in splits])
        va = np.stack([self.scenario_weights(v) for _, v in splits])
        return tr, va

    def scenario_truth(self) -> tuple[np.ndarray, np.ndarray]:
        """Per-scenario truth in model space (mired) and validity, `(N, 3)`."""
        y = np.asarray(to_model_space(self.truth))[self.lamp_of]
        return np.where(self.valid[self.lamp_of], y, 0.0), self.valid[self.lamp_of]

    def spread(self, lamps=None) -> np.ndarray:
        """Class-balanced standard deviation of each metric over `lamps` (model
        space: mired for CCT). The joint loss divides each metric's error by it."""

        lamps = np.arange(self.n_lamps) if lamps is None else np.asarray(lamps, int)
        y = np.asarray(to_model_space(self.truth))[lamps]
        out = np.empty(3)
        for m in range(3):
            ok = self.valid[lamps, m]
            w = class_balanced_weights(self.classes[lamps][ok])
            mu = np.sum(w * y[ok, m])
            out[m] = np.sqrt(np.sum(w * (y[ok, m] - mu) ** 2))
        return out


def cv_residuals(
    features: Float[Array, "n p"],
    y: Float[Array, "n 3"],
    valid: Bool[Array, "n 3"],
    train_w: Float[Array, "s n"],
    val_w: Float[Array, "s n"],
    spread: Float[Array, " 3"],
    metric_weight: Float[Array, " 3"],
    lam: float,
) -> Float[Array, "s 3 n"]:
    """Cross-validated, class-balanced, spread-normalised residuals.

    For each split and metric a ridge model is fitted in closed form on the
    training weights and evaluated on the validation scenarios. The residuals
    are `sqrt(w_val · metric_weight / S) · (ŷ - y) / spread`, so their squared
    sum is the mean over splits of the class-balanced validation MSE of each
    metric in units of its spread, summed over metrics with `metric_weight`.
    """
    n_split = train_w.shape[0]
    vf = valid.astype(features.dtype)

    def one(tw, vw, ym, vm):
        fit = fit_ridge(features, ym, tw * vm, lam)
        vw = vw * vm
        vw = vw / jnp.where(jnp.sum(vw) > 0, jnp.sum(vw), 1.0)
        return jnp.sqrt(vw) * (fit.predict(features) - ym)

    per_metric = jax.vmap(one, in_axes=(None, None, 1, 1))
    res = jax.vmap(per_metric, in_axes=(0, 0, None, None))(train_w, val_w, y, vf)
    ok = spread > 0  # a metric without spread (constant truth) cannot be scored
    scale = jnp.where(
        ok, jnp.sqrt(metric_weight / n_split) / jnp.where(ok, spread, 1.0), 0.0
    )
    return res * scale[None, :, None]


def cv_loss(*args, **kwargs) -> Float[Array, ""]:
    """Sum of squared `cv_residuals` (same arguments)."""
    return jnp.sum(cv_residuals(*args, **kwargs) ** 2)


# ------------------------------------------------------------------------------
# Fitted estimators for reporting


class Estimator(eqx.Module):
    """One ridge model per metric on log-ratio features; each metric's ridge
    strength `lam` and feature degree `degree` (1: log ratios, 2: plus their
    products) chosen by inner cross-validation, or fixed (`fit_estimator`'s
    `degree=`, `lam=`: refit the coefficients with an earlier fit's choices).
    `predict` returns `(…, 3)` in [lm W⁻¹], [1], [K]."""

    fits: tuple[RidgeFit, RidgeFit, RidgeFit]
    lam: tuple[float, float, float] = eqx.field(static=True)
    degree: tuple[int, int, int] = eqx.field(static=True)
    lower: tuple[float, float, float] = eqx.field(static=True, default=None)
    upper: tuple[float, float, float] = eqx.field(static=True, default=None)

    def predict(
        self, radiance: Float[ArrayLike, "*batch b"]
    ) -> Float[Array, "*batch 3"]:
        x = {d: log_ratio_features(radiance, d) for d in set(self.degree)}
        model = jnp.stack(
            [f.predict(x[d]) for f, d in zip(self.fits, self.degree, strict=True)],
            axis=-1,
        )
        return from_model_space(bound_model_space(model, self.lower, self.upper))


MODEL_BOUNDS = (
    (0.0, -G_CAP, MIRED / CCT_RANGE_K[1]),
    (K_M_LM_PER_W, G_CAP, MIRED / CCT_RANGE_K[0]),
)
"""Physical range in model space: LER 0-683 lm/W, G within ±its cap, CCT
1000-25000 K (as mired 40-1000). No prediction ever leaves it."""


def training_bounds(table: "LampTable", lamps) -> tuple[tuple, tuple]:
    """The training lamps' range of each metric in model space, within
    `MODEL_BOUNDS` (a regression never predicts beyond what it was shown)."""
    y = np.asarray(to_model_space(table.truth[np.asarray(lamps, int)]))
    ok = np.asarray(table.valid[np.asarray(lamps, int)])
    lo, hi = [], []
    for m in range(3):
        v = y[ok[:, m], m]
        a = float(v.min()) if v.size else MODEL_BOUNDS[0][m]
        b = float(v.max()) if v.size else MODEL_BOUNDS[1][m]
        lo.append(max(a, MODEL_BOUNDS[0][m]))
        hi.append(min(b, MODEL_BOUNDS[1][m]))
    return tuple(lo), tuple(hi)


def bound_model_space(model, lower=None, upper=None):
    """Clip (…, 3) model-space predictions to [lower, upper] (default: the
    physical range)."""
    model = jnp.asarray(model)
    lead = (1,) * (model.ndim - 1)
    lo = jnp.asarray(MODEL_BOUNDS[0] if lower is None else lower).reshape(*lead, 3)
    hi = jnp.asarray(MODEL_BOUNDS[1] if upper is None else upper).reshape(*lead, 3)
    return jnp.clip(model, lo, hi)


@jax.jit
def _inner_scores(x, y, vf, tr, va, lambdas):
    """Validation MSE summed over inner splits, `(len(lambdas), 3)`."""

    def one(lam, t, v, ym, vm):
        f = fit_ridge(x, ym, t * vm, lam)
        vw = v * vm
        return jnp.sum(vw * (f.predict(x) - ym) ** 2) / jnp.maximum(jnp.sum(vw), 1e-300)

    f = jax.vmap(one, in_axes=(None, None, None, 1, 1))  # metrics
    f = jax.vmap(f, in_axes=(None, 0, 0, None, None))  # splits
    f = jax.vmap(f, in_axes=(0, None, None, None, None))  # lambdas
    return jnp.sum(f(lambdas, tr, va, y, vf), axis=1)


_fit_jit = jax.jit(fit_ridge)

DEGREES = (1, 2)


def fit_estimator(
    radiance: Float[ArrayLike, "n b"],
    table: LampTable,
    train_lamps: np.ndarray,
    inner: Sequence[tuple[np.ndarray, np.ndarray]],
    *,
    degrees: Sequence[int] = DEGREES,
    lambdas: Sequence[float] = LAMBDA_GRID,
    degree: Sequence[int] | None = None,
    lam: Sequence[float] | None = None,
) -> Estimator:
    """Fit the ridge estimator on `train_lamps`, choosing each metric's feature
    degree from `degrees` and ridge strength from `lambdas` by the
    class-balanced validation MSE summed over the `inner` (train, validation)
    lamp splits (lamps of `train_lamps` only).

    Fixed hyper-parameters: `degree` and `lam`, per metric (`METRICS` order;
    e.g. an earlier fit's `Estimator.degree`, `Estimator.lam`), skip the inner
    cross-validation (`inner`, `degrees` and `lambdas` are then unused) and
    fit only the coefficients, e.g. to refit on other band responses with the
    choices made for the nominal ones. Give both or neither."""
    if (degree is None) != (lam is None):
        raise ValueError("fix both `degree` and `lam`, or neither.")
    rad = jnp.asarray(radiance)
    y, valid = (jnp.asarray(a) for a in table.scenario_truth())
    vf = valid.astype(rad.dtype)
    if degree is not None:
        chosen = [(int(d), float(v)) for d, v in zip(degree, lam, strict=True)]
        if len(chosen) != 3 or any(d not in (1, 2) for d, _ in chosen):
            raise ValueError(
                f"fixed degree/lam: one per metric, degree 1 or 2; got {degree}, {lam}."
            )
        xs = {d: log_ratio_features(rad, d) for d, _ in chosen}
    else:
        tr, va = (jnp.asarray(a) for a in table.split_weights(inner))
        xs = {d: log_ratio_features(rad, d) for d in degrees}
        scores = np.stack(
            [
                np.asarray(_inner_scores(xs[d], y, vf, tr, va, jnp.asarray(lambdas)))
                for d in degrees
            ]
        )  # (D, L, 3)
        chosen = []
        for m in range(3):
            di, li = np.unravel_index(int(np.argmin(scores[:, :, m])), scores.shape[:2])
            chosen.append((int(degrees[di]), float(lambdas[li])))
    fits, lams, degs = [], [], []
    w_train = jnp.asarray(table.scenario_weights(train_lamps))
    for m, (d, lam_m) in enumerate(chosen):
        fits.append(_fit_jit(xs[d], y[:, m], w_train * vf[:, m], lam_m))
        lams.append(lam_m)
        degs.append(d)
    lo, hi = training_bounds(table, train_lamps)
    return Estimator(tuple(fits), tuple(lams), tuple(degs), lo, hi)


KERNEL_GAMMAS: tuple[float, ...] = (0.03, 0.3, 3.0)
"""RBF widths `γ` (per standardised feature, `k = exp(-γ |Δz|²/p)`)."""

KERNEL_LAMBDAS: tuple[float, ...] = (1e-3, 1e-2, 1e-1, 1.0, 10.0)

KERNEL_MAX_ROWS = 800
"""Training rows of a kernel ridge (a seeded class-balanced draw when more)."""


class KernelEstimator(eqx.Module):
    """Kernel ridge (RBF on standardised centred log band ratios) per metric,
    `γ` and `λ` chosen by inner cross-validation; predictions bounded like
    `Estimator`. `predict` returns `(…, 3)` in [lm W⁻¹], [1], [K]."""

    mean: Float[Array, " p"]
    scale: Float[Array, " p"]
    z: Float[Array, "n p"]
    alpha: Float[Array, "n 3"]
    offset: Float[Array, " 3"]
    gamma: tuple[float, float, float] = eqx.field(static=True)
    lam: tuple[float, float, float] = eqx.field(static=True)
    lower: tuple[float, float, float] = eqx.field(static=True)
    upper: tuple[float, float, float] = eqx.field(static=True)

    def predict(
        self, radiance: Float[ArrayLike, "*batch b"]
    ) -> Float[Array, "*batch 3"]:
        x = log_ratio_features(radiance, 1)
        lead = (1,) * (x.ndim - 1)
        z = (x - self.mean.reshape(*lead, -1)) / self.scale.reshape(*lead, -1)
        d2 = _sqdist(z.reshape(-1, z.shape[-1]), self.z)
        cols = [
            jnp.exp(-g * d2) @ self.alpha[:, m] + self.offset[m]
            for m, g in enumerate(self.gamma)
        ]
        model = jnp.stack(cols, axis=-1).reshape(*x.shape[:-1], 3)
        return from_model_space(bound_model_space(model, self.lower, self.upper))


def _sqdist(a, b):
    """Squared distances per feature, (n, m)."""
    d = (
        jnp.sum(a**2, 1)[:, None]
        + jnp.sum(b**2, 1)[None, :]
        - 2 * jnp.matmul(a, b.T, precision=jax.lax.Precision.HIGHEST)
    )
    return jnp.maximum(d, 0.0) / a.shape[1]


def _krr_all(z, y, gamma, lambdas):
    """Kernel ridge for every `λ` at once through one eigendecomposition:
    minimise `Σ(yᵢ - f(zᵢ))² + λ|f|²` with the mean as unpenalised offset.
    Returns (alphas (L, n, m), offset (m,))."""
    off = jnp.mean(y, axis=0)
    k = jnp.exp(-gamma * _sqdist(z, z))
    lam_k, u = jnp.linalg.eigh(k)
    uty = u.T @ (y - off[None, :])
    alphas = jnp.stack(
        [u @ (uty / (jnp.maximum(lam_k, 0.0) + lam)[:, None]) for lam in lambdas]
    )
    return alphas, off


def fit_kernel_estimator(
    radiance: Float[ArrayLike, "n b"],
    table: "LampTable",
    train_lamps: np.ndarray,
    inner: Sequence[tuple[np.ndarray, np.ndarray]],
    *,
    gammas: Sequence[float] = KERNEL_GAMMAS,
    lambdas: Sequence[float] = KERNEL_LAMBDAS,
    max_rows: int = KERNEL_MAX_ROWS,
    seed: int = 0,
) -> KernelEstimator:
    """Fit the kernel-ridge baseline on `train_lamps`, choosing `γ`, `λ` per
    metric by the class-balanced validation MSE over the `inner` splits.

    Training rows are a seeded draw of at most `max_rows` scenarios with
    probability proportional to their class-balanced weight, so an unweighted
    fit on the draw is class-balanced in expectation (CCT uses its own draw
    among rows where a CCT is meaningful)."""
    rad = np.asarray(radiance, float)
    y_all, valid = (np.asarray(a) for a in table.scenario_truth())
    rng = np.random.default_rng(seed)
    lams = [float(v) for v in lambdas]

    def draw(lamps, metric):
        w = table.scenario_weights(lamps) * valid[:, metric]
        rows = np.flatnonzero(w > 0)
        if rows.size > max_rows:
            p = w[rows] / w[rows].sum()
            rows = np.sort(rng.choice(rows, max_rows, replace=False, p=p))
        return rows, w

    def feats(rows, mu=None, sd=None):
        x = log_ratio_features(jnp.asarray(rad[rows]), 1)
        if mu is None:
            mu, sd = weighted_standardisation(x, jnp.ones(len(rows)))
        return (x - mu[None]) / sd[None], mu, sd

    groups = ((0, (0, 1)), (2, (2,)))  # (row draw by metric, metrics fitted)
    scores = np.zeros((len(gammas), len(lams), 3))
    for tr, va in inner:
        for key, metrics in groups:
            rt, _ = draw(tr, key)
            rv, wv = draw(va, key)
            zt, mu, sd = feats(rt)
            zv, _, _ = feats(rv, mu, sd)
            yt = jnp.asarray(y_all[rt][:, metrics])
            for gi, g in enumerate(gammas):
                alphas, off = _krr_all(zt, yt, g, lams)
                kv = jnp.exp(-g * _sqdist(zv, zt))
                for li in range(len(lams)):
                    pv = np.asarray(kv @ alphas[li] + off[None, :])
                    for j, m in enumerate(metrics):
                        vw = wv[rv]
                        err = (pv[:, j] - y_all[rv, m]) ** 2
                        scores[gi, li, m] += np.sum(vw * err) / max(vw.sum(), 1e-300)
    lo, hi = training_bounds(table, train_lamps)
    # one feature standardisation and row set for the model (the LER/G draw);
    # CCT is fitted on its rows with a meaningful CCT
    rt, _ = draw(train_lamps, 0)
    z, mu, sd = feats(rt)
    alphas, offs, gs, ls = [], [], [], []
    for m in range(3):
        gi, li = np.unravel_index(int(np.argmin(scores[:, :, m])), scores.shape[:2])
        g, lam = float(gammas[gi]), lams[li]
        ok = valid[rt, m]
        ym = jnp.asarray(np.where(ok, y_all[rt, m], 0.0)[:, None])
        if ok.all():
            a, off = _krr_all(z, ym, g, [lam])
            a = a[0, :, 0]
        else:
            a_sub, off = _krr_all(z[ok], ym[ok], g, [lam])
            a = jnp.zeros(len(rt)).at[np.flatnonzero(ok)].set(a_sub[0, :, 0])
        alphas.append(a)
        offs.append(off[0])
        gs.append(g)
        ls.append(lam)
    return KernelEstimator(
        mu, sd, z, jnp.stack(alphas, 1), jnp.stack(offs), tuple(gs), tuple(ls), lo, hi
    )


def lamp_abs_errors(
    prediction: Float[ArrayLike, "n 3"], table: LampTable, lamps: np.ndarray
) -> np.ndarray:
    """Mean absolute error per lamp over its scenarios, `(len(lamps), 3)` in
    [lm W⁻¹], [1], [K]; NaN where the metric is not valid for the lamp."""
    pred = np.asarray(prediction)
    out = np.full((len(lamps), 3), np.nan)
    for i, lamp in enumerate(np.asarray(lamps, int)):
        rows = table.lamp_of == lamp
        err = np.abs(pred[rows] - table.truth[lamp][None, :]).mean(axis=0)
        out[i] = np.where(table.valid[lamp], err, np.nan)
    return out


def fit_ratio_estimator(
    feature: Float[ArrayLike, "n 1"],
    y: Float[ArrayLike, " n"],
    weight: Float[ArrayLike, " n"],
) -> RidgeFit:
    """Fit `y = a + b·r` (thesis-style estimator (a)) by weighted least squares."""
    return fit_ridge(feature, y, weight, 0.0)


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
