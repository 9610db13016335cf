"""The ridge estimator for reporting: `Estimator` (one ridge model per metric
on log-ratio features, hyper-parameters chosen by inner cross-validation or
fixed), `fit_estimator`, and the training lamps' range every prediction is
clipped to (`training_bounds`). Predictions are in [lm W⁻¹], [1], [K].

Apart from `_ridge` because this is the model selection and bounding
around the closed-form fit, on lamps of a `LampTable`.
"""

from collections.abc import Sequence

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike, Float

from ._ridge import LAMBDA_GRID, RidgeFit, fit_ridge, log_ratio_features
from ._table import LampTable
from ._truth import MODEL_BOUNDS, bound_model_space, from_model_space, to_model_space


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
