"""Posterior metrics: LER, G and CCT means and 5-95 % ranges of a posterior
over the prior's lamps (CCT in mired), the physical bounds no estimate or
interval leaves (`PHYSICAL_RANGE`) and the widening of a range into an
interval (`_widened`)."""

import jax
import jax.numpy as jnp
import numpy as np

from ..estimate import CCT_RANGE_K, MIRED
from ..photometry import G_CAP, K_M_LM_PER_W
from ._prior import LampPrior


COVERAGE = 0.9
"""Nominal coverage of the intervals."""


PHYSICAL_RANGE = {
    "LER": (0.0, K_M_LM_PER_W),
    "G": (-G_CAP, G_CAP),
    "CCT": CCT_RANGE_K,
}
"""Bounds no estimate or interval ever leaves. [lm W⁻¹], [1], [K]"""


INTERVAL_FLOOR = np.array([1.0, 0.005, 2.0])
"""Smallest half-width of a posterior range before conformal scaling, in model
space (LER [lm W⁻¹], G [1], CCT [mired]): a posterior concentrated on one
lamp still gets an interval."""


def weighted_quantile(values, weights, qs):
    """Quantiles of discrete distributions row-wise: values (k,), weights (n, k)."""
    order = np.argsort(values)
    v, w = values[order], weights[:, order]
    c = np.cumsum(w, axis=1)
    c = c / np.maximum(c[:, -1:], 1e-300)
    return np.stack(
        [v[np.minimum((c < q).sum(axis=1), v.size - 1)] for q in qs], axis=-1
    )


METRIC_ROWS = 1024
"""Most posterior rows `_posterior_metrics` summarises per compiled call
(fewer rows are padded to a power of two, more to a multiple of this: a few
shapes compile, and memory stays bounded)."""


@jax.jit
def _metric_summary(post, vals, okf, order, qs):
    """Per metric row of `vals`, `okf` (validity as 0/1), `order` (M, k): the
    mean (n, M) and the weighted quantiles `qs` (n, M, Q) of the prior's valid
    values under the posterior `post` (n, k), renormalised over the valid
    entries. `order` sorts each row's invalid entries first (zero weight, so
    they never hold a quantile: the first entry whose cumulative weight reaches
    q has weight > 0), then its values; `weighted_quantile`'s rule."""

    def one(v, ok, o):
        w = post * ok[None]
        w = w / jnp.maximum(w.sum(axis=1, keepdims=True), 1e-300)
        mean = jnp.matmul(w, v, precision=jax.lax.Precision.HIGHEST)
        c = jnp.cumsum(w[:, o], axis=1)
        c = c / jnp.maximum(c[:, -1:], 1e-300)
        idx = jnp.minimum(jnp.sum(c[:, :, None] < qs[None, None], axis=1), v.size - 1)
        return mean, v[o][idx]

    return jax.vmap(one, out_axes=(1, 1))(vals, okf, order)


def _posterior_metrics(post, prior: LampPrior, metrics=(0, 1, 2)):
    """Posterior mean and 5-95 % range in model space (CCT as mired), and
    P(CCT meaningful). post (n, k) sums to 1 per row. Only the columns of
    `metrics` (indices into `METRICS`) are computed; the others are NaN.
    Compiled (`_metric_summary`, `METRIC_ROWS` rows per call): the same
    numbers as `weighted_quantile` on each metric's valid entries."""
    post = np.asarray(post, float)
    t = prior.truth.copy()
    t[:, 2] = np.where(
        prior.valid[:, 2], MIRED / np.where(prior.valid[:, 2], t[:, 2], 1), 0
    )
    n = post.shape[0]
    mean = np.full((n, 3), np.nan)
    rng = np.full((n, 3, 2), np.nan)
    p_cct = post @ prior.valid[:, 2].astype(float)
    lo_q, hi_q = (1 - COVERAGE) / 2, 1 - (1 - COVERAGE) / 2
    ms = [m for m in metrics if prior.valid[:, m].any()]
    if not ms or n == 0:
        return mean, rng, p_cct
    ok = prior.valid[:, ms].T  # (M, k)
    vals = np.where(ok, t[:, ms].T, 0.0)
    order = np.stack([np.lexsort((v, o)) for v, o in zip(vals, ok, strict=True)])
    qs = jnp.asarray([lo_q, hi_q])
    # a few compiled shapes: powers of two up to METRIC_ROWS, then chunks
    step = min(METRIC_ROWS, 1 << max(3, (n - 1).bit_length()))
    rows = -(-n // step) * step
    padded = np.concatenate([post, np.zeros((rows - n, post.shape[1]))])
    parts = [
        _metric_summary(padded[i : i + step], vals, ok.astype(float), order, qs)
        for i in range(0, rows, step)
    ]
    mean[:, ms] = np.concatenate([np.asarray(p[0]) for p in parts])[:n]
    rng[:, ms] = np.concatenate([np.asarray(p[1]) for p in parts])[:n]
    return mean, rng, p_cct


def _to_model(values):
    v = np.array(values, float)
    v[..., 2] = MIRED / v[..., 2]
    return v


def _model_bounds():
    lo = np.array(
        [PHYSICAL_RANGE["LER"][0], PHYSICAL_RANGE["G"][0], MIRED / CCT_RANGE_K[1]]
    )
    hi = np.array(
        [PHYSICAL_RANGE["LER"][1], PHYSICAL_RANGE["G"][1], MIRED / CCT_RANGE_K[0]]
    )
    return lo, hi


def _metrics_per_posterior(posts, prior: LampPrior):
    """`_posterior_metrics` with each metric (`METRICS` order) taken from its
    own posterior `posts[m]` (n, k); P(CCT meaningful) from the CCT one.
    Posteriors that are the same object are summarised once."""
    done = {}
    for p in posts:
        if id(p) not in done:
            which = tuple(m for m, q in enumerate(posts) if q is p)
            done[id(p)] = _posterior_metrics(p, prior, which)
    mean = np.stack([done[id(p)][0][:, m] for m, p in enumerate(posts)], axis=1)
    rng = np.stack([done[id(p)][1][:, m] for m, p in enumerate(posts)], axis=1)
    return mean, rng, done[id(posts[2])][2]


def _widened(mean, rng, conformal, offset):
    """Posterior means clipped to the physical range and the 90 % interval
    `range ± conformal x (max(half-width, INTERVAL_FLOOR) + offset)`, clipped
    likewise and stretched to hold the mean; model space, (n, 3) each."""
    lo_b, hi_b = _model_bounds()
    unit = np.maximum((rng[..., 1] - rng[..., 0]) / 2, INTERVAL_FLOOR) + offset
    lo = np.clip(rng[..., 0] - conformal * unit, lo_b, hi_b)
    hi = np.clip(rng[..., 1] + conformal * unit, lo_b, hi_b)
    mean = np.clip(mean, lo_b, hi_b)
    return mean, np.minimum(lo, mean), np.maximum(hi, mean)
