"""`fit_inversion`: an inversion fitted on training lamps, with its band error,
conformal factors, unexplained threshold and (optionally) probability
temperatures chosen on inner folds, and its prior extended by modelled,
mixed, shifted and near-infrared variant lamps as asked."""

import dataclasses
from collections.abc import Sequence

import numpy as np

from ..estimate import METRICS, lamp_truth
from ..folds import class_balanced_weights
from ._calibrate import (
    FLAG_NOISE,
    UNEXPLAINED_QUANTILE,
    _global_probabilities,
    _narrowest_intervals,
    _per_metric_held_out,
    _probability_temperatures,
    _row_weights,
)
from ._conditions import Conditions
from ._lamps import MODELLED_CLASSES, LampSet, modelled_lamps
from ._metrics import (
    _metrics_per_posterior,
    _posterior_metrics,
    _to_model,
    weighted_quantile,
)
from ._model import FlagFold, Inversion, build_inversion
from ._scoring import SIGMA_FLOOR, SIGMA_REL_GRID
from ._surfaces import SurfaceBasis, surface_basis
from ._variants import (
    CROSS_MIX_SHARES,
    MIX_FRACTIONS,
    cross_mixture_lamps,
    mixture_lamps,
    nir_variants,
    shifted_lamps,
    variant_base,
)


CALIBRATIONS = ("lamps", "classes", "flagged")
"""Held-out data `fit_inversion` calibrates its 90 % intervals on: `"lamps"`
(default: the inner folds' held-out lamps, whose classes the inner prior
holds, so the intervals are calibrated for new lamps of known types),
`"classes"` (each training class held out in turn from a prior of the other
classes at the chosen `σ_rel`: calibrated for lamps of a type the prior does
not hold, so wider) or `"flagged"` (both: a pixel the prior explains gets
the intervals calibrated on held-out lamps of known types, a pixel flagged
`unexplained` those calibrated on held-out types; `Inversion.
conformal_unexplained`). With `"classes"` every pixel pays for the types
the prior lacks: 0.97-0.98 of new lamps of known types fell inside their
nominal 90 % intervals (robustness suite at 6097a86); `"flagged"` spends
that width only where the misfit test says the prior is out of its
depth."""


SIGMA_RULES = ("error", "evidence", "per-metric")
"""How `fit_inversion` chooses `σ_rel` on its inner folds: `"error"` (the
class-balanced metric error of the held-out inner lamps, normalised per
metric and summed: the target itself, but noisy with few lamps per class),
`"evidence"` (the class-balanced mean log marginal likelihood of their
pixels, `log_evidence`: a proper score over every pixel and band, so a
steadier choice, but of the band-noise model, not of the metric error) or
`"per-metric"` (`σ_rel` as `"error"` for the types, misfit and flag, and
each metric's estimate and interval from the posterior at its own `σ_rel`,
the one with the least held-out error of that metric: `Inversion.
metric_sigma`; one more scoring per pixel when they differ). A small
`σ_rel` weighs the bands nearly by absolute error (the floor `SIGMA_FLOOR`
is then a third of the error), a large one by relative error; LER is best
estimated with the former, G and CCT with the latter (measured by
`make study NAME=estimate-mix`), so one σ for all three is a trade-off."""


def _lamp_errors(pred_model, truth_model, valid, row_lamp, lamps):
    """Mean |error| per lamp over its rows in model space, (len(lamps), 3)."""
    out = np.full((len(lamps), 3), np.nan)
    for i, l in enumerate(lamps):
        rows = row_lamp == l
        e = np.abs(pred_model[rows] - truth_model[l][None]).mean(axis=0)
        out[i] = np.where(valid[l], e, np.nan)
    return out


def _candidates(fracs, offs, confs, widths) -> dict:
    """Each candidate interval offset's model-space offset, conformal
    factors and mean calibrated widths per metric, keyed by its fraction."""
    return {
        f"{f:g}": {
            "offset": dict(zip(METRICS, offs[c].tolist(), strict=True)),
            "conformal": dict(zip(METRICS, confs[c].tolist(), strict=True)),
            "mean_width": dict(zip(METRICS, widths[c].tolist(), strict=True)),
        }
        for c, f in enumerate(fracs)
    }


def fit_inversion(
    radiance,
    row_lamp,
    lamps: LampSet,
    train_lamps,
    inner: Sequence[tuple[np.ndarray, np.ndarray]],
    weights,
    conditions: Conditions,
    *,
    basis: SurfaceBasis | None = None,
    surface_mode: str = "unknown",
    row_surface=None,
    always: LampSet | None = None,
    sigma_grid: Sequence[float] = SIGMA_REL_GRID,
    modelled_per_class: int = 0,
    modelled_classes: Sequence[str] = MODELLED_CLASSES,
    modelled_seed: int = 0,
    sigma_rule: str = "error",
    floor_grid: Sequence[float] = (SIGMA_FLOOR,),
    row_moon=None,
    calibration: str = "lamps",
    mixtures: int = 0,
    cross_mixtures: int = 0,
    interval_offsets: Sequence[float] = (0.0,),
    peak_shifts: Sequence[float] = (),
    nir_error: bool = False,
    calibrate_probabilities: bool = False,
) -> Inversion:
    """Fit an inversion on `train_lamps` (indices into `lamps`).

    `radiance` (N, b) are simulated band radiances of labelled pixels whose lamp
    is `row_lamp` (N,) (index into `lamps`); `inner` are (train, validation)
    lamp splits of `train_lamps` on which `σ_rel`, the conformal factors and the
    unexplained threshold are chosen (never the lamps scored later).
    `row_surface`: per-pixel surface knowledge for modes 'class'/'measured'.
    `always`: lamps that are in every prior and never scored.

    `modelled_per_class` (default 0: measured lamps only): add that many
    modelled lamps per class of `modelled_classes` to every prior this fit
    builds (`modelled_lamps`, seed `modelled_seed`), each calibrated on the
    measured lamps of THAT prior only: the final prior on `train_lamps` plus
    `always`, each inner fold's prior on its own training lamps plus `always`
    (so the inner validation lamps that set `σ_rel`, the conformal factors
    and the threshold never shape a model either). Modelled lamps are never
    scored: no row of `radiance` belongs to them. `diagnostics
    ["modelled_lamps"]` records what the final prior holds.

    `sigma_rule` (`SIGMA_RULES`): how `σ_rel` is chosen on the inner folds,
    by held-out metric error (default), by held-out log evidence, or by
    held-out metric error per metric (`"per-metric"`: each metric's estimate,
    interval and conformal factor at its own `σ_rel`, `Inversion.
    metric_sigma`; types, misfit and the unexplained threshold at the
    `"error"` choice); `diagnostics` holds every criterion per candidate
    and `diagnostics["metric_sigma"]` each metric's `σ_rel`.

    `floor_grid` (default: `SIGMA_FLOOR` alone): band-error floor
    candidates, chosen with `σ_rel` (every pair of the two grids; the inner
    scoring grows with their product) by the same rule; `sigma_floor` and
    `diagnostics["sigma_floor"]` / `["metric_floor"]` say which. With more
    than one floor the diagnostics' keys are `"σ/floor"`.

    `row_moon` (N,): the Moon's brightness per row when known (see
    `Inversion.posterior`), used on the inner folds; pass the test pixels'
    to `predict` too. Default None: fitted.

    `calibration` (`CALIBRATIONS`): the held-out lamps the conformal factors
    of the 90 % intervals are chosen on: the inner folds' (`"lamps"`,
    default) or each training class held out in turn (`"classes"`: one more
    prior per training class, at the chosen `σ_rel`, its rows scored once;
    class-balanced like the inner folds) or both (`"flagged"`: the first for
    pixels the prior explains, the second for pixels flagged `unexplained`;
    `diagnostics["interval_candidates_unexplained"]` holds the second's
    candidates). `σ_rel` and the unexplained
    threshold come from the inner folds either way, so the point estimates
    and flags do not change; `diagnostics["calibration"]` says which.

    `mixtures` (default 0: none): every prior this fit builds also holds
    pairwise mixtures of its own measured lamps (`mixture_lamps`, at most
    `mixtures` pairs per class, seed `modelled_seed`): the final prior's of
    `train_lamps` and `always`, each inner fold's of its own training lamps
    and `always`. `diagnostics["mixtures"]` says how many.

    `cross_mixtures` (default 0: none): every prior this fit builds also
    holds blends of two of its measured lamps of different types, labelled
    by the majority lamp (`cross_mixture_lamps`, that many pairs per ordered
    class pair, seed `modelled_seed`), for pixels holding two lamp types.
    `diagnostics["cross_mixtures"]` says how many.

    `interval_offsets` (default `(0.0,)`: the interval's unit is the
    posterior's half-width; `INTERVAL_OFFSET_GRID` to choose):
    candidate offsets, as fractions of each metric's spread over
    `train_lamps`, added to the half-width before conformal scaling; each
    metric takes the candidate whose calibrated intervals are narrowest on
    the held-out calibration lamps (`_narrowest_intervals`; every candidate
    is calibrated to the same coverage there). `diagnostics
    ["interval_candidates"]` holds each candidate's factors and mean widths,
    so `Inversion.with_interval_offset` gives any candidate's intervals.

    `nir_error` (default False): every prior this fit builds also holds the
    NIR variants of its extended lamps (`nir_variants`), so the modelled
    780-900 nm part carries its measured error into every band that sees it.

    `calibrate_probabilities` (default False): the level-1 and level-2
    probabilities are temperature-scaled (`bandopt.calibration`) on the inner
    folds' held-out rows (types the prior knows), class-balanced.
    `diagnostics["probabilities"]` gives the temperatures and, for those rows
    and (with calibration "classes") the rows of each training class held
    out in turn (types it lacks), the ECE before and after and the
    `unexplained` rate."""
    fracs = [float(x) for x in interval_offsets]
    if not fracs or min(fracs) < 0 or len(set(fracs)) != len(fracs):
        raise ValueError(
            f"interval_offsets {tuple(interval_offsets)}: need distinct values >= 0."
        )
    if calibration not in CALIBRATIONS:
        raise ValueError(
            f"calibration {calibration!r}: expected one of {CALIBRATIONS}."
        )
    if sigma_rule not in SIGMA_RULES:
        raise ValueError(f"sigma_rule {sigma_rule!r}: expected one of {SIGMA_RULES}.")
    if modelled_per_class < 0:
        raise ValueError(f"modelled_per_class must be >= 0 (got {modelled_per_class}).")
    radiance = np.asarray(radiance, float)
    row_lamp = np.asarray(row_lamp, int)
    weights = np.asarray(weights, float)
    grid = conditions.wavelength_nm
    basis = basis if basis is not None else surface_basis(grid)
    truth, valid = lamp_truth(lamps.spectra, grid)
    tm = _to_model(np.where(valid, truth, 1.0))
    l2 = np.asarray(lamps.level2, dtype=object)

    def modelled(train_idx) -> tuple[LampSet | None, dict]:
        if modelled_per_class == 0:
            return None, {"n_per_class": 0, "added": {}}
        ids = [lamps.ids[i] for i in np.asarray(train_idx, int)]
        ids += [] if always is None else list(always.ids)
        mset, info = modelled_lamps(
            ids,
            grid,
            modelled_per_class,
            classes=modelled_classes,
            seed=modelled_seed,
        )
        if not set(mset.ids).isdisjoint(lamps.ids):  # scored rows are lamps'
            raise RuntimeError("a modelled lamp id is also a scored lamp's id.")
        return mset, info

    if mixtures < 0:
        raise ValueError(f"mixtures must be >= 0 (got {mixtures}).")
    if cross_mixtures < 0:
        raise ValueError(f"cross_mixtures must be >= 0 (got {cross_mixtures}).")

    def make(prior_set: LampSet, noise, extra=None) -> Inversion:
        pset = prior_set if always is None else prior_set + always
        measured = pset
        if mixtures:
            pset = pset + mixture_lamps(measured, mixtures, seed=modelled_seed)
        if cross_mixtures:
            pset = pset + cross_mixture_lamps(
                measured, cross_mixtures, seed=modelled_seed
            )
        if peak_shifts:
            pset = pset + shifted_lamps(measured, grid, peak_shifts)
        if nir_error:
            pset = pset + nir_variants(measured, grid)
        pset = pset if extra is None else pset + extra
        return build_inversion(
            pset, weights, conditions, basis, surface_mode, noise[0], noise[1]
        )

    def rows_of(lamp_idx):
        return np.flatnonzero(np.isin(row_lamp, lamp_idx))

    moon_rows = None if row_moon is None else np.asarray(row_moon, float)

    def moon_of(rows):
        return None if moon_rows is None else moon_rows[rows]

    def surf(rows):
        if row_surface is None:
            return None
        if isinstance(row_surface, np.ndarray) and row_surface.ndim == 2:
            return row_surface[rows]
        return [row_surface[i] for i in rows]

    # inner folds: choose σ_rel, collect calibration data
    spread = np.array(
        [
            np.sqrt(np.cov(tm[train_lamps][valid[train_lamps, m], m]))
            if valid[train_lamps, m].sum() > 1
            else 1.0
            for m in range(3)
        ]
    )
    if not floor_grid or min(floor_grid) <= 0:
        raise ValueError(f"floor_grid {tuple(floor_grid)}: needs values > 0.")
    grid_n = [(float(s), float(f)) for f in floor_grid for s in sigma_grid]
    scores = {s: [] for s in grid_n}
    scores_m = {s: [] for s in grid_n}  # per metric (3,)
    evid = {s: [] for s in grid_n}
    calib = {s: [] for s in grid_n}
    known_probs = {s: [] for s in grid_n}  # (rows, va, level-1, level-2 probs)
    scored_n = grid_n + ([] if FLAG_NOISE in grid_n else [FLAG_NOISE])
    flag_col = scored_n.index(FLAG_NOISE)
    flag_known = []  # (rows, va, misfit at FLAG_NOISE) per inner fold
    flag_folds = []  # the same with each fold's inversion, for new pixels
    for tr, va in inner:
        rows = rows_of(va)
        inv = make(lamps.take(tr), grid_n[0], modelled(tr)[0])
        posts, misfits, lev = inv.posterior(
            radiance[rows],
            surf(rows),
            sigmas=[x[0] for x in scored_n],
            evidence=True,
            moon=moon_of(rows),
            floors=[x[1] for x in scored_n],
        )
        flag_known.append((rows, va, misfits[:, flag_col]))
        flag_folds.append(
            FlagFold(
                inv,
                misfits[:, flag_col],
                _row_weights(rows, va, row_lamp, l2),
                tuple(l2[row_lamp[rows]]),
            )
        )
        w = class_balanced_weights(l2[va])
        rl = row_lamp[rows]
        for j, s in enumerate(grid_n):
            post, misfit = posts[:, j], misfits[:, j]
            mean, rng, _ = _posterior_metrics(post, inv.prior)
            err = _lamp_errors(mean, tm, valid, rl, va)
            per_m = np.zeros(3)
            for m in range(3):
                ok = ~np.isnan(err[:, m])
                per_m[m] = (
                    np.sum(w[ok] * err[ok, m]) / max(w[ok].sum(), 1e-300) / spread[m]
                )
            scores[s].append(float(per_m.sum()))
            scores_m[s].append(per_m)
            # class-balanced mean over lamps of each lamp's mean log evidence
            per_lamp = np.array([lev[rl == lamp, j].mean() for lamp in va])
            evid[s].append(float(np.sum(w * per_lamp) / max(w.sum(), 1e-300)))
            calib[s].append((rows, mean, rng, misfit, va))
            if calibrate_probabilities:
                probs = _global_probabilities(post, inv.prior)
                flagm = misfits[:, flag_col]
                known_probs[s].append((rows, va, *probs, misfit, flagm))
    if sigma_rule == "evidence":
        best = max(grid_n, key=lambda s: float(np.mean(evid[s])))
    else:
        best = min(grid_n, key=lambda s: float(np.mean(scores[s])))
    per_metric = (best,) * 3
    if sigma_rule == "per-metric":
        per_metric = tuple(
            min(grid_n, key=lambda s: float(np.mean(scores_m[s], axis=0)[m]))
            for m in range(3)
        )
    # conformal factors and reject threshold from the held-out inner lamps
    held_out = _per_metric_held_out([calib[x] for x in per_metric])
    held_known = held_out
    novel_probs = []  # the rows of each training class held out in turn
    if calibration in ("classes", "flagged"):  # each class held out in turn
        held_out = []
        sig = sorted({best, FLAG_NOISE, *per_metric})
        train_arr = np.asarray(train_lamps, int)
        for c in sorted(set(l2[train_arr])):
            va = train_arr[l2[train_arr] == c]
            tr = train_arr[l2[train_arr] != c]
            if tr.size == 0:
                continue
            rows = rows_of(va)
            inv = make(lamps.take(tr), best, modelled(tr)[0])
            posts, misfits = inv.posterior(
                radiance[rows],
                surf(rows),
                [x[0] for x in sig],
                moon=moon_of(rows),
                floors=[x[1] for x in sig],
            )
            mean, rng, _ = _metrics_per_posterior(
                [posts[:, sig.index(x)] for x in per_metric], inv.prior
            )
            held_out.append((rows, mean, rng, misfits[:, sig.index(best)], va))
            if calibrate_probabilities:
                novel_probs.append(
                    (
                        rows,
                        va,
                        *_global_probabilities(posts[:, sig.index(best)], inv.prior),
                        misfits[:, sig.index(best)],
                        misfits[:, sig.index(FLAG_NOISE)],
                    )
                )
    offs = np.array(fracs)[:, None] * spread[None]
    pick, confs, widths = _narrowest_intervals(held_out, row_lamp, l2, tm, valid, offs)
    conf, offset = confs[pick, np.arange(3)], offs[pick, np.arange(3)]
    conf_u, offset_u, cand_u = None, (), {}
    if calibration == "flagged":  # known types for explained pixels
        conf_u, offset_u = conf, tuple(offset.tolist())
        cand_u = _candidates(fracs, offs, confs, widths)
        pick, confs, widths = _narrowest_intervals(
            held_known, row_lamp, l2, tm, valid, offs
        )
        conf, offset = confs[pick, np.arange(3)], offs[pick, np.arange(3)]
    mis_all, w_all = [], []
    for rows, va, misfit in flag_known:
        mis_all.append(misfit)
        w_all.append(_row_weights(rows, va, row_lamp, l2))
    mis_all, w_all = np.concatenate(mis_all), np.concatenate(w_all)
    dof = weights.shape[0] - (1 if conditions.moon is None else 2)
    thr = (
        float(weighted_quantile(mis_all, w_all[None], (UNEXPLAINED_QUANTILE,))[0, 0])
        if dof >= 1
        else np.inf
    )
    extra, extra_info = modelled(train_lamps)
    final = make(lamps.take(train_lamps), best, extra)
    temps, prob_diag = ((1.0, 0.0), (1.0, 0.0)), {"calibrated": False}
    if calibrate_probabilities:
        temps, prob_diag = _probability_temperatures(
            known_probs[best], novel_probs, thr, row_lamp, lamps, l2
        )

    def key(x) -> str:  # a σ alone when the floor is not chosen
        return str(x[0]) if len(floor_grid) == 1 else f"{x[0]:g}/{x[1]:g}"

    per = sigma_rule == "per-metric"
    return dataclasses.replace(
        final,
        conformal=conf,
        threshold=thr,
        metric_sigma=tuple(x[0] for x in per_metric) if per else (),
        metric_floor=tuple(x[1] for x in per_metric) if per else (),
        interval_offset=tuple(offset.tolist()),
        conformal_unexplained=conf_u,
        interval_offset_unexplained=offset_u,
        level1_temperature=float(temps[0][0]),
        level2_temperature=float(temps[1][0]),
        temperature_slope=(float(temps[0][1]), float(temps[1][1])),
        flag_noise=FLAG_NOISE,
        flag_folds=tuple(flag_folds) if dof >= 1 else (),
        flag_level=1.0 - UNEXPLAINED_QUANTILE,
        diagnostics={
            "probabilities": prob_diag,
            "nir_error": {
                "variants": bool(nir_error),
                "n": sum(variant_base(i) != i for i in final.prior.ids),
            },
            "sigma_rel": best[0],
            "sigma_floor": best[1],
            "floor_grid": [float(f) for f in floor_grid],
            "sigma_rule": sigma_rule,
            "metric_sigma": dict(zip(METRICS, [x[0] for x in per_metric], strict=True)),
            "metric_floor": dict(zip(METRICS, [x[1] for x in per_metric], strict=True)),
            "calibration": calibration,
            "moon": "fitted" if row_moon is None else "known per pixel",
            "inner_scores": {key(s): float(np.mean(v)) for s, v in scores.items()},
            "inner_scores_per_metric": {
                key(s): dict(zip(METRICS, np.mean(v, axis=0).tolist(), strict=True))
                for s, v in scores_m.items()
            },
            "inner_log_evidence": {key(s): float(np.mean(v)) for s, v in evid.items()},
            "conformal_factor": dict(zip(METRICS, conf.tolist(), strict=True)),
            "conformal_factor_unexplained": (
                {}
                if conf_u is None
                else dict(zip(METRICS, conf_u.tolist(), strict=True))
            ),
            "interval_offset": {m: fracs[pick[j]] for j, m in enumerate(METRICS)},
            "interval_candidates": _candidates(fracs, offs, confs, widths),
            "interval_candidates_unexplained": cand_u,
            "unexplained_threshold_reduced_chi2": thr,
            "unexplained_band_error": dict(
                zip(("sigma_rel", "floor"), FLAG_NOISE, strict=True)
            ),
            "n_prior_lamps": len(final.prior.ids),
            "mixtures": {
                "max_pairs_per_class": int(mixtures),
                "fractions": list(MIX_FRACTIONS) if mixtures else [],
                "n": sum(i.startswith("mix:") for i in final.prior.ids),
            },
            "cross_mixtures": {
                "pairs_per_class_pair": int(cross_mixtures),
                "shares": list(CROSS_MIX_SHARES) if cross_mixtures else [],
                "n": sum(i.startswith("xmix:") for i in final.prior.ids),
            },
            "peak_shifts": {
                "shifts_nm": [float(x) for x in peak_shifts],
                "n": sum(i.startswith("shift:") for i in final.prior.ids),
            },
            "surface_mode": surface_mode,
            "modelled_lamps": {
                **extra_info,
                "ids": [] if extra is None else list(extra.ids),
                "calibrated_on": "the measured training lamps of this fit only "
                "(train_lamps and always; each inner fold's prior: its own "
                "training lamps and always); never scored",
            },
        },
    )
