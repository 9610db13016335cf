"""Summaries of stability-study results: per-partition errors, the band-count
rule, the Pareto front and its recommended point, per-band intervals, paired
comparisons (the tolerance analysis of a band set is `_tolerance`).

Stated rules (also written into every output):

- *normalised MAE* of a partition: mean over LER, G, CCT of the class-balanced
  outer-test MAE divided by the class-balanced SD of that metric's truth over
  all scored lamps (LER [lm/W], G [1], CCT [K]);
- *band count*: the smallest n whose mean normalised MAE over partitions is
  within one SD (over partitions) of the best n's mean (one-SD rule);
- *recommended Pareto point*: objectives (normalised MAE, 1 - macro F1,
  -log10 SNR) min-max scaled over the Pareto-optimal candidates; the point
  nearest the utopia point (0, 0, 0) in Euclidean distance;
- *recommended design*: the medoid of the per-resample designs of the chosen
  (n, alpha) (least summed distance in (centre, FWHM) [nm]); per-band
  intervals are the range (min-max) of the matched (sorted by centre) bands
  over resamples, so they always contain the recommended design.
"""

import itertools

import numpy as np

from ..estimate import METRICS
from ..folds import class_balanced_weights
from ..knn import macro_f1_int
from ._stability import medoid, region_frequency


NORMALISATION_NOTE = (
    "normalised MAE = mean over LER, G, CCT of class-balanced outer-test MAE / "
    "class-balanced SD of the metric's truth over all scored lamps"
)
COUNT_RULE = (
    "smallest n (free bands, + fixed pan) whose mean normalised MAE over lamp "
    "partitions is within one SD (over partitions) of the best n's mean"
)
PARETO_RULE = (
    "Pareto-optimal candidates in (normalised MAE, 1 - level-2 macro F1, "
    "-log10 SNR); each objective min-max scaled over them; recommended: the "
    "one nearest the utopia point (0, 0, 0)"
)
DESIGN_RULE = (
    "medoid of the per-resample designs (least summed Euclidean distance in "
    "(centre, FWHM) [nm], bands sorted by centre); intervals: range (min-max) "
    "of each sorted band over resamples"
)


def truth_sd(table) -> np.ndarray:
    """Class-balanced SD of each metric's lamp truth (LER, G, CCT [K])."""
    out = np.empty(3)
    for m in range(3):
        ok = table.valid[:, m]
        w = class_balanced_weights(table.classes[ok])
        v = table.truth[ok, m]
        mu = np.sum(w * v)
        out[m] = np.sqrt(np.sum(w * (v - mu) ** 2))
    return out


def macro_f1(y_true, y_pred) -> float:
    y_true, y_pred = np.asarray(y_true), np.asarray(y_pred)
    return macro_f1_int(y_true, y_pred, np.unique(y_true))


def per_partition(scores, classes, sd) -> dict:
    """MAE per metric (P, 3), normalised MAE (P,) and macro F1 (P,) of each
    partition, pooling its outer folds (every lamp tested once)."""
    classes = np.asarray(classes, object)
    parts = sorted({s["partition"] for s in scores})
    mae, f1 = [], []
    for p in parts:
        ss = [s for s in scores if s["partition"] == p]
        idx = np.concatenate([s["lamp_index"] for s in ss]).astype(int)
        err = np.concatenate([np.asarray(s["lamp_errors"], float) for s in ss])
        row = []
        for m in range(3):
            ok = np.isfinite(err[:, m])
            w = class_balanced_weights(classes[idx[ok]])
            row.append(float(np.sum(w * err[ok, m])))
        mae.append(row)
        yt = np.concatenate([s["labels_true"] for s in ss])
        yp = np.concatenate([s["labels_pred"] for s in ss])
        f1.append(macro_f1(yt, yp))
    mae = np.asarray(mae)
    return {
        "partitions": len(parts),
        "mae": mae,
        "norm_mae": (mae / np.asarray(sd)[None, :]).mean(axis=1),
        "f1": np.asarray(f1),
    }


def partition_summary(scores, classes, sd) -> dict:
    """JSON-ready mean and SD over partitions (`mae_mean`, `mae_sd` keyed by
    metric; `norm_mae_*`, `f1_*`) plus the per-partition values."""
    pp = per_partition(scores, classes, sd)
    sdd = 1 if pp["partitions"] > 1 else 0
    return {
        "partitions": pp["partitions"],
        "mae_mean": {m: float(pp["mae"][:, i].mean()) for i, m in enumerate(METRICS)},
        "mae_sd": {
            m: float(pp["mae"][:, i].std(ddof=sdd)) for i, m in enumerate(METRICS)
        },
        "norm_mae_mean": float(pp["norm_mae"].mean()),
        "norm_mae_sd": float(pp["norm_mae"].std(ddof=sdd)),
        "f1_mean": float(pp["f1"].mean()),
        "f1_sd": float(pp["f1"].std(ddof=sdd)),
        "per_partition": {
            "mae": pp["mae"].tolist(),
            "norm_mae": pp["norm_mae"].tolist(),
            "f1": pp["f1"].tolist(),
        },
    }


def band_count_choice(per_n: dict) -> dict:
    """`per_n`: {n: per-partition normalised MAE (P,)} (same partitions).
    Returns the one-SD choice and paired differences to the next n."""
    ns = sorted(per_n)
    mean = {n: float(np.mean(per_n[n])) for n in ns}
    sd = {n: float(np.std(per_n[n], ddof=1)) for n in ns}
    best = min(ns, key=lambda n: mean[n])
    chosen = min(n for n in ns if mean[n] <= mean[best] + sd[best])
    paired = {}
    for a, b in itertools.pairwise(ns):
        d = np.asarray(per_n[b]) - np.asarray(per_n[a])
        paired[f"{b}-{a}"] = {
            "mean": float(d.mean()),
            "sd": float(d.std(ddof=1)),
            "partitions_better": int(np.sum(d < 0)),
            "partitions": int(d.size),
        }
    return {
        "rule": COUNT_RULE,
        "best_n": best,
        "chosen_n": chosen,
        "mean": mean,
        "sd": sd,
        "paired_difference_to_next_n": paired,
    }


def pareto_mask(points: np.ndarray) -> np.ndarray:
    """Non-dominated rows of `points` (all objectives minimised)."""
    p = np.asarray(points, float)
    keep = np.ones(len(p), bool)
    for i in range(len(p)):
        dom = np.all(p <= p[i], axis=1) & np.any(p < p[i], axis=1)
        keep[i] = not dom.any()
    return keep


def knee(points: np.ndarray, mask: np.ndarray) -> int:
    """Index (into `points`) of the recommended Pareto point (`PARETO_RULE`)."""
    p = np.asarray(points, float)
    idx = np.flatnonzero(mask)
    q = p[idx]
    lo, hi = q.min(0), q.max(0)
    span = np.where(hi > lo, hi - lo, 1.0)
    d = np.sqrt((((q - lo) / span) ** 2).sum(1))
    return int(idx[np.argmin(d)])


def design_intervals(designs, lo_q: float = 0.0, hi_q: float = 100.0) -> dict:
    """Medoid and per-band percentile intervals (default: min-max) of sorted
    designs."""
    pairs = [(np.asarray(d["centre_nm"]), np.asarray(d["fwhm_nm"])) for d in designs]
    i = medoid(pairs)
    c = np.stack([p[0] for p in pairs])
    f = np.stack([p[1] for p in pairs])
    return {
        "rule": DESIGN_RULE,
        "medoid_resample": i,
        "centre_nm": pairs[i][0].tolist(),
        "fwhm_nm": pairs[i][1].tolist(),
        "centre_interval_nm": np.stack(
            [np.percentile(c, lo_q, 0), np.percentile(c, hi_q, 0)], 1
        ).tolist(),
        "fwhm_interval_nm": np.stack(
            [np.percentile(f, lo_q, 0), np.percentile(f, hi_q, 0)], 1
        ).tolist(),
        "centre_sd_nm": c.std(0, ddof=1).tolist(),
        "region_frequency": region_frequency(pairs),
        "resamples": len(pairs),
    }


def lamp_mean_errors(scores) -> tuple[list[int], list[list[float]]]:
    """Per lamp, the absolute error averaged over the partitions that tested it."""
    acc: dict[int, list] = {}
    for s in scores:
        for i, e in zip(s["lamp_index"], s["lamp_errors"], strict=True):
            acc.setdefault(int(i), []).append(np.asarray(e, float))
    idx = sorted(acc)
    return idx, [np.nanmean(np.stack(acc[i]), 0).tolist() for i in idx]
