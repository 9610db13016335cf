"""Scale-free features and closed-form weighted ridge regression: the
centred log band ratios (and the thesis-style single ratio), the ridge solve
with an unpenalised intercept, the weighted standardisation, and the ridge
strengths searches and reports use.

Pure array maths on features [1] and targets (model space), with no lamp
bookkeeping: the band search fits it inside its loss (`bandopt.search`),
and `_table`, `_fitted` build the class-balanced fits on it.
"""

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike, Float


LOG_FLOOR = 1e-6
"""δ added to relative band radiance before the logarithm (a band that sees no
light gives log δ, not -inf). [1]"""

LAMBDA_GRID: tuple[float, ...] = (1e-6, 1e-4, 1e-3, 1e-2, 1e-1, 1.0)
"""Ridge strengths (on standardised features, weights summing to 1) chosen
from by inner cross-validation."""

SEARCH_LAMBDA = 1e-3
"""Ridge strength used inside band-search losses (keeps overlapping bands
well conditioned; the reported models re-choose it from `LAMBDA_GRID`)."""


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


def fit_ratio_estimator(
    feature: Float[ArrayLike, "n 1"],
    y: Float[ArrayLike, " n"],
    weight: Float[ArrayLike, " n"],
) -> RidgeFit:
    """Fit `y = a + b·r` (thesis-style estimator (a)) by weighted least squares."""
    return fit_ridge(feature, y, weight, 0.0)
