"""Lamp-type classification, run by `make classify` (`python -m
experiments.classify`): how many bands, which, how well they classify
against the reference sensors, and what surface, atmosphere and Moon do to
the identification and to the LER/G/CCT estimates.

Writes into its output folder (default `results/classify/`):

- `summary.json`: every number below, with the configuration and budgets;
- `band_count.csv` + `f1_vs_band_count.png`: nested outer-fold macro F1 against
  the band count for the nlopt search and the soft-NN surrogate (bands searched
  inside each outer fold, judged on its test lamps), with reference sensors;
- `f1_per_class.csv` + `f1_per_class.png`: F1 per lamp type for 2, 3, 4 bands
  (thesis Table 4.2 / Figure 4.5);
- `confusion_level2.csv` + `confusion_level2.png`: level-2 confusion matrix of the
  recommended band set (thesis Table 4.3), `confusion_level1.csv`;
- `reject.csv` + `reject.png`: the reject option's coverage and accuracy;
- `reference_sensors.csv` + `reference_sensors.png`: every reference sensor, with
  and without photon noise;
- `influence_identification.csv` + `.png`: train on one surface / atmosphere /
  Moon state, test on the same and on the others (F1 drop);
- `influence_estimates.csv` + `.png`: the same for the LER/G/CCT estimators of
  `bandopt.estimate` (class-balanced MAE increase);
- `lamp_accuracy.csv`, `report.md` (`_classification_report`),
  `manifest.json`; and, default output only, the key "classification" of
  `results/recommendation.json`.

Budgets (`BUDGET`; `QUICK_BUDGET` shrinks them): nlopt GN_CRS2_LM 300
evaluations per search, optimistix BFGS 40 steps on the surrogate, n = 2..6,
3 outer folds.
"""

import json
import time
from pathlib import Path

import numpy as np

from ..classify import (
    TRAINING_SCENARIOS,
    SearchBox,
    available_atmospheres,
    choose_band_count,
    evaluate_band_set,
    influence_estimates,
    influence_identification,
    nlopt_search,
    outer_splits,
    search_data,
    summary as band_set_summary,
    surrogate_search,
)
from ..forward import scenario_table
from ..provenance import write_manifest
from ..results import RESULTS_DIR, recommended_band_set, update_recommendation
from ..scene import build_scenarios
from ..sensor import REFERENCE_SENSORS, reference_sensor
from ..strict_json import strict_dumps
from ._classification_report import (
    GOAL_MARGIN as GOAL_MARGIN,
    figures as figures,
    write_report as write_report,
)
from ._units import write_csv


BUDGET = {
    "nlopt_algorithm": "crs2",
    "nlopt_max_evals": 300,
    "surrogate_max_steps": 40,
    "band_counts": [2, 3, 4, 5, 6],
    "noise_seed": 0,
    "fold_seed": 0,
    "search_seed": 0,
}
"""The search budgets and seeds of a full run."""
QUICK_BUDGET = {
    **BUDGET,
    "nlopt_max_evals": 40,
    "surrogate_max_steps": 8,
    "band_counts": [2, 3, 4],
}
"""The smoke test's: fewer evaluations and steps, 2-4 bands."""
SEARCH_SCENARIOS = dict(
    surfaces=("asphalt", "concrete_roof_tile", "grass", "soil"),
    moons=(None, "full"),
    classes=("P1", "P6"),
)
"""The scenes the bands are searched on: the band search's preset ("search")."""


def _spectral_bands(results_dir: Path):
    """Band set of key "spectral" of recommendation.json, if present."""
    bands = recommended_band_set("spectral", results_dir=results_dir)
    if bands is None:
        return None, "no 'spectral' band set in results/recommendation.json"
    return bands, "ok"


def _both_searches(data, box, budget, seed: int) -> tuple[dict, dict]:
    """The nlopt search (seed `seed`) and the surrogate search of `data`
    within `box`, on `budget`."""
    r1 = nlopt_search(
        data,
        box,
        algorithm=budget["nlopt_algorithm"],
        max_evals=budget["nlopt_max_evals"],
        seed=seed,
    )
    r2 = surrogate_search(data, box, max_steps=budget["surrogate_max_steps"])
    return r1, r2


def run_searches(table_search, table_eval, budget, log):
    """Per outer fold and band count: nlopt and surrogate searches on the outer
    training lamps (inner splits), judged on the outer test lamps."""
    splits = outer_splits(table_search, budget["fold_seed"])
    results = {}
    for n in budget["band_counts"]:
        box = SearchBox(n)
        per_method = {"nlopt": [], "surrogate": []}
        for s in splits:
            data = search_data(
                table_search, "level2", s.inner, n_bands=n, seed=budget["noise_seed"]
            )
            r1, r2 = _both_searches(data, box, budget, budget["search_seed"] + s.outer)
            for key, r in (("nlopt", r1), ("surrogate", r2)):
                r["band_set"] = box.band_set(
                    np.asarray(r["u"]), name=f"{key}-n{n}-f{s.outer}"
                )
                per_method[key].append(r)
            log(
                f"n={n} fold {s.outer}: nlopt inner F1 {r1['inner_macro_f1']:.3f} "
                f"({r1['n_evals']} evals), surrogate {r2['inner_macro_f1']:.3f} "
                f"({r2['n_steps']} steps)"
            )
        results[n] = {}
        for key, runs in per_method.items():
            ev = evaluate_band_set(
                table_eval,
                [r["band_set"] for r in runs],
                seed=budget["noise_seed"],
                fold_seed=budget["fold_seed"],
            )
            results[n][key] = {"runs": runs, "eval": ev}
            log(
                f"n={n} {key}: outer level-2 macro F1 {ev.level2.macro_f1:.3f}, "
                f"level-1 {ev.level1.macro_f1:.3f}"
            )
    return results


def final_search(table_search, n, budget, log):
    """Recommended band set for `n` bands: both searches on every lamp with the
    outer folds as (train, validation) splits; the better inner F1 wins."""
    box = SearchBox(n)
    splits = [
        (s.train, s.test) for s in outer_splits(table_search, budget["fold_seed"])
    ]
    data = search_data(
        table_search, "level2", splits, n_bands=n, seed=budget["noise_seed"]
    )
    r1, r2 = _both_searches(data, box, budget, budget["search_seed"])
    best = max((r1, r2), key=lambda r: r["inner_macro_f1"])
    log(
        f"final n={n}: nlopt {r1['inner_macro_f1']:.3f}, surrogate "
        f"{r2['inner_macro_f1']:.3f} -> {best['method']}"
    )
    return box.band_set(np.asarray(best["u"]), name=f"classification-{n}"), r1, r2


def _band_rows(searches, budget) -> tuple[list[dict], list[dict]]:
    """The band-count table (per n and method) and F1 per class of the
    better method at 2, 3 and 4 bands."""
    band_rows, f1_rows = [], []
    for n, per in searches.items():
        for method, r in per.items():
            ev = r["eval"]
            band_rows.append(
                {
                    "n_bands": n,
                    "method": method,
                    "level2_macro_f1": ev.level2.macro_f1,
                    "level2_macro_f1_fold_sd": ev.level2.macro_f1_fold_sd,
                    "level1_macro_f1": ev.level1.macro_f1,
                    "level2_accuracy": ev.level2.accuracy,
                    "level1_accuracy": ev.level1.accuracy,
                    "inner_macro_f1_mean": float(
                        np.mean([x["inner_macro_f1"] for x in r["runs"]])
                    ),
                    "budget": (
                        f"{budget['nlopt_max_evals']} evals"
                        if method == "nlopt"
                        else f"{budget['surrogate_max_steps']} BFGS steps"
                    ),
                }
            )
        best_method = max(per, key=lambda m: per[m]["eval"].level2.macro_f1)
        if n in (2, 3, 4):
            for level in ("level1", "level2"):
                for c, v in per[best_method]["eval"].level(level).f1.items():
                    f1_rows.append(
                        {
                            "n_bands": n,
                            "method": best_method,
                            "level": level,
                            "class": c,
                            "f1": v,
                        }
                    )
    return band_rows, f1_rows


def _reference_rows(table_eval, spectral, budget, log) -> list[dict]:
    """Every reference sensor (and the "spectral" recommendation when there
    is one), with and without photon noise."""
    ref_rows = []
    candidates = [(k, reference_sensor(k)) for k in REFERENCE_SENSORS]
    if spectral is not None:
        candidates.append(("recommended design", spectral))
    for name, b in candidates:
        for noise in (True, False):
            ev = evaluate_band_set(
                table_eval, b, noise=noise, seed=budget["noise_seed"]
            )
            ref_rows.append(
                {
                    "sensor": name,
                    "n_bands": len(b),
                    "noise": noise,
                    "level2_macro_f1": ev.level2.macro_f1,
                    "level1_macro_f1": ev.level1.macro_f1,
                    "level2_accuracy": ev.level2.accuracy,
                    "level1_accuracy": ev.level1.accuracy,
                }
            )
        log(f"reference {name}: level-2 macro F1 {ref_rows[-2]['level2_macro_f1']:.3f}")
    return ref_rows


def _goal(best_by_n: dict, ref_rows: list[dict]) -> dict:
    """Per band count >= 4: the nested level-2 macro F1 against the best
    reference sensor's (with noise), and whether it beats it by
    `GOAL_MARGIN`."""
    refs_noisy = [
        r for r in ref_rows if r["noise"] and r["sensor"] in REFERENCE_SENSORS
    ]
    best_ref = max(refs_noisy, key=lambda r: r["level2_macro_f1"])
    return {
        n: {
            "nested_level2_macro_f1": best_by_n[n],
            "best_reference": best_ref["sensor"],
            "best_reference_level2_macro_f1": best_ref["level2_macro_f1"],
            "margin": best_by_n[n] - best_ref["level2_macro_f1"],
            "met": bool(best_by_n[n] >= best_ref["level2_macro_f1"] + GOAL_MARGIN),
        }
        for n in best_by_n
        if n >= 4
    }


def _influence(table_eval, rec_bands, spectral, budget, log):
    """Identification and LER/G/CCT estimates trained on one surface,
    atmosphere or Moon state: (identification rows, estimate rows, note)."""
    factors = ["surface", "atmosphere", "moon"]
    kw = dict(noise_seed=budget["noise_seed"], fold_seed=budget["fold_seed"])
    ident = influence_identification(table_eval, rec_bands, factors, **kw)
    for r in ident:
        log(
            f"identification {r.factor}={r.train_on}: same {r.macro_f1_same:.3f}, "
            f"others {r.macro_f1_others:.3f}"
        )
    est_bands, est_label = (
        (spectral, "the recommended design (recommendation.json 'spectral')")
        if spectral is not None
        else (
            rec_bands,
            "classification bands (no recommended design in recommendation.json yet)",
        )
    )
    est = influence_estimates(table_eval, est_bands, factors, **kw)
    for r in est:
        log(
            f"estimates {r.factor}={r.train_on}: MAE same "
            f"{np.round(r.mae_same, 3).tolist()}, others "
            f"{np.round(r.mae_others, 3).tolist()}"
        )
    note = f"bandopt.estimate ridge estimator; bands: {est_label}"
    return [r.as_dict() for r in ident], [r.as_dict() for r in est], note


def _write_tables(out: Path, tables: dict, ev_rec) -> None:
    """The CSV tables: `tables` (file stem -> rows), the confusion matrices
    and the per-lamp accuracy of the recommended set; an empty table is not
    written."""
    for lv in ("level1", "level2"):
        cm = ev_rec.level(lv)
        tables[f"confusion_{lv}"] = [
            {"true": c, **dict(zip(cm.confusion_columns, row, strict=True))}
            for c, row in zip(cm.labels, cm.confusion, strict=True)
        ]
    tables["lamp_accuracy"] = [
        {
            "lamp": k,
            "accuracy_level2": v,
            "accuracy_level1": ev_rec.level1.lamp_accuracy[k],
        }
        for k, v in ev_rec.level2.lamp_accuracy.items()
    ]
    for stem, rows in tables.items():
        if rows:
            write_csv(out / f"{stem}.csv", rows)


def _runs_json(per) -> list[dict]:
    """A method's search runs as JSON (without band sets and traces)."""
    return [
        {k: v for k, v in r.items() if k not in ("band_set", "trace")}
        for r in per["runs"]
    ]


def run(
    out: Path | str | None = None, *, quick: bool = False, report_only: bool = False
) -> int:
    """Compute the study (module docstring) into `out` (default
    results/classify, whose run, unless `quick`, also sets the key
    "classification" of results/recommendation.json); returns the exit
    status. `quick`: `QUICK_BUDGET` instead of `BUDGET`; `report_only`:
    rewrite `report.md` from the folder's `summary.json` only."""
    budget = QUICK_BUDGET if quick else BUDGET
    results_dir = Path(RESULTS_DIR)
    to = Path(out) if out else results_dir / "classify"
    to.mkdir(parents=True, exist_ok=True)
    if report_only:
        write_report(to, json.loads((to / "summary.json").read_text()))
        return 0
    t0 = time.perf_counter()

    def log(msg):
        print(f"[{time.perf_counter() - t0:7.1f} s] {msg}", flush=True)

    atms = available_atmospheres()
    log(f"atmospheres: {atms}")
    table_eval = scenario_table(
        build_scenarios(scored_only=True, atmospheres=atms, **TRAINING_SCENARIOS)
    )
    table_search = scenario_table(
        build_scenarios(scored_only=True, atmospheres=atms[:2], **SEARCH_SCENARIOS)
    )
    log(
        f"evaluation scenes {table_eval.n_rows}, search scenes {table_search.n_rows}, "
        f"lamps {len(table_eval.lamp_ids)}"
    )

    # 1. band search per band count (nested)
    searches = run_searches(table_search, table_eval, budget, log)
    band_rows, f1_rows = _band_rows(searches, budget)

    # 2. choose the band count: smallest n within 0.02 of the best nested level-2 F1
    best_by_n = {
        n: max(per[m]["eval"].level2.macro_f1 for m in per)
        for n, per in searches.items()
    }
    n_star = choose_band_count(best_by_n).n_bands
    log(
        f"chosen band count {n_star} (nested level-2 F1 by n: "
        f"{ {k: round(v, 3) for k, v in best_by_n.items()} })"
    )
    rec_bands, fin_nlopt, fin_sur = final_search(table_search, n_star, budget, log)

    # 3. the recommended set: full report, with and without noise, both feature kinds
    ev_rec = evaluate_band_set(table_eval, rec_bands, seed=budget["noise_seed"])
    ev_rec_clean = evaluate_band_set(table_eval, rec_bands, noise=False)
    ev_rec_sum = evaluate_band_set(
        table_eval, rec_bands, seed=budget["noise_seed"], kind="sum_normalised"
    )
    log(
        f"recommended {n_star} bands: "
        f"level-2 macro F1 {ev_rec.level2.macro_f1:.3f} "
        f"(noise-free {ev_rec_clean.level2.macro_f1:.3f}, sum-normalised "
        f"{ev_rec_sum.level2.macro_f1:.3f})"
    )

    # 4. reference sensors (and the "spectral" recommendation when available)
    spectral, spectral_note = _spectral_bands(results_dir)
    ref_rows = _reference_rows(table_eval, spectral, budget, log)
    goal = _goal(best_by_n, ref_rows)

    # 5. influence of surface, atmosphere, Moon
    ident_rows, est_rows, est_note = _influence(
        table_eval, rec_bands, spectral, budget, log
    )

    # 6. write
    conf2 = ev_rec.level2.confusion
    classes2 = ev_rec.level2.labels
    reject_rows = [
        {"level": lv, **x}
        for lv in ("level1", "level2")
        for x in ev_rec.level(lv).reject["curve"]
    ]
    tables = {
        "band_count": band_rows,
        "f1_per_class": f1_rows,
        "reference_sensors": ref_rows,
        "reject": reject_rows,
        "influence_identification": ident_rows,
        "influence_estimates": est_rows,
    }
    _write_tables(to, tables, ev_rec)
    rec_dict = {
        "n_bands": n_star,
        "centre_nm": [float(c) for c in rec_bands.centre_nm],
        "fwhm_nm": [float(f) for f in rec_bands.fwhm_nm],
        "shape_k": [float(k) for k in rec_bands.shape_k],
        "band_set": rec_bands.to_dict(),
        "level2_macro_f1_nested": best_by_n[n_star],
        "level2_macro_f1_recommended_set": ev_rec.level2.macro_f1,
        "level1_macro_f1_recommended_set": ev_rec.level1.macro_f1,
        "note": (
            "bands searched on every lamp (outer folds as validation); the unbiased "
            "estimate is the nested one (bands searched inside each outer fold)"
        ),
        "goal_level2_f1_10_points_above_best_reference": goal,
        "source": "results/classify/summary.json",
    }
    summary_json = {
        "budget": budget,
        "scenarios": {
            "evaluation": table_eval.config,
            "search": table_search.config,
            "n_eval_scenes": table_eval.n_rows,
            "n_search_scenes": table_search.n_rows,
        },
        "scored_classes": {
            "level1": ev_rec.level1.labels,
            "level2": ev_rec.level2.labels,
        },
        "features": "log_ratio (centred log band ratios); sum_normalised compared",
        "band_count": band_rows,
        "chosen_n_bands": n_star,
        "searches": {
            str(n): {m: _runs_json(per[m]) for m in per} for n, per in searches.items()
        },
        "final_search": {
            "nlopt": {k: v for k, v in fin_nlopt.items() if k != "trace"},
            "surrogate": fin_sur,
        },
        "recommended": {
            "bands": rec_dict,
            "noisy": band_set_summary(ev_rec),
            "noise_free": band_set_summary(ev_rec_clean),
            "sum_normalised_features": band_set_summary(ev_rec_sum),
            "reject_curve": reject_rows,
            "confusion_level2": {
                "labels": classes2,
                "columns": ev_rec.level2.confusion_columns,
                "counts": conf2,
            },
        },
        "reference_sensors": ref_rows,
        "spectral_bands": spectral_note,
        "goal": goal,
        "influence_identification": ident_rows,
        "influence_estimates": {"note": est_note, "rows": est_rows},
        "wall_s": time.perf_counter() - t0,
    }
    (to / "summary.json").write_text(
        strict_dumps(summary_json, indent=2) + "\n"
    )
    figures(to, tables, conf2, classes2)
    write_report(to, summary_json)
    write_manifest(
        to, seed=budget["noise_seed"], config={"budget": budget, "quick": quick}
    )
    if not quick and out is None:
        update_recommendation("classification", rec_dict)
    log(f"done: {to}")
    return 0
