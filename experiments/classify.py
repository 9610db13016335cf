"""Lamp-type classification experiment: `python -m experiments.classify`.

Writes `results/classify/`:

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
- `manifest.json`; and the key "classification" of `results/recommendation.json`.

Budgets (defaults; `--quick` shrinks them): nlopt GN_CRS2_LM 300 evaluations per
search, optimistix BFGS 40 steps on the surrogate, n = 2..6, 3 outer folds.
"""

import argparse
import csv
import json
import time
from pathlib import Path

import numpy as np


BUDGET = {
    "nlopt_algorithm": "crs2",
    "nlopt_max_evals": 300,
    "surrogate_max_steps": 40,
    "band_counts": [2, 3, 4, 5, 6],
    "noise_seed": 0,
    "fold_seed": 0,
    "search_seed": 0,
}
QUICK_BUDGET = {
    **BUDGET,
    "nlopt_max_evals": 40,
    "surrogate_max_steps": 8,
    "band_counts": [2, 3, 4],
}
SEARCH_SCENARIOS = dict(
    surfaces=("asphalt", "concrete_roof_tile", "grass", "soil"),
    moons=(None, "full"),
    classes=("P1", "P6"),
)
"""The band search's scenario preset (issue 5, "search")."""
GOAL_MARGIN = 0.10
"""Goal: level-2 macro F1 at least 10 points above the best reference sensor."""


def _write_csv(path: Path, rows: list[dict]) -> None:
    if not rows:
        return
    keys = list(dict.fromkeys(k for r in rows for k in r))
    with path.open("w", newline="") as fh:
        w = csv.DictWriter(fh, keys)
        w.writeheader()
        w.writerows(rows)


def _spectral_bands(results_dir: Path):
    """Band set of key "spectral" of recommendation.json, if present."""
    from bandopt.results import recommended_band_set

    bands = recommended_band_set("spectral", results_dir=results_dir)
    if bands is None:
        return None, "no 'spectral' band set in results/recommendation.json"
    return bands, "ok"


def run_searches(table_search, table_eval, budget, log):
    """Per outer fold and band count: nlopt and surrogate searches on the outer
    training lamps (inner splits), judged on the outer test lamps."""
    from bandopt.classify import (
        SearchBox,
        evaluate_band_set,
        nlopt_search,
        outer_splits,
        search_data,
        surrogate_search,
    )

    splits = outer_splits(table_search, budget["fold_seed"])
    results = {}
    for n in budget["band_counts"]:
        box = SearchBox(n)
        per_method = {"nlopt": [], "surrogate": []}
        for s in splits:
            data = search_data(
                table_search, "level2", s.inner, n_bands=n, seed=budget["noise_seed"]
            )
            r1 = nlopt_search(
                data,
                box,
                algorithm=budget["nlopt_algorithm"],
                max_evals=budget["nlopt_max_evals"],
                seed=budget["search_seed"] + s.outer,
            )
            r2 = surrogate_search(data, box, max_steps=budget["surrogate_max_steps"])
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
    from bandopt.classify import (
        SearchBox,
        nlopt_search,
        outer_splits,
        search_data,
        surrogate_search,
    )

    box = SearchBox(n)
    splits = [
        (s.train, s.test) for s in outer_splits(table_search, budget["fold_seed"])
    ]
    data = search_data(
        table_search, "level2", splits, n_bands=n, seed=budget["noise_seed"]
    )
    r1 = nlopt_search(
        data,
        box,
        algorithm=budget["nlopt_algorithm"],
        max_evals=budget["nlopt_max_evals"],
        seed=budget["search_seed"],
    )
    r2 = surrogate_search(data, box, max_steps=budget["surrogate_max_steps"])
    best = max((r1, r2), key=lambda r: r["inner_macro_f1"])
    log(
        f"final n={n}: nlopt {r1['inner_macro_f1']:.3f}, surrogate "
        f"{r2['inner_macro_f1']:.3f} -> {best['method']}"
    )
    return box.band_set(np.asarray(best["u"]), name=f"classification-{n}"), r1, r2


# ------------------------------------------------------------------------------
# Figures


def _figures(
    out: Path,
    summary: dict,
    band_rows,
    f1_rows,
    ref_rows,
    reject_rows,
    ident_rows,
    est_rows,
    conf2,
    classes2,
):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    # F1 vs band count
    fig, ax = plt.subplots(figsize=(6, 4))
    for method, mk in (("nlopt", "o-"), ("surrogate", "s--")):
        r = [b for b in band_rows if b["method"] == method]
        ax.plot(
            [b["n_bands"] for b in r],
            [b["level2_macro_f1"] for b in r],
            mk,
            label=f"{method} (level 2)",
        )
        ax.plot(
            [b["n_bands"] for b in r],
            [b["level1_macro_f1"] for b in r],
            mk,
            alpha=0.4,
            label=f"{method} (level 1)",
        )
    noisy = [r for r in ref_rows if r["noise"]]
    if noisy:
        best = max(noisy, key=lambda r: r["level2_macro_f1"])
        ax.axhline(
            best["level2_macro_f1"],
            color="k",
            ls=":",
            label=f"best reference, level 2 ({best['sensor']})",
        )
        ax.axhline(
            best["level2_macro_f1"] + GOAL_MARGIN, color="r", ls=":", label="goal"
        )
    ax.set_xlabel("number of bands")
    ax.set_ylabel("macro F1 (outer folds, photon noise)")
    ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(out / "f1_vs_band_count.png", dpi=120)
    plt.close(fig)

    # F1 per lamp type for 2, 3, 4 bands
    fig, ax = plt.subplots(figsize=(8, 4))
    ns = sorted({r["n_bands"] for r in f1_rows})
    cls = list(dict.fromkeys(r["class"] for r in f1_rows if r["level"] == "level2"))
    width = 0.8 / max(len(ns), 1)
    for i, n in enumerate(ns):
        vals = [
            next(
                r["f1"]
                for r in f1_rows
                if r["n_bands"] == n and r["class"] == c and r["level"] == "level2"
            )
            for c in cls
        ]
        ax.bar(np.arange(len(cls)) + i * width, vals, width, label=f"{n} bands")
    ax.set_xticks(
        np.arange(len(cls)) + width * (len(ns) - 1) / 2, cls, rotation=30, ha="right"
    )
    ax.set_ylabel("F1 (level 2)")
    ax.legend()
    fig.tight_layout()
    fig.savefig(out / "f1_per_class.png", dpi=120)
    plt.close(fig)

    # confusion matrix
    cm = np.asarray(conf2, float)
    norm = cm / np.maximum(cm.sum(1, keepdims=True), 1)
    fig, ax = plt.subplots(figsize=(7, 6))
    ax.imshow(norm, cmap="Blues", vmin=0, vmax=1)
    cols = [*classes2, "unknown"][: cm.shape[1]]
    ax.set_xticks(range(cm.shape[1]), cols, rotation=40, ha="right")
    ax.set_yticks(range(cm.shape[0]), classes2)
    for i in range(cm.shape[0]):
        for j in range(cm.shape[1]):
            ax.text(j, i, f"{norm[i, j]:.2f}", ha="center", va="center", fontsize=7)
    ax.set_xlabel("predicted")
    ax.set_ylabel("true")
    ax.set_title("level-2 confusion (row-normalised, outer folds)")
    fig.tight_layout()
    fig.savefig(out / "confusion_level2.png", dpi=120)
    plt.close(fig)

    # reject curve
    fig, ax = plt.subplots(figsize=(5, 4))
    for level in ("level1", "level2"):
        r = [x for x in reject_rows if x["level"] == level]
        ax.plot(
            [x["coverage"] for x in r],
            [x["accuracy_accepted"] for x in r],
            "o-",
            label=level,
        )
    ax.set_xlabel("coverage (fraction not rejected)")
    ax.set_ylabel("accuracy on accepted scenes")
    ax.legend()
    fig.tight_layout()
    fig.savefig(out / "reject.png", dpi=120)
    plt.close(fig)

    # reference sensors
    fig, ax = plt.subplots(figsize=(8, 4))
    refs = [r for r in ref_rows if r["noise"]]
    ax.bar(range(len(refs)), [r["level2_macro_f1"] for r in refs])
    ax.set_xticks(
        range(len(refs)),
        [f"{r['sensor']} ({r['n_bands']})" for r in refs],
        rotation=40,
        ha="right",
        fontsize=7,
    )
    ax.set_ylabel("level-2 macro F1 (photon noise)")
    fig.tight_layout()
    fig.savefig(out / "reference_sensors.png", dpi=120)
    plt.close(fig)

    for rows, key, ylabel, name in (
        (
            ident_rows,
            "f1_drop",
            "macro F1 same - others",
            "influence_identification.png",
        ),
        (
            est_rows,
            "CCT_mae_increase",
            "CCT MAE others - same [K]",
            "influence_estimates.png",
        ),
    ):
        if not rows:
            continue
        fig, ax = plt.subplots(figsize=(8, 4))
        ax.bar(range(len(rows)), [r[key] for r in rows])
        ax.set_xticks(
            range(len(rows)),
            [f"{r['factor']}:{r['train_on']}"[:28] for r in rows],
            rotation=50,
            ha="right",
            fontsize=6,
        )
        ax.set_ylabel(ylabel)
        fig.tight_layout()
        fig.savefig(out / name, dpi=120)
        plt.close(fig)


def write_report(out: Path, d: dict) -> Path:
    """`report.md`: the answers of the experiment in prose and small tables."""

    def f(x):
        return "-" if x is None else f"{x:.3f}"

    lines = ["# Lamp-type classification (issue 6)", ""]
    sc = d["scenarios"]
    ecfg = sc["evaluation"]
    lines += [
        f"Scenes: {sc['n_eval_scenes']} for evaluation (every scored lamp x "
        f"surfaces x atmospheres {ecfg['atmospheres']} x Moon {ecfg['moons']} "
        f"x classes {ecfg['classes']}), {sc['n_search_scenes']} for the "
        "searches (the band search's preset). Photon noise of the thesis sensor "
        "(Table 2.3) unless stated. Nested lamp-grouped CV, 3 outer x 2 inner "
        "folds, seed 0 (same folds as the band search). Scored classes only: level 2 "
        f"{d['scored_classes']['level2']}; level 1 {d['scored_classes']['level1']} "
        "(led_amber, lps, fluorescent_compact have < 3 lamps; led_rgb never scored).",
        "",
        f"Budgets: {d['budget']}.",
        "",
        "## How many bands",
        "",
        "Nested outer-fold macro F1; bands searched inside each outer fold.",
        "",
        "| n | method | level-2 macro F1 | (fold SD) | level-1 macro F1 | inner F1 |",
        "|---|---|---|---|---|---|",
    ]
    for r in d["band_count"]:
        lines.append(
            f"| {r['n_bands']} | {r['method']} | {f(r['level2_macro_f1'])} | "
            f"{f(r['level2_macro_f1_fold_sd'])} | {f(r['level1_macro_f1'])} | "
            f"{f(r['inner_macro_f1_mean'])} |"
        )
    rec = d["recommended"]
    b = rec["bands"]
    rj = rec["noisy"]["level2"]["reject"]
    lines += [
        "",
        f"Chosen: n = {d['chosen_n_bands']} (smallest n within 0.02 of the best nested "
        f"level-2 macro F1). Recommended bands (searched on all lamps): centres "
        f"{[round(c, 1) for c in b['centre_nm']]} nm, FWHM "
        f"{[round(x, 1) for x in b['fwhm_nm']]} nm. Their outer-fold level-2 macro F1 "
        f"{f(rec['noisy']['level2']['macro_f1'])} with noise, "
        f"{f(rec['noise_free']['level2']['macro_f1'])} noise-free (deduplicated "
        f"scenes), {f(rec['sum_normalised_features']['level2']['macro_f1'])} with "
        "sum-normalised "
        "features instead of log ratios (optimistic: the bands saw every lamp; the "
        "nested number above is the unbiased one).",
        "",
        f"Reject option (confidence < {rj['threshold']}): "
        f"level-2 coverage {f(rj['coverage'])}, accuracy "
        f"over all scenes {f(rj['accuracy'])}; see reject.csv.",
        "",
        "## Reference sensors (same features, classifier, folds)",
        "",
        "| sensor | bands | noise | level-2 macro F1 | level-1 macro F1 |",
        "|---|---|---|---|---|",
    ]
    for r in d["reference_sensors"]:
        lines.append(
            f"| {r['sensor']} | {r['n_bands']} | {r['noise']} | "
            f"{f(r['level2_macro_f1'])} | {f(r['level1_macro_f1'])} |"
        )
    lines += ["", "## Goal: level-2 macro F1 >= best reference + 0.10, >= 4 bands", ""]
    for n, g in d["goal"].items():
        lines.append(
            f"- n = {n}: nested {f(g['nested_level2_macro_f1'])} vs "
            f"{g['best_reference']} {f(g['best_reference_level2_macro_f1'])}: margin "
            f"{g['margin']:+.3f} -> {'MET' if g['met'] else 'NOT met'}"
        )
    lines += [
        "",
        "## Influence of surface, atmosphere and Moon on identification",
        "",
        "Train on one condition (outer training lamps), test on the outer test lamps "
        "under the same condition and under the others (level-2 macro F1).",
        "",
        "| factor | trained on | same | others | drop | trained on all |",
        "|---|---|---|---|---|---|",
    ]
    for r in d["influence_identification"]:
        lines.append(
            f"| {r['factor']} | {r['train_on']} | {f(r['macro_f1_same'])} | "
            f"{f(r['macro_f1_others'])} | {r['f1_drop']:+.3f} | "
            f"{f(r['macro_f1_trained_on_all_tested_on_this'])} |"
        )
    est = d["influence_estimates"]
    lines += [
        "",
        "## Influence on the LER / G / CCT estimates",
        "",
        f"{est['note']}. Class-balanced lamp MAE, trained on one condition.",
        "",
        "| factor | trained on | LER same/others [lm/W] | G same/others | "
        "CCT same/others [K] |",
        "|---|---|---|---|---|",
    ]
    for r in est["rows"]:
        lines.append(
            f"| {r['factor']} | {r['train_on']} | {r['LER_mae_same']:.1f} / "
            f"{r['LER_mae_others']:.1f} | {r['G_mae_same']:.3f} / "
            f"{r['G_mae_others']:.3f} | {r['CCT_mae_same']:.0f} / "
            f"{r['CCT_mae_others']:.0f} |"
        )
    if d["scenarios"]["evaluation"]["atmospheres"] == ["none"]:
        lines += [
            "",
            "No atmosphere factor: the 6S tables were not installed when this ran "
            "(`atmospheres=('none',)`); re-run `python -m experiments.classify` once "
            "they are.",
        ]
    lines += ["", f"Wall time {d['wall_s']:.0f} s.", ""]
    path = out / "report.md"
    path.write_text("\n".join(lines))
    return path


# ------------------------------------------------------------------------------


def main(argv=None) -> int:
    from bandopt import configure

    configure()
    from bandopt.classify import (
        TRAINING_SCENARIOS,
        available_atmospheres,
        choose_band_count,
        evaluate_band_set,
        influence_estimates,
        influence_identification,
        summary,
    )
    from bandopt.forward import scenario_table
    from bandopt.provenance import write_manifest
    from bandopt.results import RESULTS_DIR, update_recommendation
    from bandopt.scene import build_scenarios
    from bandopt.sensor import REFERENCE_SENSORS, reference_sensor

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="tiny budgets (smoke test)")
    ap.add_argument(
        "--out", default=None, help="output folder (default results/classify)"
    )
    ap.add_argument(
        "--report-only", action="store_true", help="rewrite report.md from summary.json"
    )
    args = ap.parse_args(argv)
    budget = QUICK_BUDGET if args.quick else BUDGET
    results_dir = Path(RESULTS_DIR)
    out = Path(args.out) if args.out else results_dir / "classify"
    out.mkdir(parents=True, exist_ok=True)
    if args.report_only:
        write_report(out, json.loads((out / "summary.json").read_text()))
        return 0
    t0 = time.perf_counter()

    def log(msg):
        print(f"[{time.perf_counter() - t0:7.1f} s] {msg}", flush=True)

    atms = available_atmospheres()
    search_atms = atms[:2]
    log(f"atmospheres: {atms}")
    table_eval = scenario_table(
        build_scenarios(scored_only=True, atmospheres=atms, **TRAINING_SCENARIOS)
    )
    table_search = scenario_table(
        build_scenarios(scored_only=True, atmospheres=search_atms, **SEARCH_SCENARIOS)
    )
    log(
        f"evaluation scenes {table_eval.n_rows}, search scenes {table_search.n_rows}, "
        f"lamps {len(table_eval.lamp_ids)}"
    )

    # 1. band search per band count (nested)
    searches = run_searches(table_search, table_eval, budget, log)
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

    # 4. reference sensors (+ the issue-5 spectral bands when available)
    ref_rows = []
    spectral, spectral_note = _spectral_bands(results_dir)
    candidates = [(k, reference_sensor(k)) for k in REFERENCE_SENSORS]
    if spectral is not None:
        candidates.append(("spectral (issue 5)", spectral))
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
    refs_noisy = [
        r for r in ref_rows if r["noise"] and r["sensor"] in REFERENCE_SENSORS
    ]
    best_ref = max(refs_noisy, key=lambda r: r["level2_macro_f1"])
    goal = {}
    for n in (n for n in best_by_n if n >= 4):
        goal[n] = {
            "nested_level2_macro_f1": best_by_n[n],
            "best_reference": best_ref["sensor"],
            "best_reference_level2_macro_f1": best_ref["level2_macro_f1"],
            "margin": best_by_n[n] - best_ref["level2_macro_f1"],
            "met": bool(best_by_n[n] >= best_ref["level2_macro_f1"] + GOAL_MARGIN),
        }

    # 5. research questions: influence of surface, atmosphere, Moon
    factors = ["surface", "atmosphere", "moon"]
    kw = dict(noise_seed=budget["noise_seed"], fold_seed=budget["fold_seed"])
    ident = influence_identification(table_eval, rec_bands, factors, **kw)
    ident_rows = [r.as_dict() for r in ident]
    for r in ident:
        log(
            f"identification {r.factor}={r.train_on}: same {r.macro_f1_same:.3f}, "
            f"others {r.macro_f1_others:.3f}"
        )
    est_bands, est_label = (
        (spectral, "issue-5 spectral recommendation")
        if spectral is not None
        else (
            rec_bands,
            "classification bands (no issue-5 spectral recommendation yet)",
        )
    )
    est = influence_estimates(table_eval, est_bands, factors, **kw)
    est_rows = [r.as_dict() for r in est]
    for r in est:
        log(
            f"estimates {r.factor}={r.train_on}: MAE same "
            f"{np.round(r.mae_same, 3).tolist()}, others "
            f"{np.round(r.mae_others, 3).tolist()}"
        )
    est_note = f"bandopt.estimate ridge estimator; bands: {est_label}"

    # 6. write
    conf2 = ev_rec.level2.confusion
    classes2 = ev_rec.level2.labels
    reject_rows = [
        {"level": lv, **x}
        for lv in ("level1", "level2")
        for x in ev_rec.level(lv).reject["curve"]
    ]
    _write_csv(out / "band_count.csv", band_rows)
    _write_csv(out / "f1_per_class.csv", f1_rows)
    _write_csv(out / "reference_sensors.csv", ref_rows)
    _write_csv(out / "reject.csv", reject_rows)
    _write_csv(out / "influence_identification.csv", ident_rows)
    _write_csv(out / "influence_estimates.csv", est_rows)
    for lv in ("level1", "level2"):
        cm = ev_rec.level(lv)
        _write_csv(
            out / f"confusion_{lv}.csv",
            [
                {"true": c, **dict(zip(cm.confusion_columns, row, strict=True))}
                for c, row in zip(cm.labels, cm.confusion, strict=True)
            ],
        )
    lamp_rows = [
        {
            "lamp": k,
            "accuracy_level2": v,
            "accuracy_level1": ev_rec.level1.lamp_accuracy[k],
        }
        for k, v in ev_rec.level2.lamp_accuracy.items()
    ]
    _write_csv(out / "lamp_accuracy.csv", lamp_rows)

    def runs_json(per):
        return [
            {k: v for k, v in r.items() if k not in ("band_set", "trace")}
            for r in per["runs"]
        ]

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
            str(n): {m: runs_json(per[m]) for m in per} for n, per in searches.items()
        },
        "final_search": {
            "nlopt": {k: v for k, v in fin_nlopt.items() if k != "trace"},
            "surrogate": fin_sur,
        },
        "recommended": {
            "bands": rec_dict,
            "noisy": summary(ev_rec),
            "noise_free": summary(ev_rec_clean),
            "sum_normalised_features": summary(ev_rec_sum),
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
    (out / "summary.json").write_text(
        json.dumps(summary_json, indent=2, default=str) + "\n"
    )
    _figures(
        out,
        summary_json,
        band_rows,
        f1_rows,
        ref_rows,
        reject_rows,
        ident_rows,
        est_rows,
        conf2,
        classes2,
    )
    write_report(out, summary_json)
    write_manifest(
        out, seed=budget["noise_seed"], config={"budget": budget, "quick": args.quick}
    )
    if not args.quick and args.out is None:
        update_recommendation("classification", rec_dict)
    log(f"done: {out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
