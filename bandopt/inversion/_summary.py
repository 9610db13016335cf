"""Summaries of cross-validation records: class-balanced means per partition,
mean and SD over partitions (`summarise`), and paired differences between
estimators or band sets within a partition."""

from collections.abc import Sequence

import numpy as np

from ..folds import class_balanced_weights
from ._estimators import (
    EVIDENCE_ESTIMATOR,
    MIX_ESTIMATOR,
    MIX_METRIC_ESTIMATOR,
    MOON_ESTIMATOR,
)


def _cb_mean(values, classes) -> float:
    """Class-balanced mean (each class the same weight) of per-lamp values."""
    v = np.asarray(values, float)
    ok = np.isfinite(v)
    if not ok.any():
        return float("nan")
    return float(np.sum(class_balanced_weights(np.asarray(classes)[ok]) * v[ok]))


SUMMARY_COLUMNS = (
    "LER",
    "G",
    "CCT",
    "CCT_mired",
    "LER_covered",
    "G_covered",
    "CCT_covered",
    "LER_width",
    "G_width",
    "CCT_width",
    "CCT_width_mired",
    "level1_correct",
    "level2_correct",
    "unexplained",
)


def summarise(records: Sequence[dict], keys=("band_set", "estimator", "surface")):
    """Per group of `keys`: per partition the class-balanced mean over test
    lamps of each `SUMMARY_COLUMNS` value (MAE for the metrics), then mean and
    SD over partitions; `out_of_range` summed. Records need a `partition`.
    Records that say `modelled_per_class` pass it on to their group's row
    (records without it, e.g. those of a run without modelled lamps: no
    such key)."""
    groups: dict = {}
    for r in records:
        groups.setdefault(tuple(r[k] for k in keys), []).append(r)
    rows = []
    for g, recs in sorted(groups.items()):
        parts = sorted({r["partition"] for r in recs})
        row = dict(zip(keys, g, strict=True))
        row["partitions"] = len(parts)
        row["lamps_per_partition"] = len(recs) // max(len(parts), 1)
        row["out_of_range"] = int(sum(r["out_of_range"] for r in recs))
        n_model = {r["modelled_per_class"] for r in recs if "modelled_per_class" in r}
        if len(n_model) > 1:
            raise ValueError(
                f"group {g}: records with different modelled_per_class {n_model}."
            )
        if n_model:
            row["modelled_per_class"] = n_model.pop()
        for col in SUMMARY_COLUMNS:
            per = []
            for p in parts:
                rp = [r for r in recs if r["partition"] == p and r.get(col) is not None]
                if rp:
                    per.append(
                        _cb_mean([r[col] for r in rp], [r["level2"] for r in rp])
                    )
            if per:
                row[col] = float(np.mean(per))
                row[f"{col}_sd"] = float(np.std(per, ddof=1)) if len(per) > 1 else None
                row[f"{col}_per_partition"] = per
        rows.append(row)
    return rows


def paired_differences(summary_rows, reference: str, against: str):
    """Per (estimator, surface): MAE of `against` minus `reference` band set,
    paired by partition; mean, SD and relative change of the mean."""
    by = {(r["band_set"], r["estimator"], r["surface"]): r for r in summary_rows}
    out = []
    for (bs, est, surf), r in sorted(by.items()):
        if bs != against or (reference, est, surf) not in by:
            continue
        row = {"estimator": est, "surface": surf, "band_set": against, "vs": reference}
        out.append(_paired_by_partition(r, by[(reference, est, surf)], row))
    return out


PAIRED_COLUMNS = ("LER", "G", "CCT", "CCT_mired")
"""Summary columns `_paired_by_partition` compares by default (the errors)."""


def _paired_by_partition(row_a, row_b, out: dict, columns=PAIRED_COLUMNS) -> dict:
    """`out` plus, per column of `columns`, `a - b` of two summary rows paired
    by partition: mean (`_diff`), SD (ddof 1, `_diff_sd`) and mean relative
    to b's (`_relative`); columns without matching per-partition values are
    left out."""
    for m in columns:
        a, b = row_a.get(f"{m}_per_partition"), row_b.get(f"{m}_per_partition")
        if not a or not b or len(a) != len(b):
            continue
        d = np.asarray(a) - np.asarray(b)
        out[f"{m}_diff"] = float(d.mean())
        out[f"{m}_diff_sd"] = float(d.std(ddof=1)) if d.size > 1 else None
        out[f"{m}_relative"] = float(d.mean() / np.mean(b)) if np.mean(b) else None
    return out


ESTIMATOR_PAIRS = (
    ("ridge+models", "ridge"),
    ("kernel+models", "kernel"),
    ("inversion+models", "inversion"),
    (EVIDENCE_ESTIMATOR, "inversion"),
    (MOON_ESTIMATOR, "inversion"),
    (MIX_ESTIMATOR, MOON_ESTIMATOR),
    (MIX_METRIC_ESTIMATOR, MIX_ESTIMATOR),
)
"""(variant, base) estimator pairs `estimator_differences` compares: what
modelled training lamps, the evidence rule for `σ_rel`, the told Moon and
mixtures in the told-Moon prior change."""


def estimator_differences(summary_rows, pairs=ESTIMATOR_PAIRS, columns=PAIRED_COLUMNS):
    """Per band set, surface and (variant, base) pair of `pairs`: MAE of the
    variant minus the base estimator (or any other summary `columns`), paired
    by partition (the same folds and test lamps); mean, SD over partitions
    (ddof 1) and relative change of the mean. Pairs missing from
    `summary_rows` are skipped."""
    by = {(r["band_set"], r["estimator"], r["surface"]): r for r in summary_rows}
    out = []
    for variant, base in pairs:
        for (bs, est, surf), r in sorted(by.items()):
            if est != variant or (bs, base, surf) not in by:
                continue
            row = {"band_set": bs, "surface": surf, "estimator": variant, "vs": base}
            out.append(_paired_by_partition(r, by[(bs, base, surf)], row, columns))
    return out
