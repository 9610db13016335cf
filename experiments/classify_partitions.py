"""Lamp-type classification of fixed designs over lamp partitions:
`python -m experiments.classify_partitions`.

Scores FIXED band sets -- the classification recommendation, the "spectral"
recommendation (`results/recommendation.json`) and every reference sensor --
on the classification evaluation scenes (every scored lamp x the default
surfaces x the 6S atmospheres when installed x Moon none/full/first quarter
x classes P1, P6, M1, M6: `bandopt.classify.TRAINING_SCENARIOS`, 97,776
scenes) with photon noise, over lamp partitions p = 0..P-1 (fold seed p:
nested lamp-grouped 3 x 2 folds, each scored lamp tested once per
partition; noise seed p). Estimators (`bandopt.classify.evaluate_band_set`):

- `knn`: one-vs-all KNN on centred log band ratios, k from the inner folds;
- `knn+models`: the same, trained also on `MODELLED_PER_CLASS` modelled lamps
  per rare class (physical lamp models calibrated on each fold's and inner
  fold's measured training lamps only; test lamps are measured ones);
- `inversion`: the physics-based inversion, surface unknown, Moon fitted;
- `inversion-moon`: the same, told each pixel's Moon brightness (known from
  the acquisition's time and place; `bandopt.classify.table_moon`) instead
  of fitting it: the Moon is the estimate's largest confounder
  (`make estimate-moon`);
- `inversion/class`, `inversion/measured` (the two recommended sets only, with
  `--surface-modes`): surface type known / measured by Sentinel-2 in daytime.

Per design x estimator: mean and SD (ddof 1) over partitions of level-2 and
level-1 macro F1; paired differences, ours minus each reference sensor on
the same partition, with their mean and SD. The band sets were chosen on
all lamps (the searches' final runs), so this measures the estimator's and
the lamp partition's spread for fixed designs, not the spread of the band
selection itself.

Writes `records.jsonl` (one line per finished (partition, design, estimator)
unit, appended as each finishes: an interrupted run keeps them and the next
run resumes from them unless `--fresh`), `summary.json`, `summary.csv`,
`paired.csv`, `f1_partitions.png`, `report.md` and `manifest.json` (its
config lists, per result row, whether modelled lamps were used).

Defaults and cost (measured, see report.md): the inversion is run for band
sets with more than one band only (with one band every pixel has the same
colour, the centred log ratio is 0 and the inversion's posterior is its
prior: `--one-band-inversion` runs them anyway), and the surface-knowledge
modes only with `--surface-modes` (they take the inversion's per-pixel path,
2-3x slower than surface unknown). `inversion-moon` runs for our designs and
reference sensors with at least `MOON_MIN_BANDS` bands (`--moon-all-designs`:
every multi-band design).

    python -m experiments.classify_partitions [--partitions 4] [--quick]
        [--surface-modes] [--one-band-inversion] [--moon-all-designs] [--fresh]
        [--out DIR]
"""

import argparse
import csv
import hashlib
import json
import os
import sys
import time
from collections.abc import Sequence
from pathlib import Path

import numpy as np


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
LEVELS = ("level2", "level1")
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


def log(msg: str, t0: float) -> None:
    print(f"[classify_partitions {time.perf_counter() - t0:8.1f} s] {msg}", flush=True)


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


# ------------------------------------------------------------------------------
# output


def _fmt(mean, sd, digits=3) -> str:
    if mean is None:
        return "-"
    return f"{mean:.{digits}f}" + ("" if sd is None else f" ± {sd:.{digits}f}")


def figure(rows: Sequence[dict], path: Path, partitions: int) -> None:
    """Macro F1 per design (x) and estimator (marker), mean with error bars of
    the SD over partitions; level 2 and level 1 panels."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    designs = list(dict.fromkeys(r["design"] for r in rows))
    ests = list(dict.fromkeys(r["estimator"] for r in rows))
    fig, axes = plt.subplots(
        2, 1, figsize=(max(7.0, 0.6 * len(designs) + 3), 7.5), sharex=True
    )
    marks = "os^Dv"
    width = 0.8 / max(len(ests), 1)
    for ax, lv in zip(axes, LEVELS, strict=True):
        for j, est in enumerate(ests):
            pts = [
                (designs.index(r["design"]), r) for r in rows if r["estimator"] == est
            ]
            x = np.array([i for i, _ in pts]) - 0.4 + width * (j + 0.5)
            y = [r[f"{lv}_macro_f1_mean"] for _, r in pts]
            e = [r[f"{lv}_macro_f1_sd"] or 0.0 for _, r in pts]
            ax.errorbar(
                x, y, yerr=e, fmt=marks[j % len(marks)], ms=4, capsize=2, label=est
            )
        ax.set_ylabel(f"{lv.replace('level', 'level-')} macro F1 [1]")
        ax.set_ylim(0, 1)
        ax.grid(axis="y", alpha=0.3)
    axes[0].legend(fontsize=8, ncol=len(ests))
    axes[-1].set_xticks(range(len(designs)), designs, rotation=45, ha="right")
    axes[-1].set_xlabel("design (band set)")
    fig.suptitle(
        f"Lamp-type macro F1, mean ± SD over {partitions} lamp partitions "
        "(fixed band sets, photon noise)",
        fontsize=10,
    )
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def _write_csv(path: Path, rows: Sequence[dict]) -> None:
    keys = list(dict.fromkeys(k for r in rows for k in r))
    with path.open("w", newline="") as fh:
        w = csv.DictWriter(fh, keys)
        w.writeheader()
        for r in rows:
            w.writerow(
                {
                    k: json.dumps(v) if isinstance(v, (list, dict)) else v
                    for k, v in r.items()
                }
            )


README_REFERENCES = ("nightsat", "sdgsat-1")
"""Reference sensors of the results/README.md section's paired table."""


def readme_text(summary: dict) -> str:
    """The `classify-partitions` section of results/README.md: macro F1 of
    every multi-band design (one-band sensors in one line) and the paired
    differences against `README_REFERENCES`, read from `summary`."""
    ests = list(summary["estimators"])
    lines = [
        "## Classification over lamp partitions (`results/classify_partitions/`, "
        "`make classify-partitions`)",
        "",
        f"Fixed band sets, {summary['n_scenes']:,} scenes, {summary['n_lamps']} "
        f"scored lamps, photon noise, {summary['partitions']} lamp partitions; "
        "macro F1 mean ± SD (ddof 1). The bands were chosen on all lamps, so the "
        "spread is the estimator's and the partition's, not the band selection's. "
        "`knn+models`: the KNN also trained on modelled lamps of rare classes "
        "(never scored)"
        + (
            "; `inversion-moon`: the inversion told each pixel's Moon brightness "
            "instead of fitting it"
            if "inversion-moon" in ests
            else ""
        )
        + ". Full tables: `report.md`. Generated from `summary.json`.",
        "",
        "| design | bands | level 2: " + " / ".join(ests) + " | level 1: "
        + " / ".join(ests) + " |",
        "|---|---|---|---|",
    ]
    by = {(r["design"], r["estimator"]): r for r in summary["rows"]}
    designs = list(dict.fromkeys(r["design"] for r in summary["rows"]))
    one_band = [d for d in designs if by[(d, ests[0])]["n_bands"] == 1]

    def cell(d, level):
        out = []
        for e in ests:
            r = by.get((d, e))
            if r is None:
                out.append("-")
                continue
            m, sd = r[f"{level}_macro_f1_mean"], r[f"{level}_macro_f1_sd"]
            out.append(f"{m:.3f} ± {sd:.3f}")
        return " / ".join(out)

    for d in designs:
        if d in one_band:
            continue
        n = by[(d, ests[0])]["n_bands"]
        lines.append(f"| {d} | {n} | {cell(d, 'level2')} | {cell(d, 'level1')} |")
    if one_band:
        r = by[(one_band[0], ests[0])]
        lines.append(
            f"| {len(one_band)} one-band sensors | 1 | "
            f"{r['level2_macro_f1_mean']:.3f} (knn) | "
            f"{r['level1_macro_f1_mean']:.3f} (knn) |"
        )
    lines += [
        "",
        "Paired differences, ours minus reference, same partition (level-2 macro "
        "F1):",
        "",
        "| ours | reference | " + " | ".join(ests) + " |",
        "|---|---|" + "---|" * len(ests),
    ]
    pairs = {
        (p["design"], p["reference"], p["estimator"]): p for p in summary["paired"]
    }
    for ours in dict.fromkeys(p["design"] for p in summary["paired"]):
        for ref in README_REFERENCES:
            cells = [
                (
                    f"{q['level2_diff_mean']:+.3f} ± {q['level2_diff_sd']:.3f}"
                    if (q := pairs.get((ours, ref, e)))
                    else "-"
                )
                for e in ests
            ]
            lines.append(f"| {ours} | {ref} | " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"


def report_text(summary: dict) -> str:
    rows, paired = summary["rows"], summary["paired"]
    ests = list(dict.fromkeys(r["estimator"] for r in rows))
    designs = list(dict.fromkeys(r["design"] for r in rows))
    by = {(r["design"], r["estimator"]): r for r in rows}
    lines = [
        "# Lamp-type classification over lamp partitions",
        "",
        f"Fixed band sets scored on {summary['n_scenes']:,} scenes "
        f"({summary['n_lamps']} scored lamps) with photon noise over "
        f"{summary['partitions']} lamp partitions (fold seeds and noise seeds "
        f"{summary['partition_ids']}); macro F1 mean ± SD (ddof 1) over "
        "partitions. Each partition tests every scored lamp once (nested "
        "lamp-grouped 3 x 2 folds).",
        "",
        "**What the spread means.** The band sets were chosen on all lamps "
        "(the searches' final runs), so scoring them over partitions measures "
        "the estimator's and the lamp partition's spread for fixed designs, "
        "not the spread of the band selection (a nested search per partition "
        "would).",
        "",
        f"Estimators: {', '.join(ests)}. `knn+models`: the KNN also trained on "
        f"{summary['modelled_per_class']} modelled lamps per rare class "
        f"(asked: {', '.join(summary['modelled_classes'])}; a class with fewer "
        "than 2 measured training lamps in a fold gets none, so classes "
        "without scored lamps never do; got lamps, outer folds over all units: "
        + ", ".join(f"{c} {n}" for c, n in summary["modelled_classes_added"].items())
        + "), calibrated on each fold's (and inner fold's) measured training "
        "lamps only, never scored. Every other row trains on measured lamps "
        "only.",
        "",
    ]
    for lv in LEVELS:
        lines += [
            f"## {lv.replace('level', 'Level ')} macro F1",
            "",
            "| design | bands | " + " | ".join(ests) + " |",
            "|---|---|" + "---|" * len(ests),
        ]
        for d in designs:
            nb = next(r["n_bands"] for r in rows if r["design"] == d)
            cells = [
                _fmt(by[(d, e)][f"{lv}_macro_f1_mean"], by[(d, e)][f"{lv}_macro_f1_sd"])
                if (d, e) in by
                else "-"
                for e in ests
            ]
            lines.append(f"| {d} | {nb} | " + " | ".join(cells) + " |")
        lines.append("")
    lines += [
        "## Paired differences (ours minus reference, same partition)",
        "",
        "Mean ± SD (ddof 1) over partitions of the difference in macro F1.",
        "",
        "| ours | reference | estimator | level 2 | level 1 |",
        "|---|---|---|---|---|",
    ]
    for r in paired:
        lines.append(
            f"| {r['design']} | {r['reference']} | {r['estimator']} | "
            f"{_fmt(r['level2_diff_mean'], r['level2_diff_sd'])} | "
            f"{_fmt(r['level1_diff_mean'], r['level1_diff_sd'])} |"
        )
    lines.append("")
    if summary["dropped"]:
        lines += ["## Not run", ""]
        for d in summary["dropped"]:
            lines.append(f"- {d['design']} / {d['estimator']}: {d['reason']}")
        lines.append("")
    t = summary["timing"]
    lines += [
        "## Cost",
        "",
        f"{t['units']} units; their scoring took {t['unit_wall_s'] / 60:.1f} min "
        "in all (mean per unit: "
        + ", ".join(f"{k} {v:.0f} s" for k, v in t["mean_unit_s"].items())
        + "; the first `knn+models` unit of a process also fits the lamp "
        f"models); the last invocation scored {t['units_this_run']} of them "
        f"in {t['this_run_s'] / 60:.1f} min. Times are the machine's at the "
        "time (manifest.json), not a benchmark. Units computed by code "
        f"{', '.join(c[:7] for c in summary['git_commits'])}.",
        "",
    ]
    return "\n".join(lines)


# ------------------------------------------------------------------------------
# run


def _bands_sha(bands, grid) -> str:
    r = np.asarray(bands.response(np.asarray(grid)), float)
    return hashlib.sha1(np.round(r, 9).tobytes()).hexdigest()[:16]


def _table_signature(table) -> dict:
    cfg = json.dumps(table.config, sort_keys=True, default=str)
    return {
        "n_rows": table.n_rows,
        "n_lamps": len(table.lamp_ids),
        "config_sha": hashlib.sha1(cfg.encode()).hexdigest()[:16],
    }


def _designs(names, results_dir):
    from bandopt.results import recommended_band_set
    from bandopt.sensor import reference_sensor

    out = {}
    for name in names:
        if name in OURS:
            b = recommended_band_set(name, results_dir=results_dir)
            if b is None:
                raise SystemExit(
                    f"{Path(results_dir) / 'recommendation.json'}: no key {name!r} "
                    "(run its experiment first)."
                )
        else:
            b = reference_sensor(name)
        out[name] = b
    return out


def _read_records(path: Path, settings: dict, t0: float) -> list[dict]:
    """Finished units of an earlier (interrupted) run with the same settings;
    an unreadable line (a write cut short) is dropped and the file rewritten
    without it, so the next appended unit starts on a line of its own.
    Refuses records of other settings (naming the line and the field)."""
    if not path.is_file():
        return []
    out, good, bad = [], [], 0
    for i, line in enumerate(path.read_text().splitlines()):
        try:
            r = json.loads(line)
        except json.JSONDecodeError:
            log(f"{path}:{i + 1}: unreadable line dropped (interrupted write)", t0)
            bad += 1
            continue
        for key, want in settings.items():
            if r.get("settings", {}).get(key) != want:
                raise SystemExit(
                    f"{path}:{i + 1}: finished unit of a run with other settings "
                    f"({key}: {r.get('settings', {}).get(key)!r}, now {want!r}); "
                    "rerun with --fresh or another --out."
                )
        out.append(r)
        good.append(line)
    if bad:
        tmp = path.with_suffix(".tmp")
        tmp.write_text("".join(f"{x}\n" for x in good))
        tmp.replace(path)
    return out


def main(argv=None) -> int:
    from bandopt import configure

    configure()
    from bandopt.classify import (
        TRAINING_SCENARIOS,
        available_atmospheres,
        evaluate_band_set,
    )
    from bandopt.datasets.lamps import library
    from bandopt.forward import scenario_table
    from bandopt.inversion import MODELLED_CLASSES
    from bandopt.provenance import git_commit, write_manifest
    from bandopt.results import RESULTS_DIR
    from bandopt.scene import build_scenarios
    from bandopt.sensor import REFERENCE_SENSORS

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument(
        "--partitions",
        type=int,
        default=4,
        help="lamp partitions, fold and noise seeds 0..P-1 (default 4)",
    )
    ap.add_argument(
        "--quick",
        action="store_true",
        help="smoke test: 2 partitions, 2 designs, 27 lamps on one surface, "
        "surface modes on (default off)",
    )
    ap.add_argument(
        "--surface-modes",
        action="store_true",
        help="also the inversion with the surface class known / measured by "
        "Sentinel-2, for our two designs (default off: ~2-3x the inversion's "
        "cost each)",
    )
    ap.add_argument(
        "--one-band-inversion",
        action="store_true",
        help="also the inversion for one-band sensors (default off: its "
        "posterior is its prior)",
    )
    ap.add_argument(
        "--moon-all-designs",
        action="store_true",
        help="also the told-Moon inversion for reference sensors with fewer than "
        f"{MOON_MIN_BANDS} bands (default off: 3-5 min per unit)",
    )
    ap.add_argument(
        "--fresh",
        action="store_true",
        help="discard finished units in the output folder (default: resume)",
    )
    ap.add_argument(
        "--out",
        default=None,
        metavar="DIR",
        help="output folder (default results/classify_partitions; --quick: "
        "results/classify_partitions/_scratch/quick)",
    )
    args = ap.parse_args(argv)
    if args.partitions < 1:
        raise SystemExit(f"--partitions {args.partitions}: must be >= 1.")
    t0 = time.perf_counter()
    results_dir = Path(RESULTS_DIR)
    default_out = results_dir / "classify_partitions"
    out = Path(
        args.out or (default_out / "_scratch" / "quick" if args.quick else default_out)
    )
    out.mkdir(parents=True, exist_ok=True)

    if args.quick:
        parts = QUICK["partitions"]
        names = list(QUICK["designs"])
        lib = library().select(scored_only=True)
        per: dict[str, list[str]] = {}
        for r in lib.records:
            per.setdefault(r.level2, []).append(r.id)
        ids = [i for c in sorted(per) for i in per[c][: QUICK["lamps_per_class"]]]
        scen = build_scenarios(
            lamps=ids,
            surfaces=("asphalt",),
            atmospheres=("none",),
            moons=(None,),
            classes=("P1", "P6"),
        )
        n_model = QUICK["modelled_per_class"]
        model_classes = tuple(QUICK["modelled_classes"])
    else:
        parts = args.partitions
        names = [*OURS, *REFERENCE_SENSORS]
        scen = build_scenarios(
            scored_only=True, atmospheres=available_atmospheres(), **TRAINING_SCENARIOS
        )
        n_model = MODELLED_PER_CLASS
        model_classes = tuple(MODELLED_CLASSES)
    table = scenario_table(scen)
    designs = _designs(names, results_dir)
    shas = {n: _bands_sha(b, table.wavelength_nm) for n, b in designs.items()}
    log(
        f"{table.n_rows} scenes, {len(table.lamp_ids)} lamps, {len(designs)} "
        f"designs, {parts} partitions -> {out}",
        t0,
    )
    settings = {
        "table": _table_signature(table),
        "noise": True,
        "modelled_per_class": n_model,
        "modelled_classes": list(model_classes),
    }
    rec_path = out / "records.jsonl"
    if args.fresh and rec_path.is_file():
        rec_path.unlink()
    records = _read_records(rec_path, settings, t0)
    for r in records:
        if r["design"] in shas and r["bands_sha"] != shas[r["design"]]:
            raise SystemExit(
                f"{rec_path}: design {r['design']!r} had other bands in a finished "
                "unit (bands_sha differs); rerun with --fresh."
            )
    units, dropped = plan_units(
        {n: len(b) for n, b in designs.items()},
        parts,
        surface_modes=args.surface_modes or args.quick,  # the smoke test runs all
        one_band_inversion=args.one_band_inversion,
        moon_all_designs=args.moon_all_designs,
    )
    done = {(r["partition"], r["design"], r["estimator"]) for r in records}
    todo = [u for u in units if u not in done]
    log(f"{len(units)} units, {len(units) - len(todo)} finished earlier", t0)
    commit = git_commit()
    spent: dict[str, list[float]] = {}  # unit times, earlier runs' too (ETA)
    for r in records:
        spent.setdefault(r["estimator"], []).append(r["wall_s"])
    for j, (p, name, est) in enumerate(todo):
        kw = dict(ESTIMATORS[est])
        if "modelled_per_class" in kw:
            kw["modelled_per_class"] = n_model
            kw["modelled_classes"] = model_classes
        t1 = time.perf_counter()
        res = evaluate_band_set(
            table, designs[name], noise=True, seed=p, fold_seed=p, **kw
        )
        wall = time.perf_counter() - t1
        rec = unit_record(
            res, partition=p, design=name, estimator=est, bands_sha=shas[name]
        )
        rec.update(
            n_bands=len(designs[name]),
            wall_s=wall,
            git_commit=commit,
            settings=settings,
        )
        with rec_path.open("a") as fh:
            fh.write(json.dumps(rec) + "\n")
            fh.flush()
            os.fsync(fh.fileno())
        records.append(rec)
        spent.setdefault(est, []).append(wall)
        overall = float(np.mean([w for v in spent.values() for w in v]))
        left = sum(
            float(np.mean(spent[e])) if e in spent else overall
            for _, _, e in todo[j + 1 :]
        )
        log(
            f"p{p} {name} {est}: level-2 F1 {rec['level2_macro_f1']:.3f}, level-1 "
            f"{rec['level1_macro_f1']:.3f} ({wall:.0f} s; {j + 1}/{len(todo)}, "
            f"~{left / 60:.0f} min left)",
            t0,
        )

    keep = set(units)
    final = [
        r for r in records if (r["partition"], r["design"], r["estimator"]) in keep
    ]
    rows = aggregate(final)
    ours = [n for n in names if n in OURS]
    refs = [n for n in names if n not in OURS]
    paired = paired_differences(final, ours, refs)
    by_est: dict[str, list[float]] = {}
    for r in final:
        by_est.setdefault(r["estimator"], []).append(r["wall_s"])
    summary = {
        "experiment": "experiments.classify_partitions",
        "quick": args.quick,
        "n_scenes": table.n_rows,
        "n_lamps": len(table.lamp_ids),
        "scenarios": table.config,
        "partitions": parts,
        "partition_ids": list(range(parts)),
        "seeds": "partition p: fold seed p, noise seed p (measured rows "
        "noise_draws(p); modelled rows modelled_noise_key(p, stream); modelled "
        "lamp samples and the Sentinel-2 draw seed p)",
        "estimators": {
            e: ESTIMATORS[e] for e in dict.fromkeys(r["estimator"] for r in rows)
        },
        "modelled_per_class": n_model,
        "modelled_classes": list(model_classes),
        "modelled_classes_added": modelled_classes_added(final),
        "designs": {
            n: {
                "n_bands": len(b),
                "source": "results/recommendation.json"
                if n in OURS
                else "reference sensor",
                "bands_sha": shas[n],
            }
            for n, b in designs.items()
        },
        "note": "band sets chosen on all lamps: the spread over partitions is "
        "the estimator's and the lamp partition's for fixed designs, not the "
        "band selection's",
        "sd": "sample SD over partitions (ddof 1)",
        "rows": rows,
        "paired": paired,
        "dropped": dropped,
        "git_commits": sorted({r["git_commit"] or "unknown" for r in final}),
        "timing": {
            "units": len(final),
            "unit_wall_s": float(sum(r["wall_s"] for r in final)),
            "mean_unit_s": {e: float(np.mean(v)) for e, v in by_est.items()},
            "this_run_s": time.perf_counter() - t0,
            "units_this_run": len(todo),
        },
    }
    (out / "summary.json").write_text(json.dumps(summary, indent=2) + "\n")
    _write_csv(out / "summary.csv", rows)
    _write_csv(out / "paired.csv", paired)
    figure(rows, out / "f1_partitions.png", parts)
    (out / "report.md").write_text(report_text(summary))
    if args.out is None and not args.quick:
        from bandopt.results import update_readme_section

        update_readme_section(
            "classify-partitions",
            readme_text(summary),
            heading="## Classification over lamp partitions",
        )
    used = sorted({r["estimator"] for r in rows if r["modelled_per_class"] > 0})
    lamp_models = (
        f"used in training only: {n_model} modelled lamps per class of "
        f"{list(model_classes)} (bandopt.lampmodels, calibrated on each fold's "
        f"measured training lamps) in the rows of {used}; never scored (test "
        "lamps are measured)"
        if used
        else None
    )
    write_manifest(
        out,
        seed=None,
        **({"lamp_models": lamp_models} if lamp_models else {}),
        config={
            "partitions": parts,
            "quick": args.quick,
            "settings": settings,
            "surface_modes": args.surface_modes,
            "one_band_inversion": args.one_band_inversion,
            "moon_all_designs": args.moon_all_designs,
            "rows": [
                {
                    "design": r["design"],
                    "estimator": r["estimator"],
                    "modelled_lamps_used": r["modelled_per_class"] > 0,
                    "modelled_per_class": r["modelled_per_class"],
                    "surface_knowledge": r["surface_knowledge"],
                    "moon": r["moon"],
                }
                for r in rows
            ],
            "seeds": summary["seeds"],
        },
    )
    log(f"done: {len(final)} units -> {out}", t0)
    return 0


if __name__ == "__main__":
    sys.exit(main())
