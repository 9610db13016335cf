"""Band search on many lamp resamples at once: one compiled, batched search.

A *resample* is one outer fold of one lamp partition (repeated grouped,
class-stratified 3-fold splits, `bandopt.folds.nested_lamp_splits` with seed
`seed + p` for partition `p`): its bands are searched on the outer training
lamps (loss = inner-CV error of the closed-form ridge surrogate, two inner
folds) and judged on the outer test lamps. All resamples and all restarts of
one band count run in ONE jitted function: `vmap` over resamples (their split
weights are data) and starts. nlopt explores each resample globally (seeded,
budgeted by evaluations) and its best distinct points start optimistix BFGS
fits, vmapped over resamples and starts, each ending with optimistix's
recorded result (`batched_search`, `BatchedSearchResult`).

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
"""

import dataclasses
import functools

import equinox as eqx
import jax
import jax.numpy as jnp
import nlopt
import numpy as np
import optimistix as optx

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
from ._global import _NLOPT_LOCK, NloptObjective


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


EXPLORE_ALGORITHM = "GN_CRS2_LM"
"""nlopt's global exploration of each resample (`Kaelo2006`, controlled
random search with local mutation): derivative-free, seeded, budgeted by
evaluations; its evaluated points are the pool the local fits start from."""


def unit_from_angle(z):
    """Unit-box point `(1 + sin z) / 2` of unconstrained angles `z` (the
    double-bounded transform of MINUIT, `James1975`). A bound is reached at a
    finite `z` (±π/2) where the gradient in `z` vanishes, so a fit whose
    optimum lies on a bound can converge there (and says so) instead of
    running a logit to infinity."""
    return 0.5 * (1.0 + jnp.sin(z))


def angle_from_unit(u):
    """Inverse of `unit_from_angle` on `[0, 1]` (the principal branch)."""
    return np.arcsin(np.clip(2.0 * np.asarray(u, float) - 1.0, -1.0, 1.0))


@dataclasses.dataclass(frozen=True)
class BatchedSearchResult:
    """Outcome of `batched_search` for `R` resamples and `K` local fits each.

    - `u (R, d)`: the best fitted unit-box point of each resample; `loss (R,)`
      its loss; `converged (R,)`: whether that point's fit converged;
    - `restart_losses (R, K)`, `restart_u (R, K, d)`: every fit's final point
      and loss; `start_u (R, K, d)`, `start_losses (R, K)`: their starts (the
      nlopt exploration's best distinct points);
    - `result (R, K)`: optimistix's outcome of every fit (`"successful"`:
      converged within `rtol`/`atol`; `"nonlinear_max_steps_reached"`; other
      `optx.RESULTS` names); `steps (R, K)`: its accepted and rejected steps;
    - `explore_evals (R,)`: nlopt evaluations (value only) per resample;
      `n_evals`: all evaluations (nlopt values + optimistix steps, each one
      value and gradient); `n_evals_computed`: the value-and-gradient
      evaluations the vmapped loop computed (every fit runs until the last
      one stops);
    - `settings`: the solvers, their tolerances and budgets, JSON-ready.
    """

    u: np.ndarray
    loss: np.ndarray
    converged: np.ndarray
    restart_losses: np.ndarray
    restart_u: np.ndarray
    start_u: np.ndarray
    start_losses: np.ndarray
    result: np.ndarray
    steps: np.ndarray
    explore_evals: np.ndarray
    n_evals: int
    n_evals_computed: int
    settings: dict

    def result_counts(self) -> dict[str, int]:
        """How many fits ended with each optimistix result."""
        names, counts = np.unique(self.result, return_counts=True)
        return {str(k): int(v) for k, v in zip(names, counts, strict=True)}


def distinct_starts(points, k: int, space, *, min_distance: float = 0.1):
    """The `k` best of `points` (`[(u (d,), f), ...]`) that lie at least
    `min_distance` apart (max norm in the unit box, free bands sorted by
    centre so a permutation of bands is the same design); filled up with the
    next best points when fewer are that far apart. Returns `(U (k, d), f (k,))`."""
    n = space.n_free
    order = sorted(range(len(points)), key=lambda i: points[i][1])

    def key(u):
        c, w = u[:n], u[n:]
        o = np.argsort(c)
        return np.concatenate([c[o], w[o]])

    chosen: list[int] = []
    for i in order:
        ki = key(points[i][0])
        if all(np.max(np.abs(ki - key(points[j][0]))) >= min_distance for j in chosen):
            chosen.append(i)
        if len(chosen) == k:
            break
    for i in order:
        if len(chosen) == k:
            break
        if i not in chosen:
            chosen.append(i)
    if len(chosen) < k:
        raise ValueError(f"the exploration evaluated {len(points)} points, need {k}.")
    return (
        np.stack([points[i][0] for i in chosen]),
        np.asarray([points[i][1] for i in chosen], float),
    )


@functools.lru_cache(maxsize=32)
def _single_loss(space):
    """Jitted `f(data, u, r, alpha)`; `alpha` traced: one compilation serves
    every objective weight."""
    return jax.jit(lambda data, u, r, a: design_loss(data, space, a, u, r))


def explore(
    data: BatchData,
    space,
    *,
    alpha: float,
    restarts: int,
    evals_per_dim: int,
    seed: int,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """nlopt's global exploration (`EXPLORE_ALGORITHM`) of every resample,
    seeded `seed + r` for resample `r` and budgeted at `evals_per_dim · d`
    loss values; returns the `restarts` best distinct points of each run
    (`distinct_starts`): `(U (R, K, d), f (R, K), evaluations (R,))`."""
    value = _single_loss(space)
    a = jnp.asarray(alpha, data.toa.dtype)
    n_r, dim = data.train_w.shape[0], space.dim
    budget = int(evals_per_dim) * dim
    if budget < restarts:
        raise ValueError(
            f"evals_per_dim {evals_per_dim} x d {dim} < restarts {restarts}: the "
            "exploration must evaluate at least one point per local fit."
        )
    U, F, E = [], [], []
    for r in range(n_r):
        obj = NloptObjective(
            lambda x, r=r: value(data, jnp.asarray(x, data.toa.dtype), r, a),
            None,
            budget,
            keep_points=True,
        )
        with _NLOPT_LOCK:
            nlopt.srand(int(seed) + r)
            opt = nlopt.opt(getattr(nlopt, EXPLORE_ALGORITHM), dim)
            opt.set_lower_bounds(np.zeros(dim))
            opt.set_upper_bounds(np.ones(dim))
            opt.set_min_objective(obj)
            opt.set_maxeval(budget)
            try:
                opt.optimize(np.full(dim, 0.5))
            except nlopt.ForcedStop:  # the adapter's budget: keep what was seen
                pass
            except Exception:  # nlopt's roundoff/generic failures: keep the points
                pass
        u, f = distinct_starts(obj.points, restarts, space)
        U.append(u)
        F.append(f)
        E.append(obj.n_evals)
    return np.stack(U), np.stack(F), np.asarray(E)


@functools.lru_cache(maxsize=32)
def _local_fits(space, max_steps: int, rtol: float, atol: float):
    """Jitted `f(z0 (R, K, d), data, alpha) -> (z, loss, result, steps)`: one
    optimistix BFGS fit per resample and start, vmapped over both (`alpha`
    traced: one compilation serves every objective weight)."""
    solver = optx.BFGS(rtol=rtol, atol=atol)

    def fn(z, args):
        data, r, a = args
        return design_loss(data, space, a, unit_from_angle(z), r)

    def one(z0, r, data, a):
        args = (data, r, a)
        sol = optx.minimise(fn, solver, z0, args=args, max_steps=max_steps, throw=False)
        return (
            sol.value,
            fn(sol.value, args),
            sol.result._value,
            sol.stats["num_steps"],
        )

    per_start = jax.vmap(one, in_axes=(0, None, None, None))
    per_resample = jax.vmap(per_start, in_axes=(0, 0, None, None))

    def run(z0, data, alpha):
        return per_resample(z0, jnp.arange(z0.shape[0]), data, alpha)

    return jax.jit(run)


def _result_names(codes) -> np.ndarray:
    names = {}
    for name in optx.RESULTS._name_to_item:
        names[int(getattr(optx.RESULTS, name)._value)] = name
    return np.vectorize(lambda c: names.get(int(c), "unknown"), otypes=[object])(
        np.asarray(codes)
    )


LOCAL_RTOL = 1e-6
"""Relative tolerance of every local fit (optimistix's Cauchy test: the step
in the angles and the change in loss both below `atol + rtol·|value|`). [1]"""

LOCAL_ATOL = 1e-6
"""Absolute tolerance of every local fit (angles [rad], loss [1])."""


def batched_search(
    data: BatchData,
    space,
    *,
    alpha: float = 0.0,
    restarts: int = 8,
    explore_evals_per_dim: int = 40,
    max_steps: int = 200,
    rtol: float = LOCAL_RTOL,
    atol: float = LOCAL_ATOL,
    seed: int = 0,
) -> BatchedSearchResult:
    """Search every resample of `data`: nlopt explores (`explore`), then an
    optimistix BFGS fit (`Rader2024`) from each of the `restarts` best
    distinct explored points, all resamples and starts in one jitted, vmapped
    function; the angles `z` of `unit_from_angle` are fitted. A fit never
    returns a worse point than its start. See `BatchedSearchResult`."""
    U0, F0, E = explore(
        data,
        space,
        alpha=alpha,
        restarts=restarts,
        evals_per_dim=explore_evals_per_dim,
        seed=seed,
    )
    z0 = jnp.asarray(angle_from_unit(U0), data.toa.dtype)
    run = _local_fits(space, int(max_steps), float(rtol), float(atol))
    z, f, code, steps = run(z0, data, jnp.asarray(alpha, data.toa.dtype))
    U = np.asarray(unit_from_angle(z), float)
    f = np.asarray(f, float)
    worse = ~np.isfinite(f) | (f > F0)
    U = np.where(worse[..., None], U0, U)
    f = np.where(worse, F0, f)
    names = _result_names(code)
    steps = np.asarray(steps, int)
    n_r = U.shape[0]
    best = np.argmin(f, axis=1)
    rows = np.arange(n_r)
    return BatchedSearchResult(
        u=U[rows, best],
        loss=f[rows, best],
        converged=names[rows, best] == "successful",
        restart_losses=f,
        restart_u=U,
        start_u=U0,
        start_losses=F0,
        result=names,
        steps=steps,
        explore_evals=E,
        n_evals=int(E.sum() + steps.sum()),
        n_evals_computed=int(steps.max() * steps.size) if steps.size else 0,
        settings={
            "global": f"nlopt {EXPLORE_ALGORITHM} per resample (seed + resample), "
            f"{explore_evals_per_dim} loss values per dimension; the {restarts} "
            f"best points at least 0.1 apart (unit box) start the local fits",
            "local": "optimistix BFGS on the angles z, u = (1 + sin z) / 2, "
            f"rtol {rtol:g}, atol {atol:g}, max_steps {max_steps}",
            "restarts": int(restarts),
            "explore_evals_per_dim": int(explore_evals_per_dim),
            "max_steps": int(max_steps),
            "rtol": float(rtol),
            "atol": float(atol),
        },
    )


def sorted_design(space, u) -> tuple[np.ndarray, np.ndarray]:
    """(centre, fwhm) of the free bands of unit point `u`, sorted by centre."""
    c, f = (np.asarray(a, float) for a in space.physical(jnp.asarray(u)))
    o = np.argsort(c)
    return c[o], f[o]


def medoid(designs) -> int:
    """Index of the medoid of designs `[(centre (b,), fwhm (b,)), ...]` (bands
    sorted by centre): the design with the least summed Euclidean distance
    in (centre, FWHM) [nm] to all others."""
    v = np.stack([np.concatenate([c, f]) for c, f in designs])
    d = np.sqrt(((v[:, None, :] - v[None, :, :]) ** 2).sum(-1))
    return int(np.argmin(d.sum(1)))


REGIONS_NM = (
    ("violet-blue", 380.0, 490.0),
    ("green", 490.0, 570.0),
    ("yellow-orange", 570.0, 620.0),
    ("red", 620.0, 700.0),
    ("far-red", 700.0, 780.0),
    ("near-infrared", 780.0, 1000.0),
)
"""Spectral regions for the frequency with which a band centre falls in them."""


def region_frequency(designs) -> dict:
    """Fraction of designs with at least one band centred in each region."""
    out = {}
    for name, lo, hi in REGIONS_NM:
        hit = [bool(np.any((c >= lo) & (c < hi))) for c, _ in designs]
        out[name] = float(np.mean(hit)) if hit else 0.0
    return out
