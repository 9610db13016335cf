"""Rows of the robustness study from its records: class-balanced means per
partition, mean ± SD over partitions, ECE of the level-1 probabilities (all
pixels and the answered ones), paired differences against the clean row and
reliability curves (`bandopt.robustness`)."""

from collections.abc import Sequence

import numpy as np

from .. import inversion as inv_mod
from ..calibration import expected_calibration_error, reliability_curve
from ..estimate import METRICS
from ..folds import class_balanced_weights, paired_lamp_ci
from ._study import RobustnessStudy


COLUMNS = (
    "level1_correct",
    "level2_correct",
    "LER",
    "G",
    "CCT",
    "LER_covered",
    "G_covered",
    "CCT_covered",
    "unexplained",
)
"""Columns of `inversion.summarise` a row reports (class-balanced means over
held-out lamps per partition; MAE for LER [lm/W], G [1], CCT [K])."""

WIDTH_COLUMNS = tuple(f"{m}_width_median" for m in METRICS)
"""Median 90 % interval width per metric: per partition the class-balanced
weighted median over lamps of each lamp's median width. [lm/W], [1], [K]"""

PAIRED = (*COLUMNS, *WIDTH_COLUMNS, "ECE", "ECE_answered", "level1_answered")
"""Columns whose perturbed-minus-clean difference is paired by partition."""

INTERVAL_NOTE = (
    "<col>_diff_ci95: 95 % percentile bootstrap interval of the paired "
    "difference (per partition the class-balanced mean over held-out lamps, "
    "then the mean over partitions), lamps resampled within level-2 class "
    "(2,000 draws, seed 0). Only columns with a value per lamp (right, MAE, "
    "covered, unexplained) have one: widths are medians and ECE is pooled "
    "over pixels"
)
"""What a `_diff_ci95` of a summary's `paired` and `versus` entries is."""


def _weights(recs) -> np.ndarray:
    return class_balanced_weights(np.asarray([r["level2"] for r in recs], object))


def partition_ece(recs, answered: bool = False) -> float | None:
    """ECE of the level-1 probabilities (top-class confidence) over every
    pixel of `recs`, each pixel weighted by its lamp's class-balanced weight
    over its rows (`calibration.expected_calibration_error`). `answered`:
    only the pixels not flagged `unexplained` (a flagged pixel is given no
    type, so its probabilities are no answer); None when none is (or the
    records predate the per-pixel flags)."""
    w = _weights(recs)
    conf = np.concatenate([r["level1_confidence"] for r in recs])
    right = np.concatenate([r["level1_top_right"] for r in recs]).astype(bool)
    pix = np.concatenate(
        [np.full(r["rows"], wi / r["rows"]) for r, wi in zip(recs, w, strict=True)]
    )
    if answered:
        if any("level1_flagged" not in r for r in recs):
            return None
        keep = ~np.concatenate([r["level1_flagged"] for r in recs]).astype(bool)
        if not keep.any():
            return None
        conf, right, pix = conf[keep], right[keep], pix[keep]
    return expected_calibration_error(conf, right, pix)


def partition_answered(recs) -> float | None:
    """Class-balanced mean over lamps of level-1 right among the pixels not
    flagged `unexplained` (lamps with every pixel flagged left out; None:
    no lamp answered)."""
    have = [r for r in recs if r.get("level1_answered_correct") is not None]
    if not have:
        return None
    w = _weights(have)
    vals = np.asarray([r["level1_answered_correct"] for r in have], float)
    return float(np.sum(w * vals) / w.sum())


def partition_width(recs, col: str) -> float | None:
    """Class-balanced weighted median over lamps of `col` (None: no lamp has
    it)."""
    have = [r for r in recs if r.get(col) is not None]
    if not have:
        return None
    vals = np.asarray([r[col] for r in have], float)
    return float(inv_mod.weighted_quantile(vals, _weights(have)[None], [0.5])[0, 0])


def _mean_sd(per: list) -> tuple:
    per = [x for x in per if x is not None]
    if not per:
        return None, None
    return float(np.mean(per)), (float(np.std(per, ddof=1)) if len(per) > 1 else None)


def reliability(recs) -> dict:
    """Pooled reliability curve (`calibration.reliability_curve`) of `recs`'
    level-1 confidences, class-balanced pixel weights per partition, each
    partition the same weight: bin edges, mean confidence, accuracy, share."""
    conf, right, pix = [], [], []
    parts = sorted({r["partition"] for r in recs})
    for p in parts:
        rp = [r for r in recs if r["partition"] == p]
        for r, wi in zip(rp, _weights(rp), strict=True):
            conf.append(r["level1_confidence"])
            right.append(r["level1_top_right"])
            pix.append(np.full(r["rows"], wi / r["rows"] / len(parts)))
    edges, c, a, share = reliability_curve(
        np.concatenate(conf), np.concatenate(right).astype(bool), np.concatenate(pix)
    )

    def listed(x):  # an empty bin's NaN is null in JSON
        return [float(v) if np.isfinite(v) else None for v in x]

    return {
        "edges": edges.tolist(),
        "confidence": listed(c),
        "accuracy": listed(a),
        "share": share.tolist(),
    }


def lamp_differences(recs_a, recs_b, col: str) -> dict:
    """`col` a - b per (lamp, partition) scored on both sides with a value
    (records with None left out), as the columns `paired_lamp_ci` takes:
    `values`, `lamps`, `classes` (level-2) and `groups` (partitions)."""
    a = {(r["lamp"], r["partition"]): r[col] for r in recs_a if r.get(col) is not None}
    out: dict[str, list] = {"values": [], "lamps": [], "classes": [], "groups": []}
    for r in recs_b:
        k = (r["lamp"], r["partition"])
        if r.get(col) is None or k not in a:
            continue
        out["values"].append(float(a[k]) - float(r[col]))
        out["lamps"].append(r["lamp"])
        out["classes"].append(r["level2"])
        out["groups"].append(r["partition"])
    return out


def _lamp_intervals(recs_a, recs_b) -> dict:
    """`<col>_diff_ci95` of a - b for every `COLUMNS` column with a value on
    both sides (`INTERVAL_NOTE`)."""
    out = {}
    for col in COLUMNS:
        d = lamp_differences(recs_a, recs_b, col)
        if d["values"]:
            _, lo, hi = paired_lamp_ci(**d)
            out[col + "_diff_ci95"] = [lo, hi]
    return out


def _paired_columns(a_row: dict, b_row: dict) -> dict:
    """`<col>_diff` and `<col>_diff_sd` of `a_row - b_row` for every `PAIRED`
    column, partition by partition (mean and SD over partitions)."""
    out = {}
    for col in PAIRED:
        a, b = a_row.get(col + "_per_partition"), b_row.get(col + "_per_partition")
        if not a or not b or len(a) != len(b) or None in a or None in b:
            continue
        diff = np.asarray(a, float) - np.asarray(b, float)
        out[col + "_diff"] = float(diff.mean())
        out[col + "_diff_sd"] = float(diff.std(ddof=1)) if diff.size > 1 else None
    return out


def summarise(
    records: Sequence[dict], study: RobustnessStudy, *, versus: bool = True
) -> dict:
    """Rows per (band set, perturbation) in the study's order: `COLUMNS` from
    `inversion.summarise`, `WIDTH_COLUMNS` and `ECE` per partition, each with
    mean, SD and per-partition values; paired differences against "clean"
    (same band set, partition by partition: mean and SD); `versus`: the
    first band set (ours) minus each other band set on the same row, paired
    by partition the same way (`versus=False`: none, for studies whose band
    sets are peers, such as the judge's candidates); every paired difference
    of a per-lamp column also with a 95 % interval over lamps
    (`INTERVAL_NOTE`); pooled reliability
    of clean and perturbed level-1 probabilities per band set (JSON-ready,
    no NaN: an empty reliability bin is None)."""
    base = {
        (r["band_set"], r["perturbation"]): r
        for r in inv_mod.summarise(records, keys=("band_set", "perturbation"))
    }
    by_key: dict[tuple, list[dict]] = {}
    for r in records:
        by_key.setdefault((r["band_set"], r["perturbation"]), []).append(r)
    rows = []
    for b, _ in study.band_sets:
        for pert in study.perturbations:
            key = (b, pert.label)
            if key not in base:
                continue
            src = base[key]
            row = {
                "band_set": b,
                "perturbation": pert.label,
                "kind": pert.kind,
                "value": pert.value,
                **({"band": pert.band} if pert.band else {}),
                "partitions": src["partitions"],
                "lamps_per_partition": src["lamps_per_partition"],
                "out_of_range": src["out_of_range"],
            }
            for col in COLUMNS:
                for suffix in ("", "_sd", "_per_partition"):
                    row[col + suffix] = src.get(col + suffix)
            recs = by_key[key]
            parts = sorted({r["partition"] for r in recs})
            by_p = [[r for r in recs if r["partition"] == p] for p in parts]
            extra = {
                "ECE": [partition_ece(rp) for rp in by_p],
                "ECE_answered": [partition_ece(rp, answered=True) for rp in by_p],
                "level1_answered": [partition_answered(rp) for rp in by_p],
            }
            for col in WIDTH_COLUMNS:
                extra[col] = [partition_width(rp, col) for rp in by_p]
            for col, per in extra.items():
                row[col], row[col + "_sd"] = _mean_sd(per)
                row[col + "_per_partition"] = per
            rows.append(row)
    paired = []
    by = {(r["band_set"], r["perturbation"]): r for r in rows}
    for r in rows:
        clean = by.get((r["band_set"], "clean"))
        if r["perturbation"] == "clean" or clean is None:
            continue
        d = {"band_set": r["band_set"], "perturbation": r["perturbation"]}
        d.update(_paired_columns(r, clean))
        perturbed = by_key[(r["band_set"], r["perturbation"])]
        d.update(_lamp_intervals(perturbed, by_key[(r["band_set"], "clean")]))
        paired.append(d)
    first = study.band_sets[0][0]
    pairs = []
    for r in rows if versus else ():
        if r["band_set"] == first:
            continue
        ours = by.get((first, r["perturbation"]))
        if ours is None:
            continue
        d = {"band_set": first, "reference": r["band_set"],
             "perturbation": r["perturbation"]}  # fmt: skip
        d.update(_paired_columns(ours, r))
        theirs = by_key[(r["band_set"], r["perturbation"])]
        d.update(_lamp_intervals(by_key[(first, r["perturbation"])], theirs))
        pairs.append(d)
    rel = {}
    for b, _ in study.band_sets:
        clean = [r for r in records if r["band_set"] == b and r["kind"] == "clean"]
        pert = [
            r for r in records if r["band_set"] == b and r["kind"] not in ("clean",)
        ]
        if clean and pert:
            rel[b] = {"clean": reliability(clean), "perturbed": reliability(pert)}
    return {
        "rows": rows,
        "paired": paired,
        "versus": pairs,
        "reliability": rel,
        "interval_note": INTERVAL_NOTE,
        "partitions": len({r["partition"] for r in records}),
        "fold": study.fold,
        "perturbations": [p.label for p in study.perturbations],
        "band_sets": [b for b, _ in study.band_sets],
    }
