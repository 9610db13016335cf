"""Nested cross-validation on a `search.Context` (lamp-grouped, the same outer
folds for every estimator): `cross_validate` and its per-lamp records."""

import dataclasses
from collections.abc import Sequence

import numpy as np

from ..estimate import METRICS, fit_estimator, fit_kernel_estimator
from ..names import validate_method
from ._context import (
    _basis,
    augment_with_modelled,
    band_weights_on,
    context_moon,
    context_setup,
)
from ._estimators import (
    DEFAULT_ESTIMATOR,
    ESTIMATORS,
    EVIDENCE_ESTIMATOR,
    LABELLED,
    MIX_ESTIMATOR,
    MIX_METRIC_ESTIMATOR,
    MODELLED_ESTIMATORS,
    MOON_ESTIMATOR,
    MOON_UNSEEN_ESTIMATOR,
    NARROW_ESTIMATOR,
    PLANCK_ESTIMATOR,
    SHIFT_ESTIMATOR,
)
from ._fit import fit_inversion
from ._lamps import (
    MODELLED_CLASSES,
    planck_lamps,
    tm30_lamps,
    with_planck_lamps,
    with_tm30_lamps,
)
from ._metrics import PHYSICAL_RANGE
from ._records import LampScore, interval_fields, record_errors
from ._result import InversionResult
from ._surfaces import _surface_knowledge


def _smaller_library(split, level2, fraction: float, seed: int, fold: int):
    """`split` (an outer fold) with `fraction` of its training lamps of each
    level-2 class in `level2` (at least one), drawn with seed `(seed, fold)`,
    and its inner folds restricted to them (an inner fold left without
    training or validation lamps is dropped). Its test lamps are unchanged."""
    rng = np.random.default_rng([seed, fold, 7919])
    train = np.asarray(split.train)
    cls = np.asarray(level2, object)[train]
    keep = []
    for c in sorted(set(cls)):
        ids = train[cls == c]
        n = max(1, round(fraction * ids.size))
        keep += rng.choice(ids, size=n, replace=False).tolist()
    kept = np.sort(np.asarray(keep, train.dtype))
    inner = tuple(
        (tr[np.isin(tr, kept)], va[np.isin(va, kept)])
        for tr, va in (tuple(np.asarray(x) for x in pair) for pair in split.inner)
    )
    inner = tuple((tr, va) for tr, va in inner if tr.size and va.size)
    if not inner:
        raise ValueError(
            f"train_fraction {fraction}: outer fold {fold} keeps no inner fold."
        )
    return dataclasses.replace(split, train=kept, inner=inner)


def cross_validate(
    ctx,
    bands,
    *,
    estimators: Sequence[str] = ESTIMATORS,
    surface_modes: Sequence[str] = ("unknown",),
    folds: Sequence[int] | None = None,
    seed: int = 0,
    modelled_per_class: int = 0,
    modelled_classes: Sequence[str] = MODELLED_CLASSES,
    scored: str = "test",
    train_fraction: float = 1.0,
) -> list[LampScore]:
    """Score estimators on the context's outer folds (lamp-grouped, the same
    folds for every estimator). One record per (estimator, surface mode, outer
    fold, test lamp) with the lamp's mean |error| per metric (CCT in K and in
    mired), interval coverage, level-1 correctness and unexplained rate
    (inversion only) and the number of rows whose estimate left the physical
    range (must be 0).

    Estimators `MODELLED_ESTIMATORS` (only with `modelled_per_class` > 0)
    train on `modelled_per_class` modelled lamps per class of
    `modelled_classes` too, calibrated on each outer fold's (and inner
    fold's) measured training lamps only, seed `seed`: "inversion+models"
    holds them in its prior (`fit_inversion`), "ridge+models" and
    "kernel+models" have their scenes among the training rows
    (`augment_with_modelled`; hyper-parameters chosen on inner folds whose
    validation lamps are measured). Test lamps are measured lamps only,
    whatever the estimator. With `modelled_per_class` > 0 every record says
    how many modelled lamps per class its estimator trained on
    (`modelled_per_class`: N for a `MODELLED_ESTIMATORS` row, 0 otherwise)
    and those rows list the classes that got them in that fold
    (`modelled_classes_added`); with the default 0 the records are as
    before (no such keys).

    `scored`: "test" (default: the outer fold's held-out lamps) or "train"
    (its training lamps, which are in the prior: how well the estimator does
    on a lamp the library holds, the in-library bound of a held-out score;
    records then say `"scored": "train"`, and the never-scored check, which
    would refuse them, is not made).

    `train_fraction` < 1: each outer fold trains on that fraction of its
    training lamps of each level-2 class (at least one; seeded by `seed` and
    the fold), its inner folds on their share of them: a smaller library, to
    see how the held-out error falls with the library's size (the
    always-in-prior lamps stay; records then say `train_fraction` and
    `train_lamps`). Default 1: all, no such keys."""
    scored = validate_method(scored, ("test", "train"), "scored")
    if not 0.0 < train_fraction <= 1.0:
        raise ValueError(f"train_fraction {train_fraction}: must be in (0, 1].")
    bad = [e for e in estimators if e in MODELLED_ESTIMATORS]
    if bad and modelled_per_class < 1:
        raise ValueError(
            f"estimators {bad} need modelled_per_class >= 1 (got {modelled_per_class})."
        )
    lamps, always, cond, row_types = context_setup(ctx)
    grid = ctx.wavelength_nm
    rad = ctx.radiance(bands)
    w = band_weights_on(bands, grid)
    row_lamp = np.asarray(ctx.table.lamp_of)
    truth, valid = ctx.table.truth, ctx.table.valid
    basis = _basis(grid)
    surf_in = _surface_knowledge(row_types, basis, seed)
    out = []
    folds = range(len(ctx.splits)) if folds is None else folds
    augmented: dict = {}  # per outer fold, shared by ridge+models and kernel+models
    # what records list of their priors: once, not per record
    planck_ids = planck_lamps(grid).ids
    tm30 = any(LABELLED[e].tm30 for e in estimators if e in LABELLED)
    n_tm30 = len(tm30_lamps(grid).ids) if tm30 else 0
    for k in folds:
        s = ctx.splits[k]
        if train_fraction < 1.0:
            s = _smaller_library(s, lamps.level2, train_fraction, seed, k)
        inner = list(s.inner)
        score_ids = s.test if scored == "test" else s.train
        rows = np.flatnonzero(np.isin(row_lamp, score_ids))
        preds, model_info = {}, {}
        for name in estimators:
            if name in LABELLED:
                opts = LABELLED[name]
                if name == "inversion+models":
                    opts = dataclasses.replace(
                        opts, modelled_per_class=modelled_per_class
                    )
                if name == MIX_METRIC_ESTIMATOR and NARROW_ESTIMATOR in estimators:
                    continue  # scored from the narrow fit at offset 0
                moon_rows = context_moon(ctx) if opts.moon_told else None
                prior_always = always
                if opts.planck:
                    prior_always = with_planck_lamps(prior_always, grid)
                if opts.tm30:
                    prior_always = with_tm30_lamps(prior_always, grid)
                for mode in surface_modes:
                    si = surf_in[mode]
                    inv = fit_inversion(
                        rad,
                        row_lamp,
                        lamps,
                        s.train,
                        inner,
                        w,
                        cond,
                        basis=basis,
                        surface_mode=mode,
                        row_surface=si,
                        always=prior_always,
                        modelled_classes=modelled_classes,
                        modelled_seed=seed,
                        row_moon=moon_rows,
                        **opts.fit_kwargs(),
                    )
                    sub = (
                        None
                        if si is None
                        else (
                            si[rows]
                            if isinstance(si, np.ndarray)
                            else [si[i] for i in rows]
                        )
                    )
                    moon_sub = None if moon_rows is None else moon_rows[rows]
                    preds[(name, mode)] = (inv.predict(rad[rows], sub, moon_sub), inv)
                    if name == NARROW_ESTIMATOR and MIX_METRIC_ESTIMATOR in estimators:
                        base = inv.with_interval_offset(0.0)
                        preds[(MIX_METRIC_ESTIMATOR, mode)] = (
                            base.predict(rad[rows], sub, moon_sub),
                            base,
                        )
            elif name == "ridge":
                est = fit_estimator(rad, ctx.table, s.train, inner)
                preds[("ridge", "unknown")] = (np.asarray(est.predict(rad[rows])), None)
            elif name == "kernel":
                est = fit_kernel_estimator(rad, ctx.table, s.train, inner, seed=seed)
                preds[("kernel", "unknown")] = (
                    np.asarray(est.predict(rad[rows])),
                    None,
                )
            elif name in ("ridge+models", "kernel+models"):
                if k not in augmented:
                    augmented[k] = augment_with_modelled(
                        ctx,
                        bands,
                        rad,
                        s.train,
                        inner,
                        modelled_per_class,
                        classes=modelled_classes,
                        seed=seed,
                    )
                aug = augmented[k]
                if np.isin(s.test, aug.train).any() or any(
                    np.isin(s.test, tr).any() for tr, _ in aug.inner
                ):
                    raise RuntimeError("a test lamp is among the training lamps.")
                est = (
                    fit_estimator(aug.radiance, aug.table, aug.train, aug.inner)
                    if name == "ridge+models"
                    else fit_kernel_estimator(
                        aug.radiance, aug.table, aug.train, aug.inner, seed=seed
                    )
                )
                preds[(name, "unknown")] = (np.asarray(est.predict(rad[rows])), None)
                model_info[name] = aug.info
            else:
                raise ValueError(
                    f"estimator {name!r}: expected one of "
                    f"{(*ESTIMATORS, *MODELLED_ESTIMATORS)} or "
                    f"{(EVIDENCE_ESTIMATOR, MOON_ESTIMATOR, MOON_UNSEEN_ESTIMATOR)}"
                    f" or {(MIX_ESTIMATOR, MIX_METRIC_ESTIMATOR, NARROW_ESTIMATOR)}"
                    f" or {(SHIFT_ESTIMATOR, PLANCK_ESTIMATOR, DEFAULT_ESTIMATOR)}."
                )
        for (name, mode), (p, inv) in preds.items():
            res = p if isinstance(p, InversionResult) else None
            est = res.estimate if res is not None else p
            if inv is not None and scored == "test":
                _check_never_scored(inv, [lamps.ids[i] for i in s.test])
            for lamp in score_ids:
                sel = row_lamp[rows] == lamp
                e = est[sel]
                t = truth[lamp]
                rec = {
                    "estimator": name,
                    "surface": mode,
                    "fold": int(k),
                    "lamp": lamps.ids[lamp],
                    "level1": lamps.level1[lamp],
                    "level2": lamps.level2[lamp],
                    "rows": int(sel.sum()),
                    "out_of_range": int(_out_of_range(e)),
                }
                if scored == "train":
                    rec["scored"] = "train"
                if train_fraction < 1.0:
                    rec["train_fraction"] = float(train_fraction)
                    rec["train_lamps"] = len(s.train)
                rec.update(record_errors(e, t, valid[lamp]))
                if res is not None:
                    rec.update(interval_fields(res.interval90[sel], t, valid[lamp]))
                    l1 = np.array(res.level1, dtype=object)[sel]
                    rec["level1_correct"] = float(np.mean(l1 == lamps.level1[lamp]))
                    l2p = np.array(res.level2, dtype=object)[sel]
                    rec["level2_correct"] = float(np.mean(l2p == lamps.level2[lamp]))
                    rec["unexplained"] = float(np.mean(res.unexplained[sel]))
                    rec["sigma_rel"] = inv.sigma_rel
                    if inv.metric_sigma:
                        rec["metric_noise"] = [list(x) for x in inv.metric_noise]
                    if name in LABELLED and LABELLED[name].planck:
                        rec["modelled_in_prior"] = list(planck_ids)
                    if name in LABELLED and LABELLED[name].tm30:
                        rec["tm30_in_prior"] = n_tm30
                if modelled_per_class > 0:
                    rec.update(model_info.get(name) or _modelled_fields(inv))
                out.append(LampScore(**rec))
    return out


def _modelled_fields(inv) -> dict:
    """What a record says about modelled lamps in its estimator's prior."""
    info = {} if inv is None else inv.diagnostics.get("modelled_lamps", {})
    n = int(info.get("n_per_class", 0))
    out = {"modelled_per_class": n}
    if n:
        out["modelled_classes_added"] = dict(info["added"])
    return out


def _check_never_scored(inv, test_ids) -> None:
    """Modelled lamps and mixtures train, never score: none is a test lamp,
    no mixture is made of one (a bug, not a user error)."""
    modelled = set(inv.diagnostics.get("modelled_lamps", {}).get("ids", ()))
    if modelled & set(test_ids):
        raise RuntimeError(
            f"modelled lamps among the scored lamps: {sorted(modelled & set(test_ids))}"
        )
    parts = {
        p
        for i in inv.prior.ids
        if i.startswith(("mix:", "xmix:"))
        for p in i.partition(":")[2].rsplit("@", 1)[0].split("+")
    }
    if parts & set(test_ids):
        raise RuntimeError(
            f"mixtures of scored lamps in the prior: {sorted(parts & set(test_ids))}"
        )
    shifted = {i[6:].rsplit("@", 1)[0] for i in inv.prior.ids if i.startswith("shift:")}
    if shifted & set(test_ids):
        raise RuntimeError(
            f"shifted copies of scored lamps in the prior: "
            f"{sorted(shifted & set(test_ids))}"
        )


def _out_of_range(est) -> int:
    """Rows with an estimate outside `PHYSICAL_RANGE` (NaN CCT is a null)."""
    bad = np.zeros(est.shape[0], bool)
    for m, name in enumerate(METRICS):
        lo, hi = PHYSICAL_RANGE[name]
        v = est[:, m]
        fin = np.isfinite(v)
        bad |= fin & ((v < lo - 1e-9) | (v > hi + 1e-9))
        if name != "CCT":
            bad |= ~fin
    return int(bad.sum())
