"""Classification scores: F1 per class, macro F1, accuracy, confusion matrix,
per-lamp accuracy and the reject curve (thesis section 2.7.1 / Table 2.4:
the confusion matrix and precision, recall and F1 read from it).

For class c with true positives TP, false positives FP and false negatives
FN: precision `TP/(TP+FP)`, recall `TP/(TP+FN)`, F1 their harmonic mean
`2TP/(2TP+FP+FN)` (0 when the class never occurs and is never predicted,
as scikit-learn's `zero_division=0`). An "unknown" (rejected) prediction is a
false negative of its true class and a false positive of none.
"""

from collections.abc import Sequence

import numpy as np


UNKNOWN = "unknown"
"""Label of a rejected prediction."""

REJECT_THRESHOLD = 0.6
"""Default confidence below which a prediction is "unknown": the winning
class holds less than 60 % of the (normalised) one-vs-all votes. [1]"""


def reject(
    proba: np.ndarray, classes: Sequence[str] | np.ndarray, threshold: float
) -> np.ndarray:
    """Labels with the reject option: the class of highest probability, or
    `UNKNOWN` when that probability is below `threshold`."""
    classes = np.asarray(classes, dtype=object)
    return withhold(classes[np.argmax(proba, axis=1)], proba.max(axis=1), threshold)


def withhold(
    predicted, confidence: np.ndarray, threshold: float, *, unexplained=None
) -> np.ndarray:
    """The reject option on given predictions: `UNKNOWN` where the
    `confidence` of the predicted class is below `threshold` or where
    `unexplained` (optional boolean per row) is set; else the prediction."""
    out = np.array(predicted, dtype=object)
    drop = np.asarray(confidence) < threshold
    if unexplained is not None:
        drop = drop | np.asarray(unexplained, bool)
    out[drop] = UNKNOWN
    return out


def confusion(
    y_true,
    y_pred,
    labels: Sequence[str] | np.ndarray,
    *,
    extra: Sequence[str] | np.ndarray = (),
) -> np.ndarray:
    """Counts `(len(labels), len(labels) + len(extra))`: rows true class,
    columns predicted class (then `extra` columns such as "unknown")."""
    cols = list(labels) + list(extra)
    ri = {c: i for i, c in enumerate(labels)}
    ci = {c: i for i, c in enumerate(cols)}
    out = np.zeros((len(labels), len(cols)), int)
    for t, p in zip(
        np.asarray(y_true, object), np.asarray(y_pred, object), strict=True
    ):
        if t in ri and p in ci:
            out[ri[t], ci[p]] += 1
    return out


def f1_from_confusion(cm: np.ndarray) -> dict:
    """Precision, recall and F1 per class (rows of a square-plus-extras
    confusion matrix); arrays of length `cm.shape[0]`."""
    n = cm.shape[0]
    tp = np.diag(cm[:, :n]).astype(float)
    fp = cm[:, :n].sum(axis=0) - tp
    fn = cm.sum(axis=1) - tp
    with np.errstate(invalid="ignore", divide="ignore"):
        prec = np.where(tp + fp > 0, tp / np.maximum(tp + fp, 1), 0.0)
        rec = np.where(tp + fn > 0, tp / np.maximum(tp + fn, 1), 0.0)
        f1 = np.where(
            2 * tp + fp + fn > 0, 2 * tp / np.maximum(2 * tp + fp + fn, 1), 0.0
        )
    return {"precision": prec, "recall": rec, "f1": f1, "support": cm.sum(axis=1)}


def scores(
    y_true,
    y_pred,
    labels: Sequence[str] | np.ndarray,
    lamp=None,
    *,
    others: Sequence[str] | np.ndarray = (),
) -> dict:
    """F1 per class, macro F1, accuracy (over all rows; rejected rows count as
    wrong), coverage (rows not "unknown"), confusion matrix and, with `lamp`
    (the lamp id of each row), per-lamp accuracy.

    `others`: classes a model may predict that are not scored (`labels`), e.g.
    the inversion's prior-only lamps; each gets a confusion column before
    "unknown", and predicting one is a miss of the true class. A prediction
    in neither `labels`, `others` nor "unknown" raises `ValueError` (it would
    silently drop out of the confusion matrix)."""
    y_true = np.asarray(y_true, object)
    y_pred = np.asarray(y_pred, object)
    extra = (*others, UNKNOWN)
    stray = set(y_pred.tolist()) - set(labels) - set(extra)
    if stray:
        raise ValueError(
            f"y_pred: classes {sorted(map(str, stray))} are neither scored labels "
            f"{list(labels)} nor in `others`."
        )
    cm = confusion(y_true, y_pred, labels, extra=extra)
    pr = f1_from_confusion(cm)
    out = {
        "labels": list(labels),
        "f1": {c: float(v) for c, v in zip(labels, pr["f1"], strict=True)},
        "precision": {
            c: float(v) for c, v in zip(labels, pr["precision"], strict=True)
        },
        "recall": {c: float(v) for c, v in zip(labels, pr["recall"], strict=True)},
        "support": {c: int(v) for c, v in zip(labels, pr["support"], strict=True)},
        "macro_f1": float(np.mean(pr["f1"])),
        "accuracy": float(np.mean(y_true == y_pred)) if len(y_true) else float("nan"),
        "coverage": float(np.mean(y_pred != UNKNOWN)) if len(y_true) else float("nan"),
        "confusion": cm.tolist(),
        "confusion_columns": [*labels, *extra],
    }
    if lamp is not None:
        lamp = np.asarray(lamp, object)
        acc = {}
        for lid in dict.fromkeys(lamp.tolist()):
            m = lamp == lid
            acc[lid] = float(np.mean(y_true[m] == y_pred[m]))
        out["lamp_accuracy"] = acc
        per_class = {}
        for c in labels:
            ids = sorted({lid for lid, t in zip(lamp, y_true, strict=True) if t == c})
            per_class[c] = (
                float(np.mean([acc[i] for i in ids])) if ids else float("nan")
            )
        out["lamp_accuracy_by_class"] = per_class
        out["mean_lamp_accuracy"] = float(np.nanmean(list(per_class.values())))
    return out


def reject_curve(
    y_true,
    proba: np.ndarray,
    classes: Sequence[str] | np.ndarray,
    thresholds: Sequence[float] | np.ndarray,
) -> list[dict]:
    """For each confidence threshold: coverage (fraction of rows not rejected),
    accuracy and macro F1 on the accepted rows, and the macro F1 with rejected
    rows counted as misses."""
    classes = np.asarray(classes, dtype=object)
    return confidence_curve(
        y_true,
        classes[np.argmax(proba, axis=1)],
        proba.max(axis=1),
        classes,
        thresholds,
    )


def confidence_curve(
    y_true,
    predicted,
    confidence: np.ndarray,
    labels: Sequence[str] | np.ndarray,
    thresholds: Sequence[float] | np.ndarray,
    *,
    unexplained=None,
    others: Sequence[str] | np.ndarray = (),
) -> list[dict]:
    """`reject_curve` for given predictions and their confidences (`withhold`
    at each threshold; `unexplained` rows are rejected at every threshold;
    `others` as in `scores`)."""
    y_true = np.asarray(y_true, object)
    out = []
    for t in thresholds:
        pred = withhold(predicted, confidence, float(t), unexplained=unexplained)
        acc_rows = pred != UNKNOWN
        s_all = scores(y_true, pred, labels, others=others)
        if acc_rows.any():
            s_acc = scores(y_true[acc_rows], pred[acc_rows], labels, others=others)
            acc, mf1 = s_acc["accuracy"], s_acc["macro_f1"]
        else:
            acc, mf1 = float("nan"), float("nan")
        out.append(
            {
                "threshold": float(t),
                "coverage": float(acc_rows.mean()),
                "accuracy_accepted": acc,
                "macro_f1_accepted": mf1,
                "macro_f1_rejects_as_misses": s_all["macro_f1"],
            }
        )
    return out
