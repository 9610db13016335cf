"""What `classification` writes besides its tables: the figures and
`report.md`, read from the run's rows and summary."""

from pathlib import Path

import numpy as np


GOAL_MARGIN = 0.10
"""Goal: level-2 macro F1 at least 10 points above the best reference sensor."""


def figures(out: Path, tables: dict, conf2, classes2) -> None:
    """F1 against the band count, F1 per class, the level-2 confusion
    (`conf2`, rows `classes2`), the reject curve, the reference sensors and
    the influence of each factor, as PNG files in `out`; `tables`: the
    study's CSV tables by file stem."""
    band_rows, f1_rows = tables["band_count"], tables["f1_per_class"]
    ref_rows, reject_rows = tables["reference_sensors"], tables["reject"]
    ident_rows = tables["influence_identification"]
    est_rows = tables["influence_estimates"]
    import matplotlib  # plotting only: start-up time

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt  # after matplotlib.use("Agg")

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
    """`report.md` from the summary `d`: the answers of the study in prose and
    small tables."""

    def f(x):
        return "-" if x is None else f"{x:.3f}"

    lines = ["# Lamp-type classification", ""]
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
