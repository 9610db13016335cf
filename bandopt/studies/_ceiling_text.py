"""The README section and the figure of the unseen-ceiling study
(`bandopt.studies.unseen_ceiling`), read from its summary."""

from pathlib import Path

import numpy as np

from ._ceiling import (
    BANDS_FEATURE,
    CLASSIFIERS,
    class_mean_score as _score,
    top_feature as _top,
)


def _confused(pred: dict | None, family: str | None) -> str:
    """'led 0.55' for the commonest wrong family of a class ('' if none)."""
    wrong = [(v, k) for k, v in (pred or {}).items() if k != family and v > 0]
    if not wrong:
        return ""
    v, k = max(wrong)
    return f"{k} {v:.2f}"


def _family_of(summary: dict, c: str) -> str | None:
    return summary.get("families", {}).get(c)


def _worst(summary: dict, r: dict, n: int = 2) -> str:
    rows = sorted(r["accuracy"].items(), key=lambda kv: (kv[1], kv[0]))[:n]
    cells = []
    for c, a in rows:
        conf = _confused(r["predicted"].get(c), _family_of(summary, c))
        cells.append(f"{c} {a:.2f}" + (f" (→ {conf})" if conf else ""))
    return ", ".join(cells)


def _visible_line(vis: dict, res: dict, best: dict) -> str:
    """The README sentence on the spectra cut at the extension's start: its
    best class mean, and the classes that lose >= 0.25 with the overall best
    features and classifier."""
    vr, vb = vis["results"], vis["best"]
    vf = _top(vr, vb)
    lo, hi = vis["range_nm"]
    n_ext = sum(vis["extended_lamps"].values())
    per_class = next(iter(next(iter(vr.values())).values()))["lamps"]
    n_all = sum(per_class.values())
    worst = max(vis["extended_lamps"], key=lambda c: vis["extended_lamps"][c])
    line = (
        f"Spectra cut to {lo:g}-{hi:g} nm ({n_all - n_ext} of the {n_all} lamps "
        f"are measured beyond, the others extended by the per-technology model of "
        f"`bandopt.datasets.nir`, e.g. {vis['extended_lamps'][worst]} of the "
        f"{per_class.get(worst, '?')} {worst}): best class mean "
        f"{_score(vr[vf][vb[vf]]):.2f} ({vf}, {vb[vf]})"
    )
    tf = _top(res, best)
    if tf in vr:
        a, b = res[tf][best[tf]]["accuracy"], vr[tf][best[tf]]["accuracy"]
        drops = sorted((b[c] - a[c], c) for c in a if c in b and a[c] - b[c] >= 0.25)
        if drops:
            line += f"; losing most with {tf}, {best[tf]}: " + ", ".join(
                f"{c} {a[c]:.2f} → {b[c]:.2f}" for _, c in drops
            )
    return line + "."


def _models_line(summary: dict) -> str | None:
    """The README sentence on the `with_physical_models` variant: its best
    class mean, the recommended bands', and where it stands against the goal."""
    var = summary.get("with_physical_models")
    if not var:
        return None
    mb, mr = var["best"], var["results"]
    mf = _top(mr, mb)
    top = mr[mf][mb[mf]]
    fams = ", ".join(var["models"])
    line = (
        f"With uncalibrated samples of every physical lamp model "
        f"(`bandopt.lampmodels`: {fams}; {var['samples_per_family']} per model, "
        f"z normal of SD {var['z_spread']:g} about its default start, fitted to "
        "no measured lamp; no fluorescent model exists) and the unscored lamps "
        f"also in training: best class mean {_score(top):.2f} ({mf}, {mb[mf]}"
        + (f"; worst {_worst(summary, top)}" if top["accuracy"] else "")
        + ")"
    )
    if BANDS_FEATURE in mr:
        b = mb[BANDS_FEATURE]
        line += f"; recommended bands {_score(mr[BANDS_FEATURE][b]):.2f} ({b})"
    reached = _score(top) >= summary["goal"]
    line += (
        ": at or above the goal." if reached else
        f": below the goal of {summary['goal']:.2f} even with what physics says "
        "these technologies can emit."
    )  # fmt: skip
    return line


def readme_text(summary: dict) -> str:
    """The `unseen-ceiling` section of `results/README.md` from `summary.json`."""
    res, best = summary["results"], summary["best"]
    goal = summary["goal"]
    any_r = next(iter(next(iter(res.values())).values()))
    n_cls = len(any_r["accuracy"])
    skipped = ", ".join(
        f"{c} ({f} has no other class)" for c, f in sorted(any_r["skipped"].items())
    )
    lines = [
        "## Ceiling of the level-1 family of unseen lamp types "
        "(`results/unseen_ceiling/`, `make unseen-ceiling`)",
        "",
        "Each scored level-2 class held out in turn; a classifier trained on the "
        "measured lamps of the other scored classes names the level-1 family of "
        "the held-out lamps from the bare lamp spectrum (no surface, atmosphere, "
        "Moon or noise), binned to 5-50 nm or as the noise-free values of the "
        "recommended bands; features: log of the values as fractions of their "
        f"sum. Class mean over the {n_cls} held-out classes whose family has "
        "another class (each class equal weight)"
        + (f"; skipped: {skipped}" if skipped else "")
        + f". Issue 12's goal: {goal:.2f}. Measured lamps only. Generated from "
        "`summary.json`.",
        "",
        "| features | " + " | ".join(CLASSIFIERS) + " | lamp mean (best) "
        "| worst held-out classes, best classifier (→ commonest wrong family) |",
        "|---|" + "---|" * (len(CLASSIFIERS) + 2),
    ]
    for feat, by in res.items():
        cells = []
        for name in CLASSIFIERS:
            v = by[name]["class_mean"]
            s = "n/a" if v is None else f"{v:.2f}"
            cells.append(f"**{s}**" if name == best[feat] else s)
        b = by[best[feat]]
        lm = "n/a" if b["lamp_mean"] is None else f"{b['lamp_mean']:.2f}"
        lines.append(
            f"| {feat} | " + " | ".join(cells) + f" | {lm} | {_worst(summary, b)} |"
        )
    top_feat = _top(res, best)
    top = res[top_feat][best[top_feat]]
    lines += [""]
    alt = summary.get("with_unscored_training_lamps")
    if alt:
        ab, ar = alt["best"], alt["results"]
        af = _top(ar, ab)
        extra = ", ".join(f"{c} {n}" for c, n in sorted(alt["lamps"].items()))
        line = (
            f"With the unscored measured lamps ({extra}) also in training, as in "
            f"the inversion's prior: best class mean {_score(ar[af][ab[af]]):.2f} "
            f"({af}, {ab[af]})"
        )
        if BANDS_FEATURE in ar:
            b = ab[BANDS_FEATURE]
            line += f"; recommended bands {_score(ar[BANDS_FEATURE][b]):.2f} ({b})"
        lines.append(line + ".")
        lines.append("")
    models = _models_line(summary)
    if models:
        lines += [models, ""]
    vis = summary.get("visible_only")
    if vis:
        lines += [_visible_line(vis, res, best), ""]
    inv = summary.get("inversion_on_scenes")
    if inv:
        parts = [
            f"`{k}` {r['class_mean']:.2f} (lamp mean {r['lamp_mean']:.2f})"
            for k, r in inv["runs"].items()
            if r["class_mean"] is not None
        ]
        lines += [
            "The inversion on the scenes (recommended bands, Moon told; read from "
            f"`{inv['source']}`, not recomputed; fraction of each lamp's scene "
            "pixels given its family), class mean over the classes whose family "
            "was in its prior: " + ", ".join(parts) + ".",
            "",
        ]
    cm = top["class_mean"]
    if cm is not None and cm < goal:
        lines.append(
            f"Best of all {len(res) * len(CLASSIFIERS)} combinations: {cm:.2f} "
            f"({top_feat}, {best[top_feat]}; chosen on the same held-out results, "
            "so if anything optimistic), below the goal of "
            f"{goal:.2f}: trained on the library's other types, none of these "
            "classifiers names the family of these held-out types often enough "
            "even from the noise-free lamp spectrum; band values are a function "
            "of the spectrum, so with such classifiers trained on this library "
            "no band set reaches the goal: the limit is what the library's "
            "other lamp types teach, not the bands alone."
        )
    elif cm is not None:
        lines.append(
            f"Best of all {len(res) * len(CLASSIFIERS)} combinations: {cm:.2f} "
            f"({top_feat}, {best[top_feat]}), at or above the goal of {goal:.2f}."
        )
    never = sorted(
        c
        for c in any_r["accuracy"]
        if max(res[f][n]["accuracy"][c] for f in res for n in res[f]) < goal
    )
    if never:
        cells = []
        for c in never:
            a = top["accuracy"][c]
            conf = _confused(top["predicted"].get(c), _family_of(summary, c))
            cells.append(f"{c} ({a:.2f}" + (f", → {conf}" if conf else "") + ")")
        lines.append(
            f"Below the goal with every feature set and classifier: "
            f"{', '.join(cells)} (in brackets: with {top_feat}, {best[top_feat]})."
        )
    return "\n".join(lines) + "\n"


def figure(summary: dict, path: Path) -> None:
    """Level-1 accuracy per held-out class: the best classifier of each
    feature set, the inversion on the scenes, and the goal."""
    import matplotlib  # plotting only: start-up time

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt  # after matplotlib.use("Agg")

    res, best = summary["results"], summary["best"]
    any_r = next(iter(next(iter(res.values())).values()))
    classes = sorted(any_r["lamps"])
    rows = ["class mean", *classes]
    binned = [f for f in res if f != BANDS_FEATURE]
    series = [
        (f"{f}: {best[f]}", res[f][best[f]], "o", plt.cm.viridis(0.8 * i / len(binned)))
        for i, f in enumerate(binned)
    ]
    if BANDS_FEATURE in res:
        b = best[BANDS_FEATURE]
        series.append((f"recommended bands: {b}", res[BANDS_FEATURE][b], "D", "C6"))
    inv = summary.get("inversion_on_scenes") or {"runs": {}}
    for k, (label, r) in enumerate(inv["runs"].items()):
        series.append(
            (f"inversion on scenes: {label}", r, "X^"[k % 2], ("C3", "C1")[k % 2])
        )
    height = 1.6 + 0.5 * len(rows)
    fig, ax = plt.subplots(figsize=(10, height))
    y = np.arange(len(rows))[::-1].astype(float)
    off = np.linspace(-0.3, 0.3, len(series))
    for j, (label, r, marker, colour) in enumerate(series):
        vals = [r["class_mean"], *(r["accuracy"].get(c) for c in classes)]
        v = np.array([np.nan if x is None else x for x in vals])
        ax.scatter(v, y + off[j], marker=marker, color=colour, s=36, label=label,
                   edgecolor="k", linewidth=0.3, zorder=3)  # fmt: skip
    for c, f in sorted(any_r["skipped"].items()):
        ax.text(0.02, y[rows.index(c)], f"not scored: no other {f} class in "
                "training", va="center", fontsize=8, color="0.3")  # fmt: skip
    ax.axvline(summary["goal"], color="k", ls="--", lw=1)
    ax.text(summary["goal"], y[0] + 0.55, f" goal {summary['goal']:.2f}",
            fontsize=8, va="bottom")  # fmt: skip
    for yy in y[:-1] - 0.5:
        ax.axhline(yy, color="0.85", lw=0.5)
    ax.axhline(y[0] - 0.5, color="0.4", lw=0.8)
    fam = summary.get("families", {})
    labels = [rows[0]] + [
        f"{c} ({fam.get(c, '?')}, {any_r['lamps'][c]})" for c in classes
    ]
    ax.set_yticks(y, labels, fontsize=9)
    ax.set_ylim(y[-1] - 0.6, y[0] + 0.9)
    ax.set_xlim(-0.02, 1.02)
    ax.set_xlabel(
        "level-1 family right [fraction of the held-out class's lamps; "
        "inversion: of their scene pixels]"
    )
    ax.grid(axis="x", alpha=0.3)
    ax.legend(
        loc="upper left",
        bbox_to_anchor=(1.01, 1.0),
        fontsize=8,
        frameon=False,
        title="features: best classifier",
        title_fontsize=8,
    )
    ax.set_title(
        "Unseen lamp types, each held out in turn (family, lamps): bare lamp "
        "spectra, classifiers trained on the other classes",
        fontsize=10,
    )
    fig.savefig(path, dpi=120, bbox_inches="tight")
    plt.close(fig)
