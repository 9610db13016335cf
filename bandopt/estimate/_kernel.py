"""The kernel-ridge baseline: `KernelEstimator` (RBF on standardised centred
log band ratios, per metric) and `fit_kernel_estimator`, with `γ` and `λ`
chosen by the class-balanced inner-CV error on a seeded, class-balanced
draw of training rows. Predictions in [lm W⁻¹], [1], [K], bounded like
`Estimator`'s.

A separate model family from the linear ridge (`_fitted`): it shares the
features, the truth and the training bounds, nothing else.
"""

from collections.abc import Sequence

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike, Float

from ._fitted import training_bounds
from ._ridge import log_ratio_features, weighted_standardisation
from ._table import LampTable
from ._truth import bound_model_space, from_model_space


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
