"""Lamp-type classification with the physics-based inversion
(`bandopt.inversion`), scored like the KNN (`evaluate_band_set`).

For every outer fold of the table's nested lamp splits (`outer_splits`: the
KNN's folds and, for the same seed and lamps, a `search.Context`'s), the
inversion is fitted on the outer training lamps (`bandopt.inversion.
fit_inversion`: its band-error scale, conformal factors and unexplained
threshold chosen on the inner folds; the prior holds the training lamps plus
the measured lamps of classes too small to score) with the surface unknown,
as for the KNN, by default. It inverts the outer test lamps' pixels; the type
is read from the posterior hierarchically: level 1 is the family of highest
posterior probability, level 2 the most probable class inside that family, so
a level-2 hit is always a level-1 hit.

**Reject option.** As for the KNN, per level, with the same threshold
(`REJECT_THRESHOLD`): a pixel is "unknown" when the inversion flags it
unexplained (its best reduced χ² above the inner folds' 99th percentile) or
when the posterior probability of its predicted class is below the threshold.
For level 2 that probability is the top level-2 probability inside the chosen
family; at any threshold >= 0.5 this is the same as requiring the top level-2
probability overall (a class holding more than half the posterior makes its
family the most probable one).

**Surface knowledge** (`surface_mode`, `bandopt.inversion.SURFACE_MODES`):
"unknown" (default, `SURFACE_MODE`: every prior surface type a candidate),
"class" (each pixel's surface type is known: the table's per-row surface
label, its mean and measured samples the candidates), or "measured" (a
simulated daytime Sentinel-2 measurement of each pixel's true type-mean
surface, `bandopt.inversion.measured_surfaces`, drawn with the noise seed).
The same knowledge is given to the inner folds that choose the band-error
scale and threshold, and to the test pixels.

**Modelled lamps** (`modelled_per_class` > 0): that many
modelled lamps per class of `modelled_classes` join every prior the fit
builds, calibrated on that prior's measured training lamps only
(`bandopt.inversion.fit_inversion`, seed = the noise seed); they are never
scored (test pixels are measured lamps only, checked per fold).

The scores without the reject option classify every pixel, unexplained or
not. Prior-only classes (e.g. low-pressure sodium, RGB LEDs) can be
predicted but are not scored: each has a confusion column and predicting one
counts as a miss.
"""

import functools
from collections.abc import Sequence

import numpy as np

from .. import inversion as inv_mod
from ..datasets import surfaces as surf_mod
from ..datasets.lamps import LEVEL1, LEVEL2, LEVEL2_PARENT
from ..forward import ScenarioTable, resolve_level
from ..knn import features
from ..names import validate_method
from ._metrics import REJECT_THRESHOLD, confidence_curve, scores, withhold
from ._scores import (
    REJECT_GRID,
    BandSetScores,
    LevelScores,
    class_order,
    outer_splits,
    usable_rows,
)


SURFACE_MODE = "unknown"
"""What the classifying inversion knows of the surface by default: nothing
(like the KNN)."""


def surface_types(table: ScenarioTable) -> list[str]:
    """Surface type of every row (`bandopt.datasets.surfaces` ids), for
    surface knowledge "class"/"measured": a label `type#k` (a measured
    sample, `surface_samples`) is its type. Raises `ValueError` for a mixed
    surface (`a+b@f`, no single type)."""
    out, cache = [], {}
    for label in table.surface:
        if label not in cache:
            if "+" in label and "@" in label:
                raise ValueError(
                    f"table: surface {label!r} is a mix of two types; surface "
                    "knowledge 'class'/'measured' needs one type per pixel."
                )
            cache[label] = surf_mod.resolve_surface(label.split("#")[0])
        out.append(cache[label])
    return out


def inversion_conditions(table: ScenarioTable) -> inv_mod.Conditions:
    """The inversion's scene conditions (atmospheres, neighbourhood, brightest
    Moon state) of the scenario set behind `table`."""
    return inv_mod.Conditions.from_scenarios(_conditions_scenarios(table))


def table_moon(table: ScenarioTable) -> np.ndarray:
    """The Moon's brightness in every row of `table`, relative to the
    inversion's Moon state (`inversion_conditions`: the brightest), from the
    row's Moon label (`bandopt.inversion.moon_amplitudes`): 0 moonless, 1
    that state. What an analyst knows from the acquisition's time and place.
    (n,) [1]. Raises `ValueError` naming a row label that is not one of the
    scenario set's Moon states."""
    scen = _conditions_scenarios(table)
    amp = inv_mod.moon_amplitudes(scen)
    index = {lab: i for i, lab in enumerate(scen.moon_labels)}
    labels = np.asarray(table.moon, dtype=object)
    bad = sorted({str(x) for x in labels} - set(index))
    if bad:
        raise ValueError(
            f"table: Moon labels {bad[:5]} are not Moon states of its scenario "
            f"set ({list(index)})."
        )
    return amp[np.array([index[x] for x in labels], dtype=int)]


def _conditions_scenarios(table: ScenarioTable):
    """The scenario set behind `table` (its atmospheres and Moon states)."""
    return table.scenario_set()


@functools.lru_cache(maxsize=2)
def _cached_basis(first_nm: float, last_nm: float, n: int) -> inv_mod.SurfaceBasis:
    return inv_mod.surface_basis(np.linspace(first_nm, last_nm, n))


def _surface_basis(grid) -> inv_mod.SurfaceBasis:
    """`bandopt.inversion.surface_basis` of a uniform grid, cached (its SVD
    takes seconds)."""
    grid = np.asarray(grid, float)
    if not np.allclose(np.diff(grid), grid[1] - grid[0]):
        return inv_mod.surface_basis(grid)
    return _cached_basis(float(grid[0]), float(grid[-1]), grid.size)


def table_lamps(table: ScenarioTable) -> tuple[inv_mod.LampSet, inv_mod.LampSet]:
    """The table's lamps as a `LampSet` in its lamp order, and the measured
    lamps that are in every prior and never scored. Raises `ValueError` when
    a table lamp is not a scored library lamp."""
    grid = table.wavelength_nm
    scored = inv_mod.library_lamps(grid, scored=True)
    index = {lid: i for i, lid in enumerate(scored.ids)}
    missing = [lid for lid in table.lamp_ids if lid not in index]
    if missing:
        raise ValueError(
            f"table: lamps {missing[:5]} are not scored library lamps; the "
            "inversion classifies with measured, typed library spectra only."
        )
    lamps = scored.take([index[lid] for lid in table.lamp_ids])
    return lamps, inv_mod.library_lamps(grid, scored=False)


def hierarchical_types(result: inv_mod.InversionResult):
    """Level-1 and level-2 types of every pixel from the posterior, ignoring
    the unexplained flag, with the probability of each predicted class:
    `(level1, p1, level2, p2)`, arrays of length n. Level 2 is the most
    probable class inside the most probable level-1 family."""
    l1 = list(result.level1_labels)
    l2 = list(result.level2_labels)
    p1 = np.asarray(result.level1_probabilities)
    p2 = np.asarray(result.level2_probabilities)
    i1 = np.argmax(p1, axis=1)
    parent = np.array([l1.index(LEVEL2_PARENT.get(c, c)) for c in l2])
    inside = parent[None, :] == i1[:, None]
    i2 = np.argmax(np.where(inside, p2, -1.0), axis=1)
    rows = np.arange(p1.shape[0])
    return (
        np.asarray(l1, object)[i1],
        p1[rows, i1],
        np.asarray(l2, object)[i2],
        p2[rows, i2],
    )


def evaluate_inversion(
    table: ScenarioTable,
    bands,
    *,
    levels: Sequence[str] | np.ndarray = ("level1", "level2"),
    noise: bool = True,
    seed: int = 0,
    fold_seed: int = 0,
    thresholds: Sequence[float] | np.ndarray = REJECT_GRID,
    params=None,
    radiance: np.ndarray | None = None,
    keep_rows: bool = False,
    modelled_per_class: int = 0,
    modelled_classes: Sequence[str] = inv_mod.MODELLED_CLASSES,
    surface_mode: str = SURFACE_MODE,
    moon_known: bool = False,
    mixtures: int = 0,
    planck: bool = False,
    peak_shifts: Sequence[float] = (),
) -> BandSetScores:
    """Outer-fold classification scores of the inversion for one band set, a
    `BandSetScores` as from `evaluate_band_set` (see the module docstring).
    Per level: F1 per class, macro F1, accuracy, per-lamp accuracy, confusion
    matrix, `reject` (threshold, coverage, accuracy and macro F1 with rejects
    as misses, F1, the `unexplained` fraction, and the curve over `thresholds`
    with accuracy on the accepted pixels) and `folds` (the inversion's
    `sigma_rel` and unexplained threshold per fold). Rows as for the KNN: all
    with `noise`, one per group of identical feature rows without. With
    `keep_rows`, each level also holds `rows` (row index, true, predicted)
    and `reject_rows` (probability of the predicted class, unexplained
    flag). `surface_mode` and `modelled_per_class`: see the module
    docstring; `config` records both (`surface`; with modelled lamps
    `modelled_per_class` and per fold the classes that got them, with the
    default 0 no such keys, the config without them). `moon_known`: the
    inversion is told each row's Moon brightness (`table_moon`, as
    `bandopt.inversion.MOON_ESTIMATOR`) in its inner folds and on the test
    pixels instead of fitting it; `config` then says `"moon": "known per
    pixel"` (default False: fitted, no such key, the config without them).
    `mixtures`: pairwise same-class blends of each prior's own lamps in the
    prior, up to that many pairs per class (`bandopt.inversion.mixture_lamps`;
    default 0: none, no such key); `config["mixtures"]` says how many.
    `planck`: the library's modelled incandescent spectra in every prior
    (`bandopt.inversion.with_planck_lamps`; modelled, they train and never
    score) and `peak_shifts` [nm]: copies of each prior's direct-emission
    LEDs shifted by these (`fit_inversion(peak_shifts=)`), as `bandopt
    evaluate` has by default; `config` then says `"modelled_in_prior"` (the
    Planck ids) and `"peak_shifts_nm"` (defaults False and (): neither, no
    such keys, the config without them)."""
    surface_mode = validate_method(surface_mode, inv_mod.SURFACE_MODES, "surface_mode")
    if modelled_per_class < 0:
        raise ValueError(f"modelled_per_class must be >= 0 (got {modelled_per_class}).")
    levels = [resolve_level(lv) for lv in levels]
    splits = outer_splits(table, fold_seed)
    rad = np.asarray(
        radiance
        if radiance is not None
        else table.band_radiance(bands, noise=noise, params=params, seed=seed),
        float,
    )
    keep = usable_rows(np.asarray(features(rad)), table, noise)
    kept = np.flatnonzero(keep)
    lamps, always = table_lamps(table)
    cond = inversion_conditions(table)
    grid = table.wavelength_nm
    if planck:
        always = inv_mod.with_planck_lamps(always, grid)
    weights = inv_mod.band_weights_on(bands, grid)
    basis = _surface_basis(grid)
    lamp_ids = np.asarray(table.lamp_ids, object)
    row_surface = _surface_knowledge(table, surface_mode, basis, seed)
    row_moon = table_moon(table) if moon_known else None

    def surf(rows):
        if row_surface is None:
            return None
        if isinstance(row_surface, np.ndarray):
            return row_surface[rows]
        return [row_surface[i] for i in np.flatnonzero(rows)]

    per_fold = []  # (split, inversion, test rows, types, unexplained)
    for s in splits:
        inv = inv_mod.fit_inversion(
            rad[kept],
            table.lamp[kept],
            lamps,
            s.train,
            s.inner,
            weights,
            cond,
            basis=basis,
            surface_mode=surface_mode,
            row_surface=None if row_surface is None else surf(keep),
            always=always,
            modelled_per_class=modelled_per_class,
            modelled_classes=modelled_classes,
            modelled_seed=seed,
            row_moon=None if row_moon is None else row_moon[kept],
            mixtures=mixtures,
            peak_shifts=tuple(peak_shifts),
        )
        te = keep & table.rows_of_lamps(s.test)
        _never_scored(inv, lamp_ids[s.test])
        moon_te = None if row_moon is None else row_moon[te]
        res = inv.predict(rad[te], surf(te), moon_te)
        # every pixel typed; the unexplained flag is applied by the reject option
        types = hierarchical_types(res)
        labels = (res.level1_labels, res.level2_labels)
        per_fold.append((s, inv, te, types, res.unexplained, labels))

    out = {}
    for level in levels:
        classes = class_order(level, table.lamp_classes(level))
        col = 0 if level == "level1" else 2
        yt, pred, conf, unexp, lamp_of, folds, row_idx = [], [], [], [], [], [], []
        # classes the inversion can predict but that are not scored
        others = set().union(*(lab[col // 2] for *_, lab in per_fold)) - set(classes)
        ref = LEVEL1 if level == "level1" else LEVEL2
        others = [c for c in ref if c in others] + sorted(others - set(ref))
        for s, inv, te, types, unexplained, _ in per_fold:
            y = table.labels(level)[te]
            p = types[col]
            fs = scores(y, p, classes, others=others)
            yt.append(y)
            pred.append(p)
            conf.append(types[col + 1])
            unexp.append(unexplained)
            lamp_of.append(lamp_ids[table.lamp[te]])
            row_idx.append(np.flatnonzero(te))
            folds.append(
                {
                    "outer": s.outer,
                    "sigma_rel": inv.sigma_rel,
                    "unexplained_threshold_reduced_chi2": inv.threshold,
                    "n_prior_lamps": len(inv.prior.ids),
                    **_modelled_fold(inv, modelled_per_class),
                    "macro_f1": fs["macro_f1"],
                    "accuracy": fs["accuracy"],
                    "n_train_rows": int((keep & table.rows_of_lamps(s.train)).sum()),
                    "n_test_rows": int(te.sum()),
                }
            )
        yt, pred, conf, unexp = map(np.concatenate, (yt, pred, conf, unexp))
        res = scores(yt, pred, classes, lamp=np.concatenate(lamp_of), others=others)
        rej = scores(
            yt,
            withhold(pred, conf, REJECT_THRESHOLD, unexplained=unexp),
            classes,
            others=others,
        )
        res["reject"] = {
            "threshold": REJECT_THRESHOLD,
            **{k: rej[k] for k in ("macro_f1", "accuracy", "coverage", "f1")},
            "unexplained": float(np.mean(unexp)),
            "curve": confidence_curve(
                yt,
                pred,
                conf,
                classes,
                thresholds,
                unexplained=unexp,
                others=others,
            ),
        }
        res["folds"] = folds
        res["macro_f1_fold_mean"] = float(np.mean([f["macro_f1"] for f in folds]))
        res["macro_f1_fold_sd"] = float(np.std([f["macro_f1"] for f in folds]))
        res["n_test_rows"] = len(yt)
        if keep_rows:
            res["rows"] = (np.concatenate(row_idx), yt, pred)
            res["reject_rows"] = (conf, unexp)
        out[level] = LevelScores(**res)
    config = {
        "estimator": "inversion",
        "surface": surface_mode,
        "noise": noise,
        "seed": seed,
        "fold_seed": fold_seed,
        "dedup": not noise,
        "n_outer": len(splits),
        "n_inner": len(splits[0].inner),
    }
    if (
        moon_known
    ):  # the default adds no key, so its config (and cache key) is unchanged
        config["moon"] = "known per pixel"
    if mixtures:  # likewise
        config["mixtures"] = int(mixtures)
    if planck:  # likewise
        config["modelled_in_prior"] = [i for i in always.ids if i.startswith("planck_")]
    if len(peak_shifts):  # likewise
        config["peak_shifts_nm"] = [float(d) for d in peak_shifts]
    if (
        modelled_per_class
    ):  # the default adds no key, so its config (and cache key) is unchanged
        config["modelled_per_class"] = int(modelled_per_class)
        config["modelled_lamps"] = {
            "n_per_class": int(modelled_per_class),
            "classes": list(modelled_classes),
            "seed": int(seed),
            "per_fold": [
                {"outer": s.outer, **_modelled_fold(inv, modelled_per_class)}
                for s, inv, *_ in per_fold
            ],
            "calibrated_on": "the measured training lamps of each prior only "
            "(outer and inner folds; bandopt.inversion.fit_inversion)",
            "scored": "never: test pixels are measured lamps only",
        }
    return BandSetScores(
        level1=out.get("level1"),
        level2=out.get("level2"),
        config=config,
        order=tuple(levels),
    )


def _surface_knowledge(table: ScenarioTable, mode: str, basis, seed: int):
    """Per-row surface input of `mode` for every table row: None ("unknown"),
    the surface type names ("class"), or Sentinel-2-derived basis
    coefficients `(n, r)` ("measured", drawn with `seed` over all rows, so a
    row's draw does not depend on which rows are kept)."""
    if mode == "unknown":
        return None
    types = surface_types(table)
    if mode == "class":
        return types
    return inv_mod.measured_surfaces(types, basis, seed=seed)


def _modelled_fold(inv: inv_mod.Inversion, n_per_class: int) -> dict:
    """A fold record's modelled-lamp fields (none when none were asked)."""
    if not n_per_class:
        return {}
    info = inv.diagnostics.get("modelled_lamps", {})
    return {
        "modelled_added": dict(info.get("added", {})),
        "modelled_calibration_lamps": dict(info.get("calibration_lamps", {})),
        "modelled_skipped": dict(info.get("skipped", {})),
    }


def _never_scored(inv: inv_mod.Inversion, test_ids) -> None:
    """Modelled lamps train, never score: no prior lamp calibrated on a test
    lamp, no modelled id among the test lamps (a bug if either happens)."""
    info = inv.diagnostics.get("modelled_lamps", {})
    test = set(test_ids)
    bad = set(info.get("ids", ())) & test
    bad |= {
        lamp for cal in info.get("calibration_lamps", {}).values() for lamp in cal
    } & test
    if bad:
        raise RuntimeError(f"modelled lamps touch the test lamps: {sorted(bad)}")
