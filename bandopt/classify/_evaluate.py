"""Nested lamp-grouped evaluation of a band set for lamp-type classification.

For every outer fold of `bandopt.folds.nested_lamp_splits` (stratified by
level-2 class, the same folds as the band search of issue 5 for the same
seed): features of the band radiances, k chosen by inner-fold macro F1, the
one-vs-all KNN fitted on the outer training lamps and applied to the outer
test lamps. Scores are computed over the pooled outer test predictions (each
scored lamp is tested exactly once); per-fold macro F1 is reported beside.
Only scored classes (`LampLibrary.is_scored`) take part.
"""

import dataclasses
from collections.abc import Mapping, Sequence

import numpy as np

from ..datasets.lamps import LEVEL1, LEVEL2
from ..folds import nested_lamp_splits
from ..forward import ScenarioTable, resolve_level
from ..knn import K_GRID, choose_k, features, make_classifier, resolve_kind
from ..names import validate_method
from ._features import deduplicate
from ._metrics import REJECT_THRESHOLD, reject, reject_curve, scores


LEVEL_KEYS = ("level1", "level2")

ESTIMATORS = ("knn", "inversion")
"""Classifiers `evaluate_band_set` scores: the one-vs-all KNN on log band
ratios (default) and the physics-based inversion (`evaluate_inversion`)."""

REJECT_GRID: tuple[float, ...] = (0.0, 0.4, 0.5, 0.6, 0.7, 0.8, 0.9, 1.0)
"""Confidence thresholds of the reported reject curve. [1]"""


@dataclasses.dataclass(frozen=True)
class LevelScores:
    """Scores of one classification level over the pooled outer test rows.

    The first fields are those of `bandopt.classify.scores` (with per-lamp
    accuracy); then the reject option at `REJECT_THRESHOLD` with its curve,
    the per-fold records, fold mean and SD of macro F1, the number of test
    rows and, with `keep_rows`, `rows` = (row index, true label, predicted
    label) arrays (not JSON-ready, left out of `to_dict`); for the inversion
    with `keep_rows` also `reject_rows` = (probability of the predicted class,
    unexplained flag) of the same rows (likewise left out).
    """

    labels: list[str]
    f1: dict[str, float]
    precision: dict[str, float]
    recall: dict[str, float]
    support: dict[str, int]
    macro_f1: float
    accuracy: float
    coverage: float
    confusion: list[list[int]]
    confusion_columns: list[str]
    lamp_accuracy: dict[str, float]
    lamp_accuracy_by_class: dict[str, float]
    mean_lamp_accuracy: float
    reject: dict
    folds: list[dict]
    macro_f1_fold_mean: float
    macro_f1_fold_sd: float
    n_test_rows: int
    rows: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None
    reject_rows: tuple[np.ndarray, np.ndarray] | None = None

    def to_dict(self, *, rows: bool = False) -> dict:
        """The JSON-ready dict (the form `evaluate_band_set` returned before
        it returned this class); `rows=True` adds the `rows` (and
        `reject_rows`) arrays that exist."""
        out = {f.name: getattr(self, f.name) for f in dataclasses.fields(self)}
        for key in ("rows", "reject_rows"):
            if not rows or out[key] is None:
                del out[key]
        return out


@dataclasses.dataclass(frozen=True)
class BandSetScores:
    """What `evaluate_band_set` returns: `level1`/`level2` scores (None for a
    level not evaluated) and the evaluation settings `config`."""

    level1: LevelScores | None
    level2: LevelScores | None
    config: Mapping
    order: tuple[str, ...] = LEVEL_KEYS
    """Order of the levels as requested (kept by `to_dict`)."""

    def level(self, name: str) -> LevelScores:
        """The scores of level `name` (`level1`/`level2`, aliases allowed)."""
        key = resolve_level(name)
        found = getattr(self, key)
        if found is None:
            raise ValueError(f"level {key!r} was not evaluated ({list(self.order)}).")
        return found

    @property
    def levels(self) -> tuple[str, ...]:
        """The evaluated levels, in the requested order."""
        return self.order

    def to_dict(self, *, rows: bool = False) -> dict:
        """JSON-ready dict: one entry per evaluated level, then `config` (the
        form `evaluate_band_set` returned before; `rows=True` keeps `rows`)."""
        out: dict = {lv: getattr(self, lv).to_dict(rows=rows) for lv in self.order}
        out["config"] = dict(self.config)
        return out


def class_order(level: str, present: Sequence[str] | np.ndarray) -> list[str]:
    """Classes of `level` in the library's identifier order, only those present."""
    ref = LEVEL1 if resolve_level(level) == "level1" else LEVEL2
    present = set(present)
    return [c for c in ref if c in present]


def outer_splits(table: ScenarioTable, seed: int = 0):
    """The nested lamp splits of the table's lamps, stratified by level 2."""
    return nested_lamp_splits(table.level2, seed=seed)


def usable_rows(x: np.ndarray, table: ScenarioTable, noise: bool) -> np.ndarray:
    """Boolean mask: all rows with noise; without noise, one row per group of
    identical feature rows of a lamp (`deduplicate`)."""
    keep = np.zeros(table.n_rows, bool)
    if noise:
        keep[:] = True
    else:
        keep[deduplicate(x, table.lamp)] = True
    return keep


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
        from ._inversion import evaluate_inversion  # it builds on this module

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
            clf = make_classifier(k).fit(x[tr], y[tr])
            p = np.zeros((te.sum(), len(classes)))
            p[:, clf.classes_] = clf.predict_proba(x[te])
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
