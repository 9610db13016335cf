"""Nested lamp-grouped evaluation of a band set for lamp-type classification.

For every outer fold of `bandopt.folds.nested_lamp_splits` (stratified by
level-2 class, the same folds as the band search for the same
seed): features of the band radiances, k chosen by inner-fold macro F1, the
one-vs-all KNN fitted on the outer training lamps and applied to the outer
test lamps. Scores are computed over the pooled outer test predictions (each
scored lamp is tested exactly once); per-fold macro F1 is reported beside.
Only scored classes (`LampLibrary.is_scored`) take part.

**Modelled training lamps** (`modelled_per_class` > 0): in every
outer fold, `modelled_per_class` lamps per class of `modelled_classes` from
the physical lamp models calibrated on that fold's measured training lamps
only (`_modelled.modelled_rows`), lighting the table's scenes, join the
training rows; test rows stay measured lamps only. The inner folds that
choose k get them too, each inner training set its own lamps calibrated on
its own measured training lamps only, so k is chosen for training sets like
the one it is used with and no inner validation lamp shapes a model. The
modelled rows' photon noise has its own draws (`_modelled.modelled_noise_key
(seed, stream)`, stream `outer * (n_inner + 1) + j`: j = inner fold, or
n_inner for the outer training set), never a measured row's.
"""

from collections.abc import Sequence

import numpy as np

from ..forward import ScenarioTable, resolve_level
from ..inversion import MODELLED_CLASSES, SURFACE_MODES
from ..knn import (
    K_GRID,
    choose_k,
    features,
    neighbour_labels,
    resolve_kind,
    vote_proba,
)
from ..names import validate_method
from ._inversion import evaluate_inversion
from ._metrics import REJECT_THRESHOLD, reject, reject_curve, scores
from ._modelled import modelled_rows
from ._scores import (
    LEVEL_KEYS,
    REJECT_GRID,
    BandSetScores,
    LevelScores,
    class_order,
    outer_splits,
    usable_rows,
)


ESTIMATORS = ("knn", "inversion")
"""Classifiers `evaluate_band_set` scores: the one-vs-all KNN on log band
ratios (default) and the physics-based inversion (`evaluate_inversion`)."""


def evaluate_band_set(
    table: ScenarioTable,
    bands,
    *,
    levels: Sequence[str] | np.ndarray = ("level1", "level2"),
    noise: bool = True,
    seed: int = 0,
    fold_seed: int = 0,
    kind: str = "log_ratio",
    k_grid: Sequence[int] | np.ndarray = K_GRID,
    thresholds: Sequence[float] | np.ndarray = REJECT_GRID,
    params=None,
    train_rows: np.ndarray | None = None,
    test_rows: np.ndarray | None = None,
    radiance: np.ndarray | None = None,
    keep_rows: bool = False,
    estimator: str = "knn",
    modelled_per_class: int = 0,
    modelled_classes: Sequence[str] = MODELLED_CLASSES,
    surface_mode: str = "unknown",
    moon_known: bool = False,
    mixtures: int = 0,
    planck: bool = False,
    peak_shifts: Sequence[float] = (),
) -> BandSetScores:
    """Outer-fold scores of one band set (or one band set per outer fold, a
    sequence, for bands searched inside each fold).

    `estimator`: `"knn"` (default) or `"inversion"` (`evaluate_inversion`,
    the same folds and scores; one band set, all rows, no KNN options).

    `modelled_per_class`: modelled training lamps per class of
    `modelled_classes` (default 0: measured lamps only, the results as
    before); for the KNN see the module docstring, for the inversion they go
    into its prior (`evaluate_inversion`). `surface_mode`: what the
    inversion knows of the surface, "unknown" (default), "class" or
    "measured" (`evaluate_inversion`); the KNN knows none ("unknown" only).
    `moon_known`: the inversion is told each pixel's Moon brightness instead
    of fitting it (`evaluate_inversion`; inversion only). `mixtures`:
    same-class blends of its lamps in the inversion's prior, up to that many
    pairs per class (`evaluate_inversion`; inversion only, default 0).
    `planck` (the library's modelled incandescent spectra) and
    `peak_shifts` [nm] (shifted copies of its direct-emission LEDs) in the
    inversion's prior: `bandopt evaluate`'s defaults (`evaluate_inversion`;
    inversion only, default neither).
    With `modelled_per_class` > 0, `config` says `modelled_per_class` and
    the classes that got lamps in each outer fold (`modelled_lamps`); with
    the default 0 it has no such keys (no modelled lamp was used).

    `train_rows`/`test_rows`: optional boolean row masks (conditions) applied
    on top of the lamp splits. `radiance`: precomputed `(n, b)` (then `bands`
    is only used for its length). Returns a `BandSetScores` (`.to_dict()` is
    JSON-ready); with `keep_rows`, each level also holds `rows`: (row index,
    true, predicted) arrays of the pooled test rows.
    """
    estimator = validate_method(estimator, ESTIMATORS, "estimator")
    if estimator == "inversion":
        knn_only = {
            "bands (one per fold)": isinstance(bands, (list, tuple)),
            "kind": resolve_kind(kind) != "log_ratio",
            "k_grid": tuple(k_grid) != K_GRID,
            "train_rows": train_rows is not None,
            "test_rows": test_rows is not None,
        }
        bad = [k for k, v in knn_only.items() if v]
        if bad:
            raise ValueError(f"estimator 'inversion' does not take {bad} (KNN only).")
        return evaluate_inversion(
            table,
            bands,
            levels=levels,
            noise=noise,
            seed=seed,
            fold_seed=fold_seed,
            thresholds=thresholds,
            params=params,
            radiance=radiance,
            keep_rows=keep_rows,
            modelled_per_class=modelled_per_class,
            modelled_classes=modelled_classes,
            surface_mode=surface_mode,
            moon_known=moon_known,
            mixtures=mixtures,
            planck=planck,
            peak_shifts=peak_shifts,
        )
    if planck or len(peak_shifts):
        raise ValueError(
            "planck, peak_shifts: modelled and shifted spectra go into the prior "
            "of estimator 'inversion'; the KNN trains on measured lamps' scenes."
        )
    if mixtures:
        raise ValueError(
            "mixtures: blends go into the prior of estimator 'inversion'; the "
            "KNN trains on measured lamps' scenes."
        )
    if moon_known:
        raise ValueError(
            "moon_known: the KNN uses band ratios and cannot be told the Moon; "
            "it is for estimator 'inversion'."
        )
    surface_mode = validate_method(surface_mode, SURFACE_MODES, "surface_mode")
    if surface_mode != "unknown":
        raise ValueError(
            f"surface_mode {surface_mode!r}: the KNN knows nothing of the surface "
            "(only 'unknown'); surface knowledge is for estimator 'inversion'."
        )
    if modelled_per_class < 0:
        raise ValueError(f"modelled_per_class must be >= 0 (got {modelled_per_class}).")
    if modelled_per_class and train_rows is not None:
        raise ValueError(
            "train_rows with modelled_per_class > 0: the row mask selects "
            "measured rows only, the modelled rows would ignore it."
        )
    if modelled_per_class and radiance is not None:
        raise ValueError(
            "radiance with modelled_per_class > 0: the modelled rows need the "
            "band set itself (`bands`) to be measured."
        )
    splits = outer_splits(table, fold_seed)
    per_fold_bands = isinstance(bands, (list, tuple))
    if per_fold_bands and len(bands) != len(splits):
        raise ValueError(
            f"bands: {len(bands)} band sets for {len(splits)} outer folds."
        )
    all_rows = np.ones(table.n_rows, bool)
    train_rows = all_rows if train_rows is None else train_rows
    test_rows = all_rows if test_rows is None else test_rows
    cache: dict[int, tuple[np.ndarray, np.ndarray]] = {}

    def feats(k):
        b = bands[k] if per_fold_bands else bands
        key = id(b)
        if key not in cache:
            rad = (
                radiance
                if radiance is not None
                else table.band_radiance(b, noise=noise, params=params, seed=seed)
            )
            x = np.asarray(features(rad, kind))
            cache[key] = (x, usable_rows(x, table, noise))
        return cache[key]

    n_inner = len(splits[0].inner)
    extra_cache: dict[tuple[int, int], tuple] = {}

    def extra(s, j):
        """Modelled training rows of outer fold `s`: inner fold `j`'s training
        set, or the outer training set (j = n_inner); (features, usable,
        ModelledRows)."""
        if (s.outer, j) not in extra_cache:
            lamps = s.train if j == n_inner else s.inner[j][0]
            m = modelled_rows(
                table,
                lamps,
                bands[s.outer] if per_fold_bands else bands,
                modelled_per_class,
                classes=modelled_classes,
                seed=seed,
                stream=s.outer * (n_inner + 1) + j,
                noise=noise,
                params=params,
            )
            if m.n_rows:
                xm = np.asarray(features(m.radiance, kind))
                um = usable_rows(xm, m.table, noise)
            else:  # no class had enough training lamps for a model
                xm, um = None, np.zeros(0, bool)
            extra_cache[(s.outer, j)] = (xm, um, m)
        return extra_cache[(s.outer, j)]

    out = {}
    order = tuple(map(resolve_level, levels))
    for level in order:
        lamp_cls = table.lamp_classes(level)
        classes = class_order(level, lamp_cls)
        cidx = {c: i for i, c in enumerate(classes)}
        y = np.asarray([cidx[c] for c in table.labels(level)])
        yt, proba_all, lamp_ids, fold_of, folds, row_idx = [], [], [], [], [], []
        for s in splits:
            x, keep = feats(s.outer)
            tr = keep & train_rows & table.rows_of_lamps(s.train)
            te = keep & test_rows & table.rows_of_lamps(s.test)
            x_tr, y_tr = x[tr], y[tr]
            if modelled_per_class:
                k, kscores, x_tr, y_tr, fold_extra = _with_modelled(
                    x, y, keep, table, s, extra, cidx, level, len(classes), k_grid
                )
            else:
                k, kscores = choose_k(
                    x,
                    y,
                    table.lamp,
                    s.inner,
                    len(classes),
                    k_grid,
                    rows=keep & train_rows,
                )
                fold_extra = {}
            # the fraction of the k nearest training rows per class: what
            # make_classifier(k).fit(...).predict_proba gives (uniform one-vs-
            # all KNN, tested), without sklearn's full scan per query when every
            # training row is equidistant (a one-band sensor)
            p = vote_proba(neighbour_labels(x_tr, y_tr, x[te], k), k, len(classes))
            yt.append(y[te])
            proba_all.append(p)
            lamp_ids.append(np.asarray(table.lamp_ids, object)[table.lamp[te]])
            fold_of.append(np.full(te.sum(), s.outer))
            row_idx.append(np.flatnonzero(te))
            fs = scores(
                np.asarray(classes, object)[y[te]],
                np.asarray(classes, object)[np.argmax(p, 1)],
                classes,
            )
            folds.append(
                {
                    "outer": s.outer,
                    "k": k,
                    "inner_macro_f1": kscores,
                    "macro_f1": fs["macro_f1"],
                    "accuracy": fs["accuracy"],
                    "n_train_rows": int(tr.sum()),
                    "n_test_rows": int(te.sum()),
                    **fold_extra,
                }
            )
        yt = np.concatenate(yt)
        proba = np.concatenate(proba_all)
        lamp_ids = np.concatenate(lamp_ids)
        labels_true = np.asarray(classes, object)[yt]
        pred = np.asarray(classes, object)[np.argmax(proba, 1)]
        res = scores(labels_true, pred, classes, lamp=lamp_ids)
        res["reject"] = {
            "threshold": REJECT_THRESHOLD,
            **{
                k: v
                for k, v in scores(
                    labels_true, reject(proba, classes, REJECT_THRESHOLD), classes
                ).items()
                if k in ("macro_f1", "accuracy", "coverage", "f1")
            },
            "curve": reject_curve(labels_true, proba, classes, thresholds),
        }
        res["folds"] = folds
        res["macro_f1_fold_mean"] = float(np.mean([f["macro_f1"] for f in folds]))
        res["macro_f1_fold_sd"] = float(np.std([f["macro_f1"] for f in folds]))
        res["n_test_rows"] = len(yt)
        if keep_rows:
            res["rows"] = (np.concatenate(row_idx), labels_true, pred)
        out[level] = LevelScores(**res)
    config = {
        "noise": noise,
        "seed": seed,
        "fold_seed": fold_seed,
        "features": kind,
        "k_grid": list(k_grid),
        "dedup": not noise,
        "n_outer": len(splits),
        "n_inner": len(splits[0].inner),
    }
    if (
        modelled_per_class
    ):  # the default adds no key, so its config (and cache key) is unchanged
        config["modelled_per_class"] = int(modelled_per_class)
        config["modelled_lamps"] = _modelled_config(
            splits, extra, modelled_per_class, modelled_classes, seed
        )
    return BandSetScores(
        level1=out.get("level1"), level2=out.get("level2"), config=config, order=order
    )


def _with_modelled(x, y, keep, table, s, extra, cidx, level, n_classes, k_grid):
    """k chosen on the inner folds with each inner training set's modelled
    rows, then the outer training rows with the outer set's modelled rows:
    `(k, inner scores, training features, training labels, fold record)`.

    For `choose_k` the modelled rows are stacked below the measured ones as
    extra "lamps" (indices from `len(table.lamp_ids)` on), each inner
    training set holding only its own modelled lamps and no validation set
    any."""
    n_inner = len(s.inner)
    xs, ys, lamp, rows, inner = [x], [y], [table.lamp], [keep], []
    next_lamp = len(table.lamp_ids)
    for j, (tr, va) in enumerate(s.inner):
        xm, um, m = extra(s, j)
        ids = np.zeros(0, int)
        if m.n_rows:
            n_l = len(m.table.lamp_ids)
            ids = np.arange(next_lamp, next_lamp + n_l)
            xs.append(xm)
            ys.append(np.asarray([cidx[c] for c in m.labels(level)]))
            lamp.append(next_lamp + m.table.lamp)
            rows.append(um)
            next_lamp += n_l
        inner.append((np.concatenate([tr, ids]), va))
    k, kscores = choose_k(
        np.vstack(xs),
        np.concatenate(ys),
        np.concatenate(lamp),
        inner,
        n_classes,
        k_grid,
        rows=np.concatenate(rows),
    )
    tr = keep & table.rows_of_lamps(s.train)
    xm, um, m = extra(s, n_inner)
    x_tr, y_tr = x[tr], y[tr]
    if m.n_rows:
        ym = np.asarray([cidx[c] for c in m.labels(level)], int)
        x_tr, y_tr = np.vstack([x_tr, xm[um]]), np.concatenate([y_tr, ym[um]])
    record = {
        "n_modelled_train_rows": int(um.sum()),
        "modelled_added": dict(m.info["added"]),
        "modelled_added_inner": [
            dict(extra(s, j)[2].info["added"]) for j in range(n_inner)
        ],
    }
    return k, kscores, x_tr, y_tr, record


def _modelled_config(splits, extra, n_per_class, classes, seed) -> dict:
    """What `config["modelled_lamps"]` says: per outer fold the lamps added per
    class, the measured lamps each model was calibrated on, the skipped
    classes, and the same for each inner training set."""
    n_inner = len(splits[0].inner)
    per_fold = []
    for s in splits:
        info = extra(s, n_inner)[2].info
        per_fold.append(
            {
                "outer": s.outer,
                "added": dict(info["added"]),
                "calibration_lamps": dict(info["calibration_lamps"]),
                "skipped": dict(info["skipped"]),
                "inner_added": [
                    dict(extra(s, j)[2].info["added"]) for j in range(n_inner)
                ],
            }
        )
    return {
        "n_per_class": int(n_per_class),
        "classes": list(classes),
        "seed": int(seed),
        "per_fold": per_fold,
        "inner_folds": "each inner training set has its own modelled lamps, "
        "calibrated on its measured training lamps only",
        "noise": "own draws: bandopt.classify._modelled.modelled_noise_key("
        "seed, outer * (n_inner + 1) + j)",
        "scored": "never: test rows are measured lamps only",
    }


def summary(result: BandSetScores) -> dict:
    """The headline numbers of an `evaluate_band_set` result (JSON-ready):
    per level macro F1 (pooled and fold mean/SD), accuracy, mean per-lamp
    accuracy, F1 per class, the model choice per outer fold (`k` of the KNN
    or `sigma_rel` of the inversion), and the reject option at its default
    threshold (with the inversion: also the unexplained fraction)."""
    out = {}
    for level in LEVEL_KEYS:
        r = getattr(result, level)
        if r is None:
            continue
        out[level] = {
            "macro_f1": r.macro_f1,
            "macro_f1_fold_mean": r.macro_f1_fold_mean,
            "macro_f1_fold_sd": r.macro_f1_fold_sd,
            "accuracy": r.accuracy,
            "mean_lamp_accuracy": r.mean_lamp_accuracy,
            "f1": r.f1,
            # the model choice of each outer fold: k (KNN) or σ_rel (inversion)
            **{
                key: [f[key] for f in r.folds]
                for key in ("k", "sigma_rel")
                if key in r.folds[0]
            },
            "reject": {
                k: r.reject[k]
                for k in (
                    "threshold",
                    "coverage",
                    "accuracy",
                    "macro_f1",
                    "unexplained",
                )
                if k in r.reject
            },
        }
    return out
