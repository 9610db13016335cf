"""Stability study tasks: batched search over lamp resamples, outer-fold scoring.

One task = one band count `n_bands` and one objective weight `alpha` (see
`_stability`), searched on every resample of `partitions` lamp partitions
in one compiled function; each resample's design is then judged on its own
outer test lamps with the pluggable *scorer* (`SCORERS`, `DEFAULT_SCORER`):
estimation error per lamp, level-2 macro F1 of the KNN classifier
(`bandopt.knn`, k chosen on the inner folds) and the design's SNR.
Reference-sensor tasks score a fixed band set on the same resamples.
"""

import dataclasses
import functools
import time
from collections.abc import Callable

import jax.numpy as jnp
import numpy as np

from .. import inversion
from ..datasets import atmosphere
from ..estimate import CCT_RANGE_K, fit_estimator, lamp_abs_errors
from ..knn import choose_k, features, neighbour_labels, vote_proba
from ..sensor import SensorParams, noise_electrons, signal_electrons
from ..sensor.reference import reference_sensor
from ._context import _scale_to, get_context
from ._problem import Space
from ._stability import (
    LOCAL_ATOL,
    LOCAL_RTOL,
    batched_search,
    design_terms,
    lamp_resamples,
    make_batch_data,
    overlap_matrix,
    sorted_design,
)


DEFAULT_SCORER = "inversion"
"""Estimator that judges designs on the outer folds (the same for reference
sensors): the physics-based inversion, the estimator users get from
`bandopt evaluate`. The search objective itself stays the differentiable
ridge surrogate (closed-form, inside the compiled batched search); the
inversion costs about as much as the ridge per outer fold, so judging with it
keeps the study's run time."""


@dataclasses.dataclass(frozen=True)
class FittedScorer:
    """A scorer fitted on one outer training set. Call it as
    `predict(radiance, bands=None) -> (N, 3)` [lm/W, 1, K]; `hyper` holds its
    inner-CV choices, which the scorer reuses instead of choosing again when
    given them back (`fit(..., hyper=fitted.hyper)`: only the rest is refitted)."""

    predict: Callable
    hyper: dict

    def __call__(self, radiance, bands=None) -> np.ndarray:
        return self.predict(radiance, bands)


def _ridge_fit(ctx, bands, rad, train, inner, *, hyper=None) -> FittedScorer:
    """Ridge on centred log ratios (degree and strength by inner CV, or fixed
    by `hyper` = `{"degree": (3,), "lam": (3,)}`, one per metric: then only
    the coefficients are fitted)."""
    est = fit_estimator(rad, ctx.table, train, inner, **(hyper or {}))
    return FittedScorer(
        lambda r, b=None: np.asarray(est.predict(jnp.asarray(r))),
        {"degree": est.degree, "lam": est.lam},
    )


def _inversion_fit(ctx, bands, rad, train, inner, *, hyper=None) -> FittedScorer:
    """Physics-based inversion (`bandopt.inversion`, surface unknown) fitted on
    `train` (`σ_rel` by inner CV, or fixed by `hyper` = `{"sigma_rel": s}`;
    the prior's forward model always uses `bands`); `predict` inverts only the
    rows of lamps outside `train` (the outer test lamps; other rows are NaN).
    A null CCT (the posterior says no meaningful CCT) counts as 25000 K, the
    far end of the range."""
    grid = inversion.SIGMA_REL_GRID if hyper is None else (hyper["sigma_rel"],)
    inv = inversion.fit_for_context(ctx, bands, rad, train, inner, sigma_grid=grid)
    held = ~np.isin(ctx.table.lamp_of, np.asarray(train))

    def predict(r, b=None):
        out = np.full((r.shape[0], 3), np.nan)
        rows = np.flatnonzero(held) if r.shape[0] == held.size else np.arange(len(r))
        est = inv.predict(np.asarray(r)[rows]).estimate
        est[:, 2] = np.where(np.isfinite(est[:, 2]), est[:, 2], CCT_RANGE_K[1])
        out[rows] = est
        return out

    return FittedScorer(predict, {"sigma_rel": float(inv.sigma_rel)})


SCORERS: dict[str, Callable] = {"ridge": _ridge_fit, "inversion": _inversion_fit}
"""`fit(ctx, bands, radiance, train, inner, *, hyper=None) -> FittedScorer`."""

SCORER_NOTES = {
    "ridge": "ridge regression on centred log band ratios (bandopt.estimate."
    "fit_estimator: feature degree 1-2 and strength by inner CV), refitted on "
    "each outer training set",
    "inversion": "physics-based inversion (bandopt.inversion.fit_for_context: "
    "prior over the measured training lamps, surface unknown), refitted on each "
    "outer training set",
}


def get_scorer(name: str) -> Callable:
    if name not in SCORERS:
        raise ValueError(f"Unknown scorer {name!r}; expected one of {list(SCORERS)}.")
    return SCORERS[name]


def f1_outer(ctx, rad, train, inner, test) -> tuple[np.ndarray, np.ndarray]:
    """KNN (`bandopt.knn`, as `bandopt.classify` uses it) level-2 predictions
    on the test lamps' scenes: returns (true labels, predicted labels) as
    integers."""
    x = np.asarray(features(jnp.asarray(rad)))
    names = sorted(set(np.asarray(ctx.table.classes, object).tolist()))
    lab = np.asarray([names.index(c) for c in ctx.table.classes])[ctx.table.lamp_of]
    lamp = ctx.table.lamp_of
    rows = np.isfinite(x).all(1)
    tr_rows = rows & np.isin(lamp, train)
    k, _ = choose_k(x, lab, lamp, inner, len(names), rows=tr_rows)
    te = rows & np.isin(lamp, test)
    nbr = neighbour_labels(x[tr_rows], lab[tr_rows], x[te], k)
    pred = np.argmax(vote_proba(nbr, k, len(names)), axis=1)
    return lab[te], pred


def design_snr(ctx, bands) -> float:
    """Median over scenes (signal > 0 in every band) of the weakest band's
    shot-noise SNR at the context's signal level (thesis Table 2.3 sensor)."""
    wl = jnp.asarray(ctx.wavelength_nm)
    toa = ctx.toa.reshape(-1, ctx.toa.shape[-1])
    if ctx.noise_radiance is not None:
        toa = _scale_to(toa, ctx.wavelength_nm, ctx.noise_radiance)
    e = np.asarray(signal_electrons(toa, bands.response(wl), wl, SensorParams()))
    ok = (e > 0).all(axis=1)
    snr = e[ok] / np.asarray(noise_electrons(jnp.asarray(e[ok]), SensorParams()))
    return float(np.median(snr.min(axis=1))) if ok.any() else 0.0


def score_design(ctx, bands, resamples, *, scorer: str, seed: int, which=None):
    """Outer-fold scores of one band set on `resamples` (indices `which`, all
    by default). Returns one dict per resample: test lamp indices and
    per-lamp absolute errors `(k, 3)`, true/predicted class labels."""
    rad = ctx.radiance(bands, seed=seed)
    fit = get_scorer(scorer)
    out = []
    for i in range(len(resamples)) if which is None else which:
        r = resamples[i]
        predict = fit(ctx, bands, rad, r.train, list(r.inner))

        err = lamp_abs_errors(predict(rad, bands), ctx.table, r.test)
        yt, yp = f1_outer(ctx, rad, r.train, list(r.inner), r.test)
        out.append(
            {
                "resample": int(i),
                "partition": int(r.partition),
                "fold": int(r.fold),
                "lamp_index": np.asarray(r.test).tolist(),
                "lamp_errors": err.tolist(),
                "labels_true": yt.tolist(),
                "labels_pred": yp.tolist(),
            }
        )
    return out


def study_space(task, ctx):

    return Space(
        int(task["n_bands"]),
        pan=task["pan"],
        min_fwhm_nm=float(task["min_fwhm_nm"]),
        max_fwhm_nm=float(task["max_fwhm_nm"]),
        lower_nm=float(np.min(ctx.wavelength_nm)),
        upper_nm=float(np.max(ctx.wavelength_nm)),
    )


def study_batch_data(task, ctx, resamples):
    """The search space of a study task and its batched data on `resamples`
    (the context's noise setting, the task's seed)."""
    space = study_space(task, ctx)
    data = make_batch_data(
        ctx.toa,
        ctx.wavelength_nm,
        ctx.table,
        resamples,
        space,
        noise=ctx.noise,
        noise_radiance=ctx.noise_radiance,
        seed=task["seed"],
    )
    return space, data


@functools.lru_cache(maxsize=4)
def study_resamples(preset, noise, atmospheres, partitions, seed):

    ctx = get_context(preset, noise, 0, atmospheres)
    return ctx, tuple(lamp_resamples(ctx.table.classes, partitions, seed=seed))


def task_resamples(task):
    """`study_resamples` of a study task: its context and lamp resamples."""
    return study_resamples(
        task["preset"],
        task["noise"],
        task["atmospheres"],
        task["partitions"],
        task["seed"],
    )


STUDY_TASK = {
    "kind": "stability",
    "version": 4,  # bump when a task's result changes for the same fields
    "preset": "search",
    "noise": "P4",
    "atmospheres": "auto",
    "partitions": 4,
    "seed": 0,
    "n_bands": 3,
    "pan": "fixed",
    "alpha": 0.0,
    "restarts": 8,
    "explore_evals_per_dim": 40,
    "max_steps": 200,
    "rtol": LOCAL_RTOL,
    "atol": LOCAL_ATOL,
    "min_fwhm_nm": 20.0,
    "max_fwhm_nm": 200.0,
    "scorer": DEFAULT_SCORER,
    "target": "all",
}


def make_study_task(**kw) -> dict:

    unknown = set(kw) - set(STUDY_TASK) - {"sensor"}
    if unknown:
        raise ValueError(f"Unknown study task fields {sorted(unknown)}.")
    t = {**STUDY_TASK, **kw}
    # resolved now, so the task's hash says which atmosphere was used
    t["atmospheres"] = atmosphere.resolve_setting(t["atmospheres"])
    return t


def run_study_task(task: dict) -> dict:
    """Run one stability task (search) or reference task (`sensor` set)."""
    t0 = time.perf_counter()
    ctx, res = task_resamples(task)
    if task.get("sensor"):
        bands = reference_sensor(task["sensor"])
        scores = score_design(ctx, bands, res, scorer=task["scorer"], seed=task["seed"])
        return {
            "task": task,
            "bands": {
                "name": bands.name,
                "centre_nm": np.asarray(bands.centre_nm, float).tolist(),
                "fwhm_nm": np.asarray(bands.fwhm_nm, float).tolist(),
                "names": list(bands.names),
            },
            "n_bands_total": len(bands.names),
            "snr": design_snr(ctx, bands),
            "scores": scores,
            "context": ctx.config,
            "wall_s": time.perf_counter() - t0,
        }
    space, data = study_batch_data(task, ctx, res)
    t1 = time.perf_counter()
    s = batched_search(
        data,
        space,
        alpha=task["alpha"],
        restarts=task["restarts"],
        explore_evals_per_dim=task["explore_evals_per_dim"],
        max_steps=task["max_steps"],
        rtol=task["rtol"],
        atol=task["atol"],
        seed=task["seed"],
    )
    search_s = time.perf_counter() - t1

    designs, scores, snrs, terms, overlaps = [], [], [], [], []
    for i, u in enumerate(s.u):
        c, f = sorted_design(space, u)
        bands = space.band_set(c, f, name=f"stability-n{space.n_bands}-r{i}")
        designs.append({"centre_nm": c.tolist(), "fwhm_nm": f.tolist()})
        e, cl, _ = design_terms(data, space, jnp.asarray(u), i)
        terms.append({"est": float(e), "cls": float(cl)})
        free = np.asarray(bands.response(jnp.asarray(ctx.wavelength_nm)))[
            : space.n_free
        ]
        overlaps.append(float(np.max(np.asarray(overlap_matrix(jnp.asarray(free))))))
        snrs.append(design_snr(ctx, bands))
        scores += score_design(
            ctx, bands, res, scorer=task["scorer"], seed=task["seed"], which=[i]
        )
    return {
        "task": task,
        "space": space.to_dict(),
        "designs": designs,
        "inner_loss": s.loss.tolist(),
        "inner_terms": terms,
        "restart_losses": s.restart_losses.tolist(),
        "optimiser": s.settings,
        "fit_results": s.result_counts(),
        "design_converged": s.converged.tolist(),
        "restart_results": s.result.tolist(),
        "local_steps": s.steps.tolist(),
        "saturated": ((s.u < 1e-3) | (s.u > 1 - 1e-3)).tolist(),
        "max_overlap": overlaps,
        "snr": snrs,
        "scores": scores,
        "n_evals": s.n_evals,
        "n_evals_computed": s.n_evals_computed,
        "search_s": search_s,
        "evals_per_s": s.n_evals / search_s,
        "context": ctx.config,
        "wall_s": time.perf_counter() - t0,
    }
