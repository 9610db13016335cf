"""Unseen lamp types: `leave_one_class_out` fits on all other level-2 classes
and scores each class's lamps."""

import itertools
from collections.abc import Sequence

import numpy as np

from ..estimate import CCT_RANGE_K, METRICS
from ..folds import stratified_lamp_folds
from ._context import _basis, band_weights_on, context_moon, context_setup
from ._crossval import (
    _check_never_scored,
    _modelled_fields,
    _out_of_range,
)
from ._fit import fit_inversion
from ._lamps import MODELLED_CLASSES, planck_lamps, with_planck_lamps, with_tm30_lamps
from ._records import interval_fields
from ._scoring import SIGMA_FLOOR
from ._surfaces import _surface_knowledge


def _fractions(labels) -> dict[str, float]:
    """Fraction of each label among `labels` (None: "unexplained"), by
    decreasing fraction."""
    keys = ["unexplained" if x is None else str(x) for x in labels]
    n = max(len(keys), 1)
    counts: dict[str, int] = {}
    for k in keys:
        counts[k] = counts.get(k, 0) + 1
    return {k: c / n for k, c in sorted(counts.items(), key=lambda kv: -kv[1])}


def leave_one_class_out(
    ctx,
    bands,
    *,
    surface_mode: str = "unknown",
    seed: int = 0,
    modelled_per_class: int = 0,
    modelled_classes: Sequence[str] = MODELLED_CLASSES,
    moon_known: bool = False,
    calibration: str = "lamps",
    mixtures: int = 0,
    sigma_rule: str = "error",
    floor_grid: Sequence[float] = (SIGMA_FLOOR,),
    interval_offsets: Sequence[float] = (0.0,),
    peak_shifts: Sequence[float] = (),
    planck: bool = False,
    tm30: bool = False,
):
    """Unseen lamp types: for every scored level-2 class, fit on all other
    classes (inner folds: 2 class-stratified lamp folds of those) and score its
    lamps. One record per test lamp as `cross_validate` (fold = the class),
    with the fraction of its pixels given each level-1 family
    (`level1_predicted`; "unexplained" for flagged pixels).

    `modelled_per_class` > 0: modelled lamps in every prior, calibrated on that
    fit's training lamps only (`fit_inversion`), so the held-out class never
    gets any (its lamps are not training lamps); the records then say
    `modelled_per_class` and the classes that got them. Default 0: none.

    `moon_known`: the inversion is told each row's Moon brightness
    (`context_moon`) instead of fitting it (`MOON_ESTIMATOR`). `calibration`:
    the intervals' held-out lamps (`fit_inversion`; "classes": each of the
    fit's training classes held out in turn, never the scored class).
    `mixtures`: pairwise same-class mixtures of the prior's lamps
    (`fit_inversion(mixtures=)`; never of the held-out class: its lamps are
    not in any prior). `sigma_rule`, `floor_grid`, `interval_offsets`: as
    `fit_inversion`'s; with more than one offset (0 among them) every lamp
    gets two records from the one fit, `"intervals": "narrowest"` and
    `"offset 0"` (`Inversion.with_interval_offset(0)`), the same but for the
    intervals. `peak_shifts`: wavelength-shifted copies of the prior's
    direct-emission LEDs (`fit_inversion(peak_shifts=)`; never of the
    held-out class's lamps, which are in no prior). `planck`: the library's
    modelled incandescent spectra in every prior (`planck_lamps`; the
    records then say `modelled_in_prior`). `tm30`: the measured IES TM-30-15
    lamps in every prior (`tm30_lamps`) except those of the held-out class
    (measured lamps of an unseen type must not train; the records then say
    `tm30_in_prior`, the number in that class's prior)."""
    two = len(interval_offsets) > 1
    if two and 0.0 not in [float(x) for x in interval_offsets]:
        raise ValueError(
            f"interval_offsets {tuple(interval_offsets)}: several need 0 among them."
        )
    lamps, always, cond, row_types = context_setup(ctx)
    grid = ctx.wavelength_nm
    modelled_in_prior = planck_lamps(grid) if planck else None
    if planck:
        always = with_planck_lamps(always, grid)
    rad = ctx.radiance(bands)
    w = band_weights_on(bands, grid)
    row_lamp = np.asarray(ctx.table.lamp_of)
    classes = np.asarray(lamps.level2, dtype=object)
    basis = _basis(grid)
    si = _surface_knowledge(row_types, basis, seed)[surface_mode]
    moon_rows = context_moon(ctx) if moon_known else None
    out = []
    for c in sorted(set(classes)):
        test = np.flatnonzero(classes == c)
        train = np.flatnonzero(classes != c)
        folds = stratified_lamp_folds(classes[train], 2, seed)
        inner = [(np.setdiff1d(train, train[v]), np.sort(train[v])) for v in folds]
        prior_always = with_tm30_lamps(always, grid, drop_class=c) if tm30 else always
        inv = fit_inversion(
            rad,
            row_lamp,
            lamps,
            train,
            inner,
            w,
            cond,
            basis=basis,
            surface_mode=surface_mode,
            row_surface=si,
            always=prior_always,
            modelled_per_class=modelled_per_class,
            modelled_classes=modelled_classes,
            modelled_seed=seed,
            row_moon=moon_rows,
            calibration=calibration,
            mixtures=mixtures,
            sigma_rule=sigma_rule,
            floor_grid=floor_grid,
            interval_offsets=interval_offsets,
            peak_shifts=peak_shifts,
        )
        _check_never_scored(inv, [lamps.ids[i] for i in test])
        if c in inv.diagnostics["modelled_lamps"]["added"]:
            raise RuntimeError(f"held-out class {c} got modelled lamps (a leak).")
        if any(
            "ies_tm30_" in i and l2 == c
            for i, l2 in zip(inv.prior.ids, inv.prior.level2, strict=True)
        ):
            raise RuntimeError(f"held-out class {c} has IES TM-30 lamps (a leak).")
        rows = np.flatnonzero(np.isin(row_lamp, test))
        sub = (
            None
            if si is None
            else (si[rows] if isinstance(si, np.ndarray) else [si[i] for i in rows])
        )
        moon_sub = None if moon_rows is None else moon_rows[rows]
        res = inv.predict(rad[rows], sub, moon_sub)
        variants = [("narrowest", res.interval90)] if two else [(None, res.interval90)]
        if two:
            base = inv.with_interval_offset(0.0).predict(rad[rows], sub, moon_sub)
            variants.append(("offset 0", base.interval90))
        for lamp, (tag, iv90) in itertools.product(test, variants):
            sel = row_lamp[rows] == lamp
            t, v = ctx.table.truth[lamp], ctx.table.valid[lamp]
            rec = {
                "held_out_class": c,
                "lamp": lamps.ids[lamp],
                "level1": lamps.level1[lamp],
                "level2": c,
                "rows": int(sel.sum()),
                "out_of_range": _out_of_range(res.estimate[sel]),
                "level1_in_prior": lamps.level1[lamp] in set(inv.prior.level1),
                "level1_correct": float(
                    np.mean(
                        np.array(res.level1, dtype=object)[sel] == lamps.level1[lamp]
                    )
                ),
                "unexplained": float(np.mean(res.unexplained[sel])),
                "level1_predicted": _fractions(np.array(res.level1, dtype=object)[sel]),
            }
            for m, name in enumerate(METRICS):
                if not v[m]:
                    continue
                e = res.estimate[sel, m]
                ee = np.where(np.isfinite(e), e, CCT_RANGE_K[1]) if name == "CCT" else e
                rec[name] = float(np.mean(np.abs(ee - t[m])))
            rec.update(interval_fields(iv90[sel], t, v))
            if tag is not None:
                rec["intervals"] = tag
            if modelled_in_prior is not None:
                rec["modelled_in_prior"] = list(modelled_in_prior.ids)
            if tm30:
                rec["tm30_in_prior"] = sum(
                    i.startswith("ies_tm30_") for i in prior_always.ids
                )
            if modelled_per_class > 0:
                rec.update(_modelled_fields(inv))
            out.append(rec)
    return out
