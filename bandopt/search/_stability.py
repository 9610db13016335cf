"""Band search on many lamp resamples at once: one compiled, batched search.

A *resample* is one outer fold of one lamp partition (repeated grouped,
class-stratified 3-fold splits, `bandopt.folds.nested_lamp_splits` with seed
`seed + 101·p` for partition `p`): its bands are searched on the outer training
lamps (loss = inner-CV error of the closed-form ridge surrogate, two inner
folds) and judged on the outer test lamps. All resamples and all restarts of
one band count run in ONE jitted function: `vmap` over resamples (their split
weights are data) and starts. nlopt explores each resample globally (seeded,
budgeted by evaluations) and its best distinct points start optimistix BFGS
fits, vmapped over resamples and starts, each ending with optimistix's
recorded result (`batched_search`, `BatchedSearchResult`).

The resamples, `BatchData` and the loss of a design (estimation,
classification and band-overlap terms) are `_batch_loss`'s, re-exported
here; this module holds the solvers (nlopt exploration, optimistix BFGS
fits) and the summaries of the designs they find (medoid, spectral
regions).
"""

import dataclasses
import functools

import jax
import jax.numpy as jnp
import nlopt
import numpy as np
import optimistix as optx

from ._batch_loss import (
    MAX_OVERLAP as MAX_OVERLAP,
    MIN_FWHM_NM as MIN_FWHM_NM,
    OVERLAP_WEIGHT as OVERLAP_WEIGHT,
    BatchData as BatchData,
    Resample as Resample,
    _batched_loss as _batched_loss,
    _radiance as _radiance,
    batched_loss as batched_loss,
    class_cv_loss as class_cv_loss,
    design_loss as design_loss,
    design_terms as design_terms,
    lamp_resamples as lamp_resamples,
    make_batch_data as make_batch_data,
    overlap_matrix as overlap_matrix,
    shared_ridge_cv as shared_ridge_cv,
)
from ._global import _NLOPT_LOCK, NloptObjective


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
def single_loss(space):
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
    value = single_loss(space)
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
def local_fits(space, max_steps: int, rtol: float, atol: float):
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
    run = local_fits(space, int(max_steps), float(rtol), float(atol))
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
