"""The plan and the arithmetic of `classification_partitions`: its
estimators and designs, which (partition, design, estimator) units run and
in what order, one record per unit, and the mean, SD and paired differences
over partitions (pure functions of the records)."""

import json
from collections.abc import Sequence

import numpy as np

from ._partitions_report import LEVELS


OURS = ("classification", "spectral")
"""Our designs: the keys of `results/recommendation.json`."""
MODELLED_PER_CLASS = 5
"""Modelled training lamps per rare class of estimator `knn+models`."""
ESTIMATORS = {
    "knn": {"estimator": "knn"},
    "knn+models": {"estimator": "knn", "modelled_per_class": MODELLED_PER_CLASS},
    "inversion": {"estimator": "inversion", "surface_mode": "unknown"},
    "inversion-moon": {
        "estimator": "inversion",
        "surface_mode": "unknown",
        "moon_known": True,
    },
    "inversion/class": {"estimator": "inversion", "surface_mode": "class"},
    "inversion/measured": {"estimator": "inversion", "surface_mode": "measured"},
}
"""Estimator label -> keyword arguments of `evaluate_band_set`."""
SURFACE_ESTIMATORS = ("inversion/class", "inversion/measured")
MOON_MIN_BANDS = 4
"""`inversion-moon` runs for our designs and for reference sensors with at
least this many bands (SDGSAT-1, Nightsat) by default: the 3-band cameras
score level-2 macro F1 <= 0.40 with every other estimator, and each unit
costs 3-5 min (`--moon-all-designs` runs them too)."""
QUICK = {
    "partitions": 2,
    "designs": ("classification", "sdgsat-1"),
    "lamps_per_class": 3,
    "modelled_per_class": 2,
    "modelled_classes": ("mercury",),
}
"""The smoke test: 2 partitions, our classification set and one reference,
3 lamps per scored class on asphalt without atmosphere or Moon (classes P1,
P6), 2 modelled mercury lamps (its 4 measured lamps fit in seconds)."""


# ------------------------------------------------------------------------------
# the plan (pure)


def plan_units(
    designs: dict[str, int],
    partitions: int,
    *,
    surface_modes: bool = False,
    one_band_inversion: bool = False,
    ours: Sequence[str] = OURS,
    moon_all_designs: bool = False,
) -> tuple[list[tuple[int, str, str]], list[dict]]:
    """The (partition, design, estimator) units to score and the units left
    out with the reason. `designs`: name -> band count. Order: the KNN units
    (seconds each) of every partition first, then the inversion's (minutes
    each: the Moon fitted, then told), then the surface-knowledge modes,
    each stage partition by partition, so a run cut short has the cheap
    estimators complete over every partition."""
    run, dropped = [], []
    for name, n_bands in designs.items():
        for est in ESTIMATORS:
            if est in SURFACE_ESTIMATORS and name not in ours:
                continue  # surface knowledge: our two designs only, by design
            reason = None
            if est in SURFACE_ESTIMATORS and not surface_modes:
                reason = "surface-knowledge modes off (--surface-modes)"
            elif est.startswith("inversion") and n_bands < 2 and not one_band_inversion:
                reason = (
                    "one band: every pixel has the same colour, the inversion's "
                    "posterior is its prior (--one-band-inversion)"
                )
            elif (
                ESTIMATORS[est].get("moon_known")
                and name not in ours
                and n_bands < MOON_MIN_BANDS
                and not moon_all_designs
            ):
                reason = (
                    f"told-Moon inversion for our designs and sensors with >= "
                    f"{MOON_MIN_BANDS} bands only (--moon-all-designs)"
                )
            if reason:
                dropped.append({"design": name, "estimator": est, "reason": reason})
            else:
                run.append((name, est))
    units = [
        (p, name, est)
        for stage in range(4)
        for p in range(partitions)
        for name, est in run
        if _stage(est) == stage
    ]
    return units, dropped


def _stage(estimator: str) -> int:
    if estimator in SURFACE_ESTIMATORS:
        return 3
    if ESTIMATORS[estimator].get("moon_known"):
        return 2
    return 1 if ESTIMATORS[estimator]["estimator"] == "inversion" else 0


# ------------------------------------------------------------------------------
# aggregation (pure)


def _sd(values) -> float | None:
    """Sample SD (ddof 1) over partitions; None for fewer than two."""
    v = np.asarray(values, float)
    return float(np.std(v, ddof=1)) if v.size > 1 else None


def _moon(rec: dict) -> str:
    """What a record's estimator knew of the Moon: "known per pixel", "fitted"
    (the inversion) or "unknown" (the KNN); records from before the field
    existed had the Moon fitted or unknown."""
    if "moon" in rec:
        return rec["moon"]
    return "fitted" if rec.get("classifier") == "inversion" else "unknown"


def aggregate(records: Sequence[dict]) -> list[dict]:
    """Per (design, estimator), in first-seen order: the number of
    partitions, per-partition level-2/level-1 macro F1 (by partition), their
    mean and SD (ddof 1), and what the rows used (`modelled_per_class`,
    `surface_knowledge`, band count). Raises `ValueError` if a group holds a
    partition twice or rows with different settings."""
    groups: dict[tuple[str, str], list[dict]] = {}
    for r in records:
        groups.setdefault((r["design"], r["estimator"]), []).append(r)
    out = []
    for (design, est), recs in groups.items():
        parts = [r["partition"] for r in recs]
        if len(set(parts)) != len(parts):
            raise ValueError(f"{design} / {est}: partition repeated in {parts}.")
        for key in ("modelled_per_class", "surface_knowledge", "n_bands"):
            if len({json.dumps(r[key]) for r in recs}) > 1:
                raise ValueError(f"{design} / {est}: rows differ in {key!r}.")
        recs = sorted(recs, key=lambda r: r["partition"])
        row = {
            "design": design,
            "estimator": est,
            "n_bands": recs[0]["n_bands"],
            "modelled_per_class": recs[0]["modelled_per_class"],
            "surface_knowledge": recs[0]["surface_knowledge"],
            "moon": _moon(recs[0]),
            "partitions": len(recs),
            "partition_ids": [r["partition"] for r in recs],
        }
        for lv in LEVELS:
            v = [r[f"{lv}_macro_f1"] for r in recs]
            row[f"{lv}_macro_f1_mean"] = float(np.mean(v))
            row[f"{lv}_macro_f1_sd"] = _sd(v)
            row[f"{lv}_macro_f1_per_partition"] = v
        out.append(row)
    return out


def paired_differences(
    records: Sequence[dict], ours: Sequence[str], references: Sequence[str]
) -> list[dict]:
    """Ours minus each reference, per estimator both have, paired by
    partition (only partitions both have): per level the per-partition
    differences of macro F1, their mean and SD (ddof 1)."""
    by = {(r["design"], r["estimator"], r["partition"]): r for r in records}
    ests = list(dict.fromkeys(r["estimator"] for r in records))
    out = []
    for a in ours:
        for b in references:
            if a == b:
                continue
            for est in ests:
                parts = sorted(
                    p for (d, e, p) in by if d == a and e == est and (b, est, p) in by
                )
                if not parts:
                    continue
                row = {
                    "design": a,
                    "reference": b,
                    "estimator": est,
                    "partitions": len(parts),
                    "partition_ids": parts,
                }
                for lv in LEVELS:
                    d = [
                        by[(a, est, p)][f"{lv}_macro_f1"]
                        - by[(b, est, p)][f"{lv}_macro_f1"]
                        for p in parts
                    ]
                    row[f"{lv}_diff_mean"] = float(np.mean(d))
                    row[f"{lv}_diff_sd"] = _sd(d)
                    row[f"{lv}_diff_per_partition"] = d
                out.append(row)
    return out


def modelled_classes_added(records: Sequence[dict]) -> dict[str, int]:
    """Per class, the outer folds (over every unit with modelled lamps) in
    which it got modelled training lamps."""
    out: dict[str, int] = {}
    for r in records:
        for f in r.get("modelled_added_per_fold", []):
            for c, n in f["added"].items():
                if n:
                    out[c] = out.get(c, 0) + 1
    return dict(sorted(out.items()))


def unit_record(res, *, partition: int, design: str, estimator: str, bands_sha: str):
    """One records.jsonl line from an `evaluate_band_set` result (JSON-ready):
    macro F1, accuracy, fold mean/SD and the reject coverage per level, the
    model choice per fold, and what the estimator was given."""
    cfg = dict(res.config)
    kw = ESTIMATORS[estimator]
    rec = {
        "partition": partition,
        "fold_seed": cfg["fold_seed"],
        "noise_seed": cfg["seed"],
        "design": design,
        "bands_sha": bands_sha,
        "estimator": estimator,
        "classifier": kw["estimator"],
        "surface_knowledge": cfg.get("surface", "unknown"),
        "moon": _moon({"classifier": kw["estimator"], **cfg}),
        "modelled_per_class": int(cfg.get("modelled_per_class", 0)),
    }
    for lv in LEVELS:
        s = res.level(lv)
        rec[f"{lv}_macro_f1"] = s.macro_f1
        rec[f"{lv}_accuracy"] = s.accuracy
        rec[f"{lv}_macro_f1_fold_mean"] = s.macro_f1_fold_mean
        rec[f"{lv}_macro_f1_fold_sd"] = s.macro_f1_fold_sd
        rec[f"{lv}_reject_coverage"] = s.reject["coverage"]
        rec[f"{lv}_model_choice"] = [f.get("k", f.get("sigma_rel")) for f in s.folds]
    if rec["modelled_per_class"]:
        rec["modelled_added_per_fold"] = [
            {"outer": f["outer"], "added": f["added"]}
            for f in cfg["modelled_lamps"]["per_fold"]
        ]
    return rec
