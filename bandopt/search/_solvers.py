"""Paired comparison of the stability search's solvers, in one run: the
Adam loop the study used before (12 uniform random starts x 200 fixed steps
on the logit of the unit box; since the pairing, on optax's Adam rather than
the hand-written update it had, kept here only for this pairing)
against `bandopt.search.batched_search` (nlopt exploration per resample, then
optimistix BFGS fits), on the same resamples, scenes, noise draws and seed,
the new search's evaluations not above the old loop's.

Per band count: final inner loss per resample (the same loss function at each
solver's point), the distance between the two designs of a resample, wall
time, optimistix's results, and whether the designs the study recommends from
them agree (medoid band of one inside the other's min-max interval, per band).
The band count itself is chosen from outer-fold scores of the whole study
(`make run`), which this run does not compute.

Run:  python -m experiments.search_solvers [--bands 3,5] [--out results/search_solvers]
"""

import functools
import os
import sys
import time
from pathlib import Path

import jax
import jax.numpy as jnp
import numpy as np
import optax

from ..provenance import write_manifest
from ..strict_json import strict_dumps
from ._analysis import design_intervals
from ._stability import (
    batched_loss,
    batched_search,
    design_loss,
    local_fits,
    single_loss,
    sorted_design,
)
from ._study import make_study_task, study_batch_data, task_resamples


ADAM = {"restarts": 12, "steps": 200, "lr": 0.08}
"""The Adam loop's settings: restarts per resample, steps, learning rate."""


@functools.lru_cache(maxsize=8)
def _adam_search(space, alpha, steps: int, lr: float):
    """The Adam loop on optax's Adam (`optax.adam`, the old loop's b1 0.9,
    b2 0.999, eps 1e-8 outside the root): the logit of the unit box, a fixed
    number of steps (`lax.scan`), no convergence criterion, the best point of
    each restart kept."""

    def per(data, u, r):
        return design_loss(data, space, alpha, u, r)

    def total(zs, data):
        U = jax.nn.sigmoid(zs)
        rs = jnp.arange(U.shape[0])
        f = jax.vmap(jax.vmap(per, in_axes=(None, 0, None)), in_axes=(None, 0, 0))(
            data, U, rs
        )
        f = jnp.where(jnp.isfinite(f), f, 1e30)
        return jnp.sum(f), f

    grad = jax.grad(total, has_aux=True)
    adam = optax.adam(lr, b1=0.9, b2=0.999, eps=1e-8)

    def run(z0, data):
        def step(carry, _):
            z, state, best_f, best_z = carry
            g, f = grad(z, data)
            g = jnp.where(jnp.isfinite(g), g, 0.0)
            better = f < best_f
            best_f = jnp.where(better, f, best_f)
            best_z = jnp.where(better[..., None], z, best_z)
            updates, state = adam.update(g, state, z)
            z = jnp.clip(optax.apply_updates(z, updates), -8.0, 8.0)
            return (z, state, best_f, best_z), None

        init = (z0, adam.init(z0), jnp.full(z0.shape[:2], jnp.inf, z0.dtype), z0)
        (z, _, best_f, best_z), _ = jax.lax.scan(step, init, None, length=steps)
        _, f_last = total(z, data)
        better = f_last < best_f
        best_f = jnp.where(better, f_last, best_f)
        best_z = jnp.where(better[..., None], z, best_z)
        return jax.nn.sigmoid(best_z), best_f

    return jax.jit(run)


def adam_search(data, space, *, alpha, seed) -> dict:
    """The Adam loop's search: uniform starts in [0.05, 0.95] from
    `default_rng(seed)`, then `_adam_search`."""
    n_r = data.train_w.shape[0]
    rng = np.random.default_rng(seed)
    u0 = rng.uniform(0.05, 0.95, size=(n_r, ADAM["restarts"], space.dim))
    z0 = jnp.asarray(np.log(u0 / (1 - u0)), data.toa.dtype)
    run = _adam_search(space, float(alpha), ADAM["steps"], ADAM["lr"])
    U, f = (np.asarray(a, float) for a in run(z0, data))
    best = np.argmin(f, axis=1)
    rows = np.arange(n_r)
    return {
        "u": U[rows, best],
        "loss": f[rows, best],
        "n_evals": int(n_r * ADAM["restarts"] * (ADAM["steps"] + 1)),
    }


def _timed(fn):
    """(result, wall time [s]) of one call."""
    t0 = time.perf_counter()
    out = fn()
    return out, time.perf_counter() - t0


def _precompile(data, space, alpha, task) -> dict:
    """Compile both solvers' jitted cores ahead of time (into JAX's persistent
    cache, which the timed calls then load), so the wall times compare the
    searches, not the compilers. Returns the compile times [s]."""
    n_r = data.train_w.shape[0]
    z = jnp.zeros((n_r, ADAM["restarts"], space.dim), data.toa.dtype)
    t0 = time.perf_counter()
    _adam_search(space, float(alpha), ADAM["steps"], ADAM["lr"]).lower(
        z, data
    ).compile()
    t1 = time.perf_counter()
    z = jnp.zeros((n_r, task["restarts"], space.dim), data.toa.dtype)
    a = jnp.asarray(alpha, data.toa.dtype)
    local_fits(space, task["max_steps"], task["rtol"], task["atol"]).lower(
        z, data, a
    ).compile()
    single_loss(space)(data, jnp.full(space.dim, 0.5), 0, a)
    t2 = time.perf_counter()
    return {"adam": t1 - t0, "nlopt+bfgs": t2 - t1}


def _inside(value, interval) -> bool:
    """`value` inside `[lo, hi]`, up to rounding."""
    return bool(interval[0] - 1e-9 <= value <= interval[1] + 1e-9)


def compare_band_count(ctx, res, task, alpha: float) -> dict:
    """Both solvers on the resamples `res` of one study `task` (its band
    count) at objective weight `alpha`: losses, design distances, wall and
    compile times, evaluations, optimistix's results and whether the two
    recommended designs agree. Prints a one-line summary to stderr."""
    space, data = study_batch_data(task, ctx, res)
    t_compile = _precompile(data, space, alpha, task)
    load = {"before_adam": os.getloadavg()[0]}
    old, t_old = _timed(
        lambda: adam_search(data, space, alpha=alpha, seed=task["seed"])
    )
    kw = {
        k: task[k]
        for k in ("restarts", "explore_evals_per_dim", "max_steps", "rtol", "atol")
    }
    load["after_adam"] = os.getloadavg()[0]
    new, t_new = _timed(
        lambda: batched_search(data, space, alpha=alpha, seed=task["seed"], **kw)
    )
    load["after_nlopt+bfgs"] = os.getloadavg()[0]
    f = batched_loss(space, alpha)
    # the same loss function at both points (the old loop's own value too)
    f_old = np.asarray(f(data, jnp.asarray(old["u"][:, None, :])), float)[:, 0]
    f_new = np.asarray(f(data, jnp.asarray(new.u[:, None, :])), float)[:, 0]
    designs = {"adam": [], "nlopt+bfgs": []}
    dist = []
    for i in range(len(res)):
        co, fo = sorted_design(space, old["u"][i])
        cn, fn = sorted_design(space, new.u[i])
        designs["adam"].append({"centre_nm": co.tolist(), "fwhm_nm": fo.tolist()})
        designs["nlopt+bfgs"].append({"centre_nm": cn.tolist(), "fwhm_nm": fn.tolist()})
        d = np.concatenate([co - cn, fo - fn])
        dist.append(
            {
                "euclidean_nm": float(np.sqrt(np.sum(d**2))),
                "max_abs_nm": float(np.max(np.abs(d))),
            }
        )
    rec = {k: design_intervals(v) for k, v in designs.items()}
    a, b = rec["adam"], rec["nlopt+bfgs"]
    nb = len(a["centre_nm"])
    agree = {
        "new_medoid_inside_old_intervals": [
            _inside(b["centre_nm"][j], a["centre_interval_nm"][j])
            and _inside(b["fwhm_nm"][j], a["fwhm_interval_nm"][j])
            for j in range(nb)
        ],
        "old_medoid_inside_new_intervals": [
            _inside(a["centre_nm"][j], b["centre_interval_nm"][j])
            and _inside(a["fwhm_nm"][j], b["fwhm_interval_nm"][j])
            for j in range(nb)
        ],
        "medoid_centre_difference_nm": (
            np.asarray(b["centre_nm"]) - np.asarray(a["centre_nm"])
        ).tolist(),
        "medoid_fwhm_difference_nm": (
            np.asarray(b["fwhm_nm"]) - np.asarray(a["fwhm_nm"])
        ).tolist(),
    }
    ratio = f_new / f_old
    row = {
        "n_free_bands": space.n_free,
        "alpha": alpha,
        "resamples": len(res),
        "loss": {"adam": f_old.tolist(), "nlopt+bfgs": f_new.tolist()},
        "loss_ratio_new_over_old": ratio.tolist(),
        "median_loss_ratio": float(np.median(ratio)),
        "resamples_new_lower": int(np.sum(f_new < f_old * (1 - 1e-9))),
        "resamples_new_higher": int(np.sum(f_new > f_old * (1 + 1e-9))),
        "old_loop_own_value_matches": bool(np.allclose(old["loss"], f_old, rtol=1e-8)),
        "design_distance": dist,
        "median_design_distance_nm": float(
            np.median([d["euclidean_nm"] for d in dist])
        ),
        "wall_s": {"adam": t_old, "nlopt+bfgs": t_new},
        "compile_s": t_compile,
        "wall_s_note": "one call each, compiled beforehand (compile_s), on a "
        "shared 2-core machine (1-min load averages in load_average)",
        "load_average": load,
        "time_ratio_new_over_old": t_new / t_old,
        "evaluations": {
            "adam": old["n_evals"],
            "nlopt+bfgs": new.n_evals,
            "nlopt+bfgs_computed": new.n_evals_computed + int(new.explore_evals.sum()),
            "nlopt_values": int(new.explore_evals.sum()),
        },
        "fit_results": new.result_counts(),
        "designs_converged": int(new.converged.sum()),
        "settings": {"adam": ADAM, "nlopt+bfgs": new.settings},
        "recommendation": {"adam": a, "nlopt+bfgs": b, **agree},
    }
    print(
        f"n={space.n_free}: median loss ratio {row['median_loss_ratio']:.3f} "
        f"(new lower on {row['resamples_new_lower']}/{len(res)}), time ratio "
        f"{row['time_ratio_new_over_old']:.2f} ({t_new:.0f} s vs {t_old:.0f} s), "
        f"converged designs {row['designs_converged']}/{len(res)}, fits "
        f"{row['fit_results']}",
        file=sys.stderr,
        flush=True,
    )
    return row


def compare_solvers(
    out, *, bands=(5,), alpha=0.0, partitions=4, seed=0, config=None
) -> dict:
    """Compare the two solvers at each band count of `bands` (objective
    weight `alpha`, `partitions` lamp partitions); writes `compare.json` and
    the manifest (`config`: the run's settings) into `out`. Returns the
    comparison."""
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    rows = []
    for n in bands:
        task = make_study_task(n_bands=n, alpha=alpha, partitions=partitions, seed=seed)
        ctx, res = task_resamples(task)
        rows.append(compare_band_count(ctx, res, task, alpha))
    result = {
        "note": __doc__,
        "rows": rows,
        "same_band_count": "not decided here: the band count comes from the "
        "whole study's outer-fold scores (make run)",
        "context": ctx.config,
    }
    (out / "compare.json").write_text(
        strict_dumps(result, indent=1) + "\n"
    )
    write_manifest(out, seed=seed, config=config)
    print(f"wrote {out / 'compare.json'}")
    return result
