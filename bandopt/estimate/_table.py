"""Lamp-grouped bookkeeping and the class-balanced cross-validated loss:
`LampTable` (which lamp and class each scenario belongs to, the truth per
lamp, class-balanced weights), the inner-CV residuals and loss a band
search minimises, and the per-lamp absolute errors every study reports.

Between the ridge maths (`_ridge`) and the fitted estimators (`_fitted`,
`_kernel`): the weights here decide what "class-balanced" means for both.
"""

import dataclasses
from collections.abc import Sequence

import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike, Bool, Float

from ..folds import class_balanced_weights
from ._ridge import fit_ridge
from ._truth import to_model_space


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
