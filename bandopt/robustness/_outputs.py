"""What a finished robustness run writes beside its records: `summary.json`
(strict JSON), the figure (error and coverage per row, paired with the clean
row, and the reliability diagram of the level-1 probabilities), `README.md`
and the manifest (`write_outputs`)."""

from pathlib import Path

import numpy as np

from ..provenance import write_manifest
from ..results import bands_record
from ..sensor.reference import resolve_band_set
from ..strict_json import strict_dumps


def _cell(row: dict, col: str, digits: int, sd: bool = True) -> str:
    v = row.get(col)
    if v is None:
        return "n/a"
    s = row.get(f"{col}_sd")
    return f"{v:.{digits}f}" + (f" ± {s:.{digits}f}" if sd and s is not None else "")


def readme_text(summary: dict, out: Path) -> str:
    """`README.md` of the results folder, generated from `summary.json`."""
    lines = [
        "# Robustness suite (`make robustness`)",
        "",
        "`bandopt evaluate`'s estimator (shipped defaults, surface unknown, Moon "
        "told) fitted once per lamp partition and band set on the training lamps; "
        "the held-out measured lamps' spectra perturbed, lit under the same scenes "
        "and scored against the clean rows of the same lamps and scenes "
        f"(`bandopt.robustness`). {summary['partitions']} partition(s) (fold "
        f"seeds 0..{summary['partitions'] - 1}, outer fold {summary['fold']} held "
        "out); class-balanced means, mean ± SD over partitions. Truth: LER, G and "
        "CCT of the spectrum the pixel holds; types: the lamp's own (the majority "
        "lamp of a mixture). Coverage: share of true values in the 90 % "
        "intervals; width: median 90 % interval width; ECE: expected calibration "
        "error of the level-1 probabilities (10 bins; ECE answered: over the "
        "pixels not flagged, whose type is given); level-1 answered: right "
        "among the pixels not flagged `unexplained` (a flagged pixel's type is "
        "not given, so level-1 counts it as not right); out of range: estimates "
        "outside the physical range (must be 0). Generated from "
        f"`{out}/summary.json`.",
        "",
        "| band set | row | level-1 | level-1 answered | level-2 | LER [lm/W] | G | "
        "CCT [K] | coverage LER/G/CCT | width LER/G/CCT | ECE | ECE answered | "
        "unexplained | out of range |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for r in summary["rows"]:
        cov = "/".join(_cell(r, f"{m}_covered", 2, False) for m in ("LER", "G", "CCT"))
        wid = "/".join(
            _cell(r, f"{m}_width_median", d, False)
            for m, d in (("LER", 0), ("G", 2), ("CCT", 0))
        )
        lines.append(
            f"| {r['band_set']} | {r['perturbation']} | "
            f"{_cell(r, 'level1_correct', 2)} | {_cell(r, 'level1_answered', 2)} | "
            f"{_cell(r, 'level2_correct', 2)} | "
            f"{_cell(r, 'LER', 1)} | {_cell(r, 'G', 3)} | {_cell(r, 'CCT', 0)} | "
            f"{cov} | {wid} | {_cell(r, 'ECE', 3)} | {_cell(r, 'ECE_answered', 3)} | "
            f"{_cell(r, 'unexplained', 2, False)} | {r['out_of_range']} |"
        )
    lines += [
        "",
        "Paired by partition, perturbed minus clean (same band set, lamps and "
        "scenes), mean ± SD:",
        "",
        "| band set | row | level-1 | level-2 | LER [lm/W] | G | CCT [K] | ECE |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for d in summary["paired"]:
        cells = []
        for col, digits in (
            ("level1_correct", 2),
            ("level2_correct", 2),
            ("LER", 1),
            ("G", 3),
            ("CCT", 0),
            ("ECE", 3),
        ):
            v, s = d.get(f"{col}_diff"), d.get(f"{col}_diff_sd")
            cells.append(
                "n/a"
                if v is None
                else f"{v:+.{digits}f}" + ("" if s is None else f" ± {s:.{digits}f}")
            )
        lines.append(f"| {d['band_set']} | {d['perturbation']} | {' | '.join(cells)} |")
    for b in summary["band_sets"]:
        ds = [d for d in summary["paired"] if d["band_set"] == b]
        if not ds:
            continue
        l1 = min(ds, key=lambda d: d.get("level1_correct_diff") or 0.0)
        ler = max(ds, key=lambda d: d.get("LER_diff") or 0.0)
        lines += [
            "",
            f"{b}: the largest level-1 drop is under '{l1['perturbation']}' "
            f"({l1['level1_correct_diff']:+.2f}), the largest LER rise under "
            f"'{ler['perturbation']}' ({ler['LER_diff']:+.1f} lm/W).",
        ]
    lines += ["", "![robustness](robustness.png)", ""]
    return "\n".join(lines)


def figure(summary: dict, path: Path) -> None:
    """Per row: level-1 right and LER MAE per band set (mean ± SD over
    partitions); reliability diagram of the clean and the pooled perturbed
    level-1 probabilities per band set."""
    import matplotlib  # plotting only: start-up time

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt  # after matplotlib.use("Agg")

    labels = [p for p in summary["perturbations"]]
    labels = [p for p in labels if any(r["perturbation"] == p for r in summary["rows"])]
    sets = summary["band_sets"]
    by = {(r["band_set"], r["perturbation"]): r for r in summary["rows"]}
    height = 2.0 + 0.32 * len(labels) * max(len(sets), 1) ** 0.5
    fig, axes = plt.subplots(1, 3, figsize=(15, height))
    y = np.arange(len(labels))[::-1]
    bar = 0.8 / max(len(sets), 1)
    for ax, (col, title) in zip(
        axes[:2],
        (("level1_correct", "level-1 right"), ("LER", "class-balanced MAE LER [lm/W]")),
        strict=True,
    ):
        for j, b in enumerate(sets):
            v = [by.get((b, p), {}).get(col) for p in labels]
            e = [by.get((b, p), {}).get(f"{col}_sd") or 0.0 for p in labels]
            v = [np.nan if x is None else x for x in v]
            off = bar * (len(sets) - 1) / 2 - bar * j
            ax.barh(y + off, v, height=bar, xerr=e, capsize=2, color=f"C{j}", label=b)
        ax.set_yticks(y, labels, fontsize=8)
        ax.set_xlabel(title)
        ax.grid(axis="x", alpha=0.3)
    axes[1].set_yticklabels([])
    axes[0].legend(fontsize=8, loc="lower left")
    ax = axes[2]
    ax.plot([0, 1], [0, 1], color="0.6", lw=0.8)
    for j, b in enumerate(sets):
        rel = summary["reliability"].get(b)
        if not rel:
            continue
        for kind, style in (("clean", "-"), ("perturbed", "--")):
            c = np.asarray(
                [np.nan if x is None else x for x in rel[kind]["confidence"]]
            )
            a = np.asarray([np.nan if x is None else x for x in rel[kind]["accuracy"]])
            ok = np.isfinite(c) & np.isfinite(a)
            ax.plot(c[ok], a[ok], style, color=f"C{j}", label=f"{b}, {kind}")
            share = np.asarray(rel[kind]["share"])[ok]  # marker area: pixel share
            ax.scatter(c[ok], a[ok], s=400 * share, color=f"C{j}", alpha=0.6)
    ax.set_xlabel("level-1 confidence (top probability)")
    ax.set_ylabel("fraction right")
    ax.set_xlim(0, 1)
    ax.set_ylim(0, 1)
    ax.legend(fontsize=7, loc="upper left")
    ax.set_title(
        "reliability (10 bins, marker area: share of pixels; perturbed: all rows "
        "pooled)",
        fontsize=9,
    )
    fig.suptitle(
        "Held-out measured lamps under measurement effects, surface unknown, Moon "
        "told (mean ± SD over partitions)",
        fontsize=10,
    )
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def write_outputs(summary: dict, study, out: Path) -> None:
    """`summary.json` (strict JSON), the figure, `README.md` and the
    manifest of a finished run."""
    out.mkdir(parents=True, exist_ok=True)
    summary = {
        **summary,
        "bands": {
            label: bands_record(resolve_band_set(src).bands)
            for label, src in study.band_sets
        },
    }
    text = strict_dumps(summary, indent=2)
    (out / "summary.json").write_text(text + "\n")
    figure(summary, out / "robustness.png")
    (out / "README.md").write_text(readme_text(summary, out))
    write_manifest(out, seed=study.seed, config=study.to_dict())
