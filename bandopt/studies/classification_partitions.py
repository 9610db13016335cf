"""Lamp-type classification of fixed designs over lamp partitions, run by
`make classify-partitions` (`python -m experiments.classify_partitions`).

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
  `surface_modes`): surface type known / measured by Sentinel-2 in daytime.

Per design x estimator: mean and SD (ddof 1) over partitions of level-2 and
level-1 macro F1; paired differences, ours minus each reference sensor on
the same partition, with their mean and SD. The band sets were chosen on
all lamps (the searches' final runs), so this measures the estimator's and
the lamp partition's spread for fixed designs, not the spread of the band
selection itself.

- `_partitions`: the estimators, the plan of units, the records and their
  mean, SD and paired differences;
- `_partitions_report`: the figure, `report.md` and the README section.

Writes `records.jsonl` (one line per finished (partition, design, estimator)
unit, appended as each finishes: an interrupted run keeps them and the next
run resumes from them unless `fresh`), `summary.json`, `summary.csv`,
`paired.csv`, `f1_partitions.png`, `report.md` and `manifest.json` (its
config lists, per result row, whether modelled lamps were used).

Defaults and cost (measured, see report.md): the inversion is run for band
sets with more than one band only (with one band every pixel has the same
colour, the centred log ratio is 0 and the inversion's posterior is its
prior: `one_band_inversion` runs them anyway), and the surface-knowledge
modes only with `surface_modes` (they take the inversion's per-pixel path,
2-3x slower than surface unknown). `inversion-moon` runs for our designs and
reference sensors with at least `MOON_MIN_BANDS` bands (`moon_all_designs`:
every multi-band design).
"""

import hashlib
import json
import os
import time
from pathlib import Path

import numpy as np

from ..classify import TRAINING_SCENARIOS, available_atmospheres, evaluate_band_set
from ..datasets.lamps import library
from ..forward import scenario_table
from ..inversion import MODELLED_CLASSES
from ..provenance import git_commit, write_manifest
from ..results import RESULTS_DIR, recommended_band_set, update_readme_section
from ..scene import build_scenarios
from ..sensor import REFERENCE_SENSORS, reference_sensor
from ..strict_json import strict_dumps
from ._partitions import (
    ESTIMATORS as ESTIMATORS,
    MODELLED_PER_CLASS as MODELLED_PER_CLASS,
    MOON_MIN_BANDS as MOON_MIN_BANDS,
    OURS as OURS,
    QUICK as QUICK,
    SURFACE_ESTIMATORS as SURFACE_ESTIMATORS,
    aggregate as aggregate,
    modelled_classes_added as modelled_classes_added,
    paired_differences as paired_differences,
    plan_units as plan_units,
    unit_record as unit_record,
)
from ._partitions_report import (
    LEVELS as LEVELS,
    README_REFERENCES as README_REFERENCES,
    figure as figure,
    readme_text as readme_text,
    report_text as report_text,
)
from ._units import write_csv


def log(msg: str, t0: float) -> None:
    """Progress line on stdout, `[classify_partitions seconds since t0] msg`."""
    print(f"[classify_partitions {time.perf_counter() - t0:8.1f} s] {msg}", flush=True)


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


def _setup(quick: bool, partitions: int):
    """(partitions, design names, scenes, modelled lamps per class, modelled
    classes): `QUICK`'s smoke test, or every design on the classification
    evaluation scenes."""
    if not quick:
        scen = build_scenarios(
            scored_only=True, atmospheres=available_atmospheres(), **TRAINING_SCENARIOS
        )
        names = [*OURS, *REFERENCE_SENSORS]
        return partitions, names, scen, MODELLED_PER_CLASS, tuple(MODELLED_CLASSES)
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
    return (
        QUICK["partitions"],
        list(QUICK["designs"]),
        scen,
        QUICK["modelled_per_class"],
        tuple(QUICK["modelled_classes"]),
    )


def _score(todo, records, table, designs, shas, settings, rec_path, t0) -> None:
    """Score the units `todo`, appending each record to `records` and (synced)
    to `rec_path` as it finishes; logs the time left, estimated from the unit
    times of this and earlier runs."""
    n_model = settings["modelled_per_class"]
    commit = git_commit()
    spent: dict[str, list[float]] = {}  # unit times, earlier runs' too (ETA)
    for r in records:
        spent.setdefault(r["estimator"], []).append(r["wall_s"])
    for j, (p, name, est) in enumerate(todo):
        kw = dict(ESTIMATORS[est])
        if "modelled_per_class" in kw:
            kw["modelled_per_class"] = n_model
            kw["modelled_classes"] = tuple(settings["modelled_classes"])
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
            fh.write(strict_dumps(rec, indent=None) + "\n")
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


def _summary(final, names, table, parts, designs, shas, dropped, settings, quick):
    """`summary.json` of the finished units `final` (timing without the
    invocation's own: `run` adds it)."""
    rows = aggregate(final)
    ours = [n for n in names if n in OURS]
    refs = [n for n in names if n not in OURS]
    by_est: dict[str, list[float]] = {}
    for r in final:
        by_est.setdefault(r["estimator"], []).append(r["wall_s"])
    return {
        "experiment": "experiments.classify_partitions",
        "quick": quick,
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
        "modelled_per_class": settings["modelled_per_class"],
        "modelled_classes": settings["modelled_classes"],
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
        "paired": paired_differences(final, ours, refs),
        "dropped": dropped,
        "git_commits": sorted({r["git_commit"] or "unknown" for r in final}),
        "timing": {
            "units": len(final),
            "unit_wall_s": float(sum(r["wall_s"] for r in final)),
            "mean_unit_s": {e: float(np.mean(v)) for e, v in by_est.items()},
        },
    }


def _lamp_models(rows, settings) -> str | None:
    """The manifest's note on modelled training lamps (None: none used)."""
    used = sorted({r["estimator"] for r in rows if r["modelled_per_class"] > 0})
    if not used:
        return None
    return (
        f"used in training only: {settings['modelled_per_class']} modelled lamps "
        f"per class of {settings['modelled_classes']} (bandopt.lampmodels, "
        "calibrated on each fold's measured training lamps) in the rows of "
        f"{used}; never scored (test lamps are measured)"
    )


def run(
    out: Path | str | None = None,
    *,
    partitions: int = 4,
    quick: bool = False,
    surface_modes: bool = False,
    one_band_inversion: bool = False,
    moon_all_designs: bool = False,
    fresh: bool = False,
) -> int:
    """Score the designs over `partitions` lamp partitions into `out` (module
    docstring), resuming from its `records.jsonl` unless `fresh`; returns the
    exit status. `quick`: `QUICK`'s smoke test (surface modes on). Default
    `out`: results/classify_partitions, whose run also rewrites the
    `classify-partitions` section of results/README.md (`quick`:
    results/classify_partitions/_scratch/quick)."""
    if partitions < 1:
        raise ValueError(f"partitions {partitions}: must be >= 1.")
    t0 = time.perf_counter()
    results_dir = Path(RESULTS_DIR)
    default_out = results_dir / "classify_partitions"
    to = Path(out or (default_out / "_scratch" / "quick" if quick else default_out))
    to.mkdir(parents=True, exist_ok=True)
    parts, names, scen, n_model, model_classes = _setup(quick, partitions)
    table = scenario_table(scen)
    designs = _designs(names, results_dir)
    shas = {n: _bands_sha(b, table.wavelength_nm) for n, b in designs.items()}
    log(
        f"{table.n_rows} scenes, {len(table.lamp_ids)} lamps, {len(designs)} "
        f"designs, {parts} partitions -> {to}",
        t0,
    )
    settings = {
        "table": _table_signature(table),
        "noise": True,
        "modelled_per_class": n_model,
        "modelled_classes": list(model_classes),
    }
    rec_path = to / "records.jsonl"
    if fresh and rec_path.is_file():
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
        surface_modes=surface_modes or quick,  # the smoke test runs all
        one_band_inversion=one_band_inversion,
        moon_all_designs=moon_all_designs,
    )
    done = {(r["partition"], r["design"], r["estimator"]) for r in records}
    todo = [u for u in units if u not in done]
    log(f"{len(units)} units, {len(units) - len(todo)} finished earlier", t0)
    _score(todo, records, table, designs, shas, settings, rec_path, t0)

    keep = set(units)
    final = [
        r for r in records if (r["partition"], r["design"], r["estimator"]) in keep
    ]
    summary = _summary(
        final, names, table, parts, designs, shas, dropped, settings, quick
    )
    summary["timing"].update(
        this_run_s=time.perf_counter() - t0, units_this_run=len(todo)
    )
    rows = summary["rows"]
    (to / "summary.json").write_text(strict_dumps(summary, indent=2) + "\n")
    write_csv(to / "summary.csv", rows)
    write_csv(to / "paired.csv", summary["paired"])
    figure(rows, to / "f1_partitions.png", parts)
    (to / "report.md").write_text(report_text(summary))
    if out is None and not quick:
        update_readme_section(
            "classify-partitions",
            readme_text(summary),
            heading="## Classification over lamp partitions",
        )
    lamp_models = _lamp_models(rows, settings)
    write_manifest(
        to,
        seed=None,
        **({"lamp_models": lamp_models} if lamp_models else {}),
        config={
            "partitions": parts,
            "quick": quick,
            "settings": settings,
            "surface_modes": surface_modes,
            "one_band_inversion": one_band_inversion,
            "moon_all_designs": moon_all_designs,
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
    log(f"done: {len(final)} units -> {to}", t0)
    return 0
