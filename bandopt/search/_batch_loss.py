"""The loss of the stability study's batched search: lamp resamples, the
arrays every resample and restart share (`BatchData`), and the loss of a
design for one resample, jitted and vmapped over restarts (`batched_loss`).

A *resample* is one outer fold of one lamp partition (repeated grouped,
class-stratified 3-fold splits, `bandopt.folds.nested_lamp_splits` with
seed `seed + 101·p` for partition `p`); its bands are searched on the outer
training lamps with the loss below and judged on the outer test lamps.

Loss of a design for resample `r` (all terms dimensionless):

    (1 - α) · est + α · cls + OVERLAP_WEIGHT · Σ_{i<j} relu(ov_ij - MAX_OVERLAP)²

- `est`: mean over LER, G, CCT of the inner-CV class-balanced MSE divided by
  the metric's class-balanced variance over the training lamps
  (`bandopt.estimate.cv_loss` / 3);
- `cls`: the classification surrogate, the inner-CV class-balanced MSE of a
  ridge fit to the one-hot level-2 class (a least-squares classifier on the
  same centred log ratios), divided by `1 - 1/C` (its value when the bands
  carry no information);
- `ov_ij`: overlap of free bands i, j, `Σ min(r_i, r_j) / min(Σ r_i, Σ r_j)`
  (0 disjoint, 1 one band inside the other); the panchromatic band is exempt.

Test lamps carry zero weight in every inner split, so they cannot influence
the search (tested by the gradient with respect to their spectra).

Apart from `_stability` (the solvers that minimise it) because the loss is
what a design is judged by, whichever solver explores it.
"""

import dataclasses
import functools

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from ..estimate import (
    SEARCH_LAMBDA,
    LampTable,
    cv_loss,
    fit_ridge,
    log_ratio_features,
    weighted_standardisation,
)
from ..folds import N_INNER_FOLDS, N_OUTER_FOLDS, nested_lamp_splits
from ..forward import noise_draws, radiance_from_response
from ..sensor import SensorParams, slit_super_gaussian


MIN_FWHM_NM = 20.0
"""Narrowest band a filter maker is asked for (multispectral bands). [nm]"""

MAX_OVERLAP = 0.25
"""Largest allowed overlap `Σ min(r_i, r_j) / min(Σ r_i, Σ r_j)` between two
multispectral bands (enforced by a penalty, reported per design). [1]"""

OVERLAP_WEIGHT = 100.0
"""Weight of the squared overlap excess in the loss. [1]"""


@dataclasses.dataclass(frozen=True)
class Resample:
    """One outer fold of one lamp partition (indices into the lamp table)."""

    partition: int
    fold: int
    train: np.ndarray
    test: np.ndarray
    inner: tuple


def lamp_resamples(
    classes,
    n_partitions: int,
    *,
    seed: int = 0,
    n_outer: int = N_OUTER_FOLDS,
    n_inner: int = N_INNER_FOLDS,
) -> list[Resample]:
    """`n_partitions` repeated lamp-grouped, class-stratified partitions into
    `n_outer` folds (seed `seed + 101·p`), flattened to resamples."""
    out = []
    for p in range(int(n_partitions)):
        for s in nested_lamp_splits(
            classes, n_outer=n_outer, n_inner=n_inner, seed=seed + 101 * p
        ):
            out.append(Resample(p, s.outer, s.train, s.test, s.inner))
    return out


class BatchData(eqx.Module):
    """Arrays shared by every resample and restart (see module docstring).

    - `toa (N, w)`, `wavelength_nm (w,)`; `y`, `valid (N, 3)` truth (mired);
    - `onehot (N, C)` level-2 class indicators;
    - `train_w`, `val_w (R, I, N)` inner split weights of each resample;
    - `spread (R, 3)` class-balanced SD of each metric over its training lamps;
    - `fixed_response (f, w)` pan band or None; `noise_z (N, b)` or None.
    """

    toa: jax.Array
    wavelength_nm: jax.Array
    y: jax.Array
    valid: jax.Array
    onehot: jax.Array
    train_w: jax.Array
    val_w: jax.Array
    spread: jax.Array
    fixed_response: jax.Array | None
    noise_z: jax.Array | None
    sensor: object
    shape_k: float = eqx.field(static=True, default=6.0)
    lam: float = eqx.field(static=True, default=SEARCH_LAMBDA)
    metric_groups: tuple = eqx.field(static=True, default=((0,), (1,), (2,)))
    full_groups: tuple = eqx.field(static=True, default=(False, False, False))
    shared: bool = eqx.field(static=True, default=True)


def make_batch_data(
    toa_lamp: np.ndarray,
    wavelength_nm: np.ndarray,
    table: LampTable,
    resamples,
    space,
    *,
    noise: bool = False,
    noise_radiance: float | None = None,
    seed: int = 0,
    dtype=jnp.float64,
    shared: bool = True,
) -> BatchData:
    """`BatchData` over all lamps of `table` for `resamples` (the search of
    resample r only sees its training lamps: every other scene has weight 0).
    `shared`: fit columns with the same weights as one multi-output ridge
    (`shared_ridge_cv`, the fast path); False: one `fit_ridge` per column."""
    toa = np.asarray(toa_lamp).reshape(-1, toa_lamp.shape[-1])
    if noise_radiance is not None:
        w = np.asarray(wavelength_nm)
        band = (w >= 400) & (w <= 900)
        toa = toa * (noise_radiance / toa[:, band].mean(axis=1))[:, None]
    y, valid = table.scenario_truth()
    cls = np.asarray(table.classes, dtype=object)
    names = sorted(set(cls.tolist()))
    onehot = (cls[table.lamp_of][:, None] == np.asarray(names, object)[None, :]).astype(
        float
    )
    trs, vas, spreads = [], [], []
    for r in resamples:
        for tr, va in r.inner:
            if set(np.asarray(tr).tolist()) & set(np.asarray(r.test).tolist()):
                raise ValueError("an inner split uses an outer test lamp.")
            if set(np.asarray(va).tolist()) & set(np.asarray(r.test).tolist()):
                raise ValueError("an inner split uses an outer test lamp.")
        tw, vw = table.split_weights(list(r.inner))
        trs.append(tw)
        vas.append(vw)
        spreads.append(table.spread(r.train))
    fixed = space.fixed_bands()
    wl = jnp.asarray(wavelength_nm, dtype)
    n_b = space.n_free + (fixed is not None)
    z = None
    sensor = None
    if noise:
        # drawn at the default float dtype, then cast: `jax.random.normal`
        # gives other numbers in float32 than in float64, so drawing in
        # `dtype` would search a float32 study on different noise
        z = noise_draws(seed, toa.shape[0], n_b).astype(dtype)
        sensor = SensorParams()
    groups: list[list[int]] = []
    for m in range(3):  # metrics with identical validity share one ridge system
        for g in groups:
            if np.array_equal(valid[:, g[0]], valid[:, m]):
                g.append(m)
                break
        else:
            groups.append([m])
    return BatchData(
        metric_groups=tuple(tuple(g) for g in groups),
        full_groups=tuple(bool(np.asarray(valid)[:, g[0]].all()) for g in groups),
        shared=shared,
        toa=jnp.asarray(toa, dtype),
        wavelength_nm=wl,
        y=jnp.asarray(y, dtype),
        valid=jnp.asarray(valid),
        onehot=jnp.asarray(onehot, dtype),
        train_w=jnp.asarray(np.stack(trs), dtype),
        val_w=jnp.asarray(np.stack(vas), dtype),
        spread=jnp.asarray(np.stack(spreads), dtype),
        fixed_response=None
        if fixed is None
        else jnp.asarray(fixed.response(jnp.asarray(wavelength_nm)), dtype),
        noise_z=z,
        sensor=sensor,
        shape_k=space.shape_k,
    )


def _radiance(data: BatchData, response):
    return radiance_from_response(
        data.toa, data.wavelength_nm, response, data.noise_z, data.sensor
    )


def overlap_matrix(response) -> jax.Array:
    """`(b, b)` overlaps `Σ min(r_i, r_j) / min(Σ r_i, Σ r_j)` (diagonal 0)."""
    r = jnp.asarray(response)
    inter = jnp.sum(jnp.minimum(r[:, None, :], r[None, :, :]), axis=-1)
    area = jnp.sum(r, axis=-1)
    den = jnp.minimum(area[:, None], area[None, :])
    ok = den > 0
    ov = jnp.where(ok, inter / jnp.where(ok, den, 1.0), 0.0)
    return ov * (1.0 - jnp.eye(r.shape[0], dtype=r.dtype))


def design_terms(data: BatchData, space, u, r):
    """(est, cls, overlap penalty) of unit-box point `u` for resample index `r`."""
    centre, fwhm = space.physical(u)
    k = jnp.full_like(centre, data.shape_k)
    free = slit_super_gaussian(data.wavelength_nm, centre, fwhm, k)
    resp = free
    if data.fixed_response is not None:
        resp = jnp.concatenate([free, data.fixed_response], axis=0)
    x = log_ratio_features(_radiance(data, resp))
    tw, vw = data.train_w[r], data.val_w[r]
    c = data.onehot.shape[1]
    if data.shared:
        sp = data.spread[r]
        est = 0.0
        cls = None
        for g, full in zip(data.metric_groups, data.full_groups, strict=True):
            idx = np.asarray(g)
            ok = sp[idx] > 0
            inv = jnp.where(ok, 1.0 / jnp.where(ok, sp[idx], 1.0) ** 2, 0.0)
            if full:  # every scene valid: the same weights as the class columns
                ones = jnp.ones(x.shape[0], x.dtype)
                ys = jnp.concatenate([data.y[:, idx], data.onehot], axis=1)
                mse = jnp.mean(shared_ridge_cv(x, ys, ones, tw, vw, data.lam), 0)
                cls = jnp.sum(mse[len(g) :])
                mse = mse[: len(g)]
            else:
                mask = data.valid[:, g[0]].astype(x.dtype)
                mse = shared_ridge_cv(x, data.y[:, idx], mask, tw, vw, data.lam)
                mse = jnp.mean(mse, axis=0)
            est = est + jnp.sum(mse * inv)
        est = est / 3.0
        if cls is None:
            ones = jnp.ones(x.shape[0], x.dtype)
            mse = shared_ridge_cv(x, data.onehot, ones, tw, vw, data.lam)
            cls = jnp.sum(jnp.mean(mse, axis=0))
        cls = cls / (1.0 - 1.0 / c)
        ov = overlap_matrix(free)
        pen = 0.5 * jnp.sum(jnp.maximum(ov - MAX_OVERLAP, 0.0) ** 2)
        return est, cls, pen
    est = (
        cv_loss(
            x,
            data.y,
            data.valid,
            tw,
            vw,
            data.spread[r],
            jnp.ones(3, x.dtype),
            data.lam,
        )
        / 3.0
    )
    cls = class_cv_loss(x, data.onehot, tw, vw, data.lam) / (1.0 - 1.0 / c)
    ov = overlap_matrix(free)
    pen = 0.5 * jnp.sum(jnp.maximum(ov - MAX_OVERLAP, 0.0) ** 2)
    return est, cls, pen


def shared_ridge_cv(x, Y, mask, train_w, val_w, lam):
    """Validation MSE `(S, c)` of ridge fits of every column of `Y (N, c)` on
    features `x (N, p)`, with training weights `train_w·mask` and validation
    weights `val_w·mask` (normalised) of each split: the arithmetic of
    `bandopt.estimate.fit_ridge` (weighted standardisation, centring,
    unpenalised intercept, `(XᵀWX + λI) β = XᵀWy`) done ONCE per split for
    all columns (they share the weights, hence the Gram matrix)."""
    hi = jax.lax.Precision.HIGHEST

    def one(t, v):
        w = t * mask
        sw = jnp.sum(w)
        sw = jnp.where(sw > 0, sw, 1.0)
        mu, sd = weighted_standardisation(x, w)
        xs = (x - mu[None, :]) / sd[None, :]
        yy = jnp.where(w[:, None] > 0, Y, 0.0)
        mx = jnp.sum(w[:, None] * xs, 0) / sw
        my = jnp.sum(w[:, None] * yy, 0) / sw
        xc = xs - mx[None, :]
        xw = xc * w[:, None]
        gram = jnp.matmul(xw.T, xc, precision=hi)
        rhs = jnp.matmul(xw.T, yy - my[None, :], precision=hi)
        beta = jnp.linalg.solve(gram + lam * jnp.eye(x.shape[1], dtype=gram.dtype), rhs)
        b0 = my - mx @ beta
        pred = jnp.matmul(xs, beta, precision=hi) + b0[None, :]
        vv = v * mask
        sv = jnp.sum(vv)
        vn = vv / jnp.where(sv > 0, sv, 1.0)
        return jnp.sum(vn[:, None] * (pred - Y) ** 2, axis=0)

    return jax.vmap(one)(train_w, val_w)


def class_cv_loss(x, onehot, train_w, val_w, lam):
    """Inner-CV class-balanced MSE of a ridge fit (`fit_ridge`) to each one-hot
    class column, summed over columns and averaged over splits (the same
    arithmetic as `cv_loss` with unit spread, for any number of columns)."""

    def one(t, v, ym):
        fit = fit_ridge(x, ym, t, lam)
        sv = jnp.sum(v)
        vn = v / jnp.where(sv > 0, sv, 1.0)
        return jnp.sum(vn * (fit.predict(x) - ym) ** 2)

    per_col = jax.vmap(one, in_axes=(None, None, 1))
    per_split = jax.vmap(per_col, in_axes=(0, 0, None))(train_w, val_w, onehot)
    return jnp.sum(per_split) / train_w.shape[0]


def design_loss(data, space, alpha, u, r):
    est, cls, pen = design_terms(data, space, u, r)
    return (1.0 - alpha) * est + alpha * cls + OVERLAP_WEIGHT * pen


def batched_loss(space, alpha):
    """Jitted `f(data, U (R, K, d)) -> (R, K)` losses (restarts of each resample)."""
    return _batched_loss(space, float(alpha))


@functools.lru_cache(maxsize=32)
def _batched_loss(space, alpha):
    def per(data, u, r):
        return design_loss(data, space, alpha, u, r)

    inner = jax.vmap(per, in_axes=(None, 0, None))  # restarts

    def f(data, U):
        rs = jnp.arange(U.shape[0])
        return jax.vmap(inner, in_axes=(None, 0, 0))(data, U, rs)

    return jax.jit(f)
