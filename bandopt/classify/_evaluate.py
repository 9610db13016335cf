"""Nested lamp-grouped evaluation of a band set for lamp-type classification.

For every outer fold of `bandopt.folds.nested_lamp_splits` (stratified by
level-2 class, the same folds as the band search of issue 5 for the same
seed): features of the band radiances, k chosen by inner-fold macro F1, the
one-vs-all KNN fitted on the outer training lamps and applied to the outer
test lamps. Scores are computed over the pooled outer test predictions (each
scored lamp is tested exactly once); per-fold macro F1 is reported beside.
Only scored classes (`LampLibrary.is_scored`) take part.
"""

from collections.abc import Sequence

import numpy as np

from ..forward import ScenarioTable, resolve_level
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
) -> BandSetScores:
    """Outer-fold scores of one band set (or one band set per outer fold, a
    sequence, for bands searched inside each fold).

    `estimator`: `"knn"` (default) or `"inversion"` (`evaluate_inversion`,
    the same folds and scores; one band set, all rows, no KNN options).

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
            k, kscores = choose_k(
                x, y, table.lamp, s.inner, len(classes), k_grid, rows=keep & train_rows
            )
            tr = keep & train_rows & table.rows_of_lamps(s.train)
            te = keep & test_rows & table.rows_of_lamps(s.test)
            # the fraction of the k nearest training rows per class: what
            # make_classifier(k).fit(...).predict_proba gives (uniform one-vs-
            # all KNN, tested), without sklearn's full scan per query when every
            # training row is equidistant (a one-band sensor)
            p = vote_proba(neighbour_labels(x[tr], y[tr], x[te], k), k, len(classes))
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
    return BandSetScores(
        level1=out.get("level1"), level2=out.get("level2"), config=config, order=order
    )


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
