"""What `classification_partitions` writes besides its records: the figure,
`report.md` and the `classify-partitions` section of results/README.md, each
read from the run's summary."""

from collections.abc import Sequence
from pathlib import Path

import numpy as np


LEVELS = ("level2", "level1")
"""Lamp-type levels reported, level 2 (the finer) first."""
README_REFERENCES = ("nightsat", "sdgsat-1")
"""Reference sensors of the results/README.md section's paired table."""


def _fmt(mean, sd, digits=3) -> str:
    if mean is None:
        return "-"
    return f"{mean:.{digits}f}" + ("" if sd is None else f" ± {sd:.{digits}f}")


def figure(rows: Sequence[dict], path: Path, partitions: int) -> None:
    """Macro F1 per design (x) and estimator (marker), mean with error bars of
    the SD over partitions; level 2 and level 1 panels."""
    import matplotlib  # plotting only: start-up time

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt  # after matplotlib.use("Agg")

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
        "| design | bands | level 2: "
        + " / ".join(ests)
        + " | level 1: "
        + " / ".join(ests)
        + " |",
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
        "Paired differences, ours minus reference, same partition (level-2 macro F1):",
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
    """`report.md`: macro F1 per design and estimator at both levels, the
    paired differences, what was not run and why, and the cost."""
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
