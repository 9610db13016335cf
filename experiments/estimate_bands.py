"""How many bands the goal needs: evaluate's estimator on contiguous bands (issue 12).

`bandopt evaluate`'s estimator (`inversion-moon-mix-metric-narrow-shift-planck`,
surface unknown, the Moon told) misses issue 12's goal (5 lm/W, G 0.10,
200 K) with our pan + 5 bands. `make estimate-library` found that a lamp
the prior holds is estimated within the goal, so either the six bands carry
too little of the spectrum, or the prior (measured lamps, their blends and
shifted copies) is what limits a lamp it lacks. This scores the same
estimator on idealised imaging spectrometers, `N` equal-width contiguous
bands tiling the scenes' 380-900 nm (`BandSet.contiguous`: 13 x 40 nm,
26 x 20 nm, 52 x 10 nm; narrower bands collect fewer photons, so their noise
is the scenes' photon noise for their width), against our pan + 5 bands, on
the scenes, lamp partitions and folds of `make estimate`, paired by
partition. If the error does not fall with the band count, more bands do not
buy the goal: the library does.

    python -m experiments.estimate_bands [--partitions 4] [--out DIR]
        [--resume] [--only-partitions P ...]

Writes `records.jsonl`, `summary.json`, `errors.png`, `manifest.json` and
the `estimate-bands` section of `results/README.md` (default output only),
as `experiments.estimate_mix` does (`Study`). Measured lamps only score;
the priors hold the library's modelled Planck spectra (as evaluate's).
"""

import numpy as np

from experiments.estimate import diff_cells
from experiments.estimate_defaults import DEFAULT
from experiments.estimate_mix import Study, main as _run, row_line


COUNTS = (13, 26, 52)
"""Band counts of the contiguous sets (40, 20 and 10 nm wide over 380-900 nm;
52 x 10 nm is issue 12's own reconstruction test)."""

BAND_SETS = {
    "recommended": ("unknown",),
    **{f"contiguous-{n}": ("unknown",) for n in COUNTS},
}
"""Our pan + 5 bands and the contiguous sets, surface unknown."""

GOAL = {"LER": 5.0, "G": 0.10, "CCT": 200.0}
"""Issue 12's goal for the class-balanced MAE with the surface unknown."""

CLASS_KEYS = ("LER", "G", "CCT", "level1_correct")


def by_class(records) -> dict:
    """Per band set and held-out level-2 class, the mean over lamps and
    partitions of each lamp's error and level-1 rate."""
    out: dict = {}
    for b in dict.fromkeys(r["band_set"] for r in records):
        rs = [r for r in records if r["band_set"] == b and r["estimator"] == DEFAULT]
        out[b] = {}
        for c in sorted({r["level2"] for r in rs}):
            cr = [r for r in rs if r["level2"] == c]
            out[b][c] = {
                k: float(np.mean(v)) if v else None
                for k in CLASS_KEYS
                for v in [[r[k] for r in cr if r.get(k) is not None]]
            }
            out[b][c]["lamps"] = len({r["lamp"] for r in cr})
    return out


def nearest_lamp_gap(spectra, wavelength_nm, level2) -> dict:
    """What naming the spectrally nearest other lamp costs: for each lamp of
    `spectra` (l, w; 1 nm, covering 380-780 nm), the lamp among the others
    whose 380-780 nm spectrum, in 5 nm bins and as fractions of its sum, is
    nearest (Euclidean), and the absolute difference of their LER, G and CCT
    (a CCT that has no meaning counts as 25000 K, as the scoring does);
    class-balanced means over lamps and per class (LER), for the nearest lamp
    and for the mean of the 3 nearest. An estimate that answers with library
    lamps, blends of them, is near this even when it sees the whole
    spectrum without noise."""
    # lazy: JAX is configured by the study's main before photometry runs
    from bandopt.estimate import CCT_RANGE_K, lamp_truth
    from bandopt.folds import class_balanced_weights

    w = np.asarray(wavelength_nm, float)
    truth, valid = lamp_truth(spectra, w)
    truth[:, 2] = np.where(valid[:, 2], truth[:, 2], CCT_RANGE_K[1])
    vis = (w >= 380.0) & (w < 780.0)
    x = np.asarray(spectra, float)[:, vis]
    x = x[:, : x.shape[1] // 5 * 5].reshape(len(x), -1, 5).sum(axis=-1)
    x = x / x.sum(axis=1, keepdims=True)
    dist = np.sqrt(((x[:, None, :] - x[None, :, :]) ** 2).sum(axis=-1))
    np.fill_diagonal(dist, np.inf)
    order = np.argsort(dist, axis=1)
    l2 = np.asarray(level2, object)
    wts = class_balanced_weights(l2)
    out: dict = {"lamps": len(x)}
    for label, k in (("nearest", 1), ("mean_of_3", 3)):
        est = truth[order[:, : min(k, len(x) - 1)]].mean(axis=1)  # never itself
        err = np.abs(est - truth)
        ok = valid[:, :2].all(axis=1)
        out[label] = {
            m: float(np.sum(wts[ok] * err[ok, j]) / wts[ok].sum())
            for j, m in enumerate(("LER", "G", "CCT"))
        }
        out[label]["LER_by_class"] = {
            c: float(err[(l2 == c) & ok, 0].mean()) for c in sorted(set(l2))
        }
    return out


def library_gap() -> dict:
    """`nearest_lamp_gap` of the library's scored measured lamps (each lamp
    against all the others)."""
    # lazy: JAX is configured by the study's main before the library is built
    from bandopt.inversion import library_lamps

    grid = np.arange(380.0, 901.0)
    lamps = library_lamps(grid, scored=True)
    return nearest_lamp_gap(lamps.spectra, grid, lamps.level2)


def band_definitions() -> dict:
    """Each band set's bands: count, centres and FWHMs [nm]."""
    # lazy: JAX is configured by the study's main before bands are built
    from experiments.estimate import band_set

    out = {}
    for name in BAND_SETS:
        b = band_set(name)
        out[name] = {
            "bands": len(b.names),
            "centre_nm": [round(float(c), 3) for c in np.asarray(b.centre_nm)],
            "fwhm_nm": [round(float(f), 3) for f in np.asarray(b.fwhm_nm)],
        }
    return out


def meets_goal(row: dict) -> bool:
    """Whether a summary row's mean error is within the goal on all three
    metrics."""
    return all(row.get(m) is not None and row[m] <= g for m, g in GOAL.items())


def verdict(rows) -> str:
    """The decision rule fixed before the run, applied to the rows: which band
    sets meet the goal and what that says."""
    rows = [r for r in rows if r["estimator"] == DEFAULT]
    met = [r["band_set"] for r in rows if meets_goal(r)]
    contiguous = [r for r in rows if r["band_set"] != "recommended"]
    if any(r["band_set"] != "recommended" for r in rows if r["band_set"] in met):
        first = min(
            (r for r in contiguous if r["band_set"] in met),
            key=lambda r: int(r["band_set"].split("-")[1]),
        )
        return (
            f"The goal is met with {first['band_set']}: the band count limits "
            "evaluate's estimator, and this is the smallest tried that suffices."
        )
    spans = {
        m: (min(r[m] for r in rows), max(r[m] for r in rows))
        for m in ("LER", "G", "CCT")
    }
    return (
        "No band set meets the goal (5 lm/W, 0.10, 200 K), not even 52 bands of "
        "10 nm: across 6 to 52 bands the error stays at "
        f"{spans['LER'][0]:.1f}-{spans['LER'][1]:.1f} lm/W, "
        f"{spans['G'][0]:.3f}-{spans['G'][1]:.3f} and "
        f"{spans['CCT'][0]:.0f}-{spans['CCT'][1]:.0f} K. More bands do not buy the "
        "goal with this library: what limits a lamp the library lacks is the "
        "prior's coverage of lamp kinds (`make estimate-library`: the same "
        "estimator meets the goal on lamps its prior holds), not the band count."
    )


def figure(summary: dict, path) -> None:
    """Class-balanced MAE per band set (mean ± SD over partitions) with the
    goal and the nearest-library-lamp error as lines."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    rows = [r for r in summary["rows"] if r["estimator"] == DEFAULT]
    near = ((summary.get("extra") or {}).get("nearest_lamp") or {}).get("nearest")
    fig, axes = plt.subplots(1, 3, figsize=(13, 3.2), sharey=True)
    y = np.arange(len(rows))[::-1]
    for ax, (m, unit) in zip(
        axes, (("LER", "lm/W"), ("G", "1"), ("CCT", "K")), strict=True
    ):
        ax.barh(y, [r[m] for r in rows], xerr=[r.get(f"{m}_sd") or 0 for r in rows],
                color="C8", capsize=2)  # fmt: skip
        ax.axvline(GOAL[m], color="C2", ls="--", label="issue 12's goal")
        if near:
            ax.axvline(near[m], color="C3", ls=":", label="nearest library lamp")
        ax.set_yticks(y, [r["band_set"] for r in rows], fontsize=8)
        ax.set_xlabel(f"class-balanced MAE {m} [{unit}]")
        ax.grid(axis="x", alpha=0.3)
    handles, labels = axes[0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="lower center", ncol=2, fontsize=8, frameon=False)
    fig.suptitle(summary.get("title", ""), fontsize=10)
    fig.subplots_adjust(left=0.1, right=0.98, top=0.86, bottom=0.3, wspace=0.08)
    fig.savefig(path, dpi=120, bbox_inches="tight")
    plt.close(fig)


def readme_text(summary: dict) -> str:
    defs = (summary.get("extra") or {}).get("bands") or {}

    def label(b: str) -> str:
        d = defs.get(b)
        if not d:
            return b
        if b == "recommended":
            return f"recommended (pan + {d['bands'] - 1})"
        return f"{b} ({d['bands']} x {d['fwhm_nm'][0]:.0f} nm)"

    lines = [
        "## How many bands the goal needs (`results/estimate_bands/`, "
        "`make estimate-bands`)",
        "",
        "`bandopt evaluate`'s estimator (`" + DEFAULT + "`: surface unknown, the "
        "Moon told) on the scenes, lamp partitions and folds of `make estimate`, "
        "with our pan + 5 bands and with N equal-width contiguous bands tiling "
        "380-900 nm (`BandSet.contiguous`; each band's photon noise that of its "
        f"width); {summary['partitions']} partitions, class-balanced MAE over "
        "held-out measured lamps, mean ± SD over partitions. Measured lamps only "
        "score; modelled lamps used: the library's Planck spectra in every prior, "
        "as evaluate's. Generated from `summary.json`.",
        "",
        "| band set | estimator | LER [lm/W] | G | CCT [K] | coverage LER/G/CCT "
        "| level-1 right |",
        "|---|---|---|---|---|---|---|",
    ]
    for r in summary["rows"]:
        lines.append(row_line({**r, "band_set": label(r["band_set"])}, surface=False))
    lines += [
        "",
        "Paired by partition, contiguous minus our pan + 5 bands (negative = "
        "the contiguous set is better):",
        "",
        "| band set | LER [lm/W] | G | CCT [K] |",
        "|---|---|---|---|",
    ]
    for p in summary["paired"]:
        lines.append(f"| {label(p['band_set'])} | " + " | ".join(diff_cells(p)) + " |")
    classes = (summary.get("extra") or {}).get("by_class") or {}
    if classes:
        sets = list(classes)
        lines += [
            "",
            "LER error per held-out class [lm/W] (mean over lamps and partitions; "
            "level-1 right in brackets):",
            "",
            "| class | " + " | ".join(label(b) for b in sets) + " |",
            "|---|" + "---|" * len(sets),
        ]
        names = sorted({c for b in sets for c in classes[b]})
        for c in names:
            cells = []
            for b in sets:
                v = classes[b].get(c)
                cells.append(
                    "n/a" if not v or v["LER"] is None
                    else f"{v['LER']:.1f} ({v['level1_correct']:.2f})"
                )  # fmt: skip
            n = next(classes[b][c]["lamps"] for b in sets if c in classes[b])
            lines.append(f"| {c} ({n}) | " + " | ".join(cells) + " |")
    lines += ["", verdict(summary["rows"])]
    gap = (summary.get("extra") or {}).get("nearest_lamp")
    if gap:
        near, three = gap["nearest"], gap["mean_of_3"]
        worst = sorted(near["LER_by_class"].items(), key=lambda kv: -kv[1])[:3]
        lines += [
            "",
            "For comparison, with no scene, noise or bands at all: naming each of "
            f"the library's {gap['lamps']} scored lamps by the other library lamp "
            "whose noise-free 380-780 nm spectrum (5 nm bins) is nearest costs "
            f"{near['LER']:.1f} lm/W, G {near['G']:.3f}, CCT {near['CCT']:.0f} K "
            f"(the mean of the 3 nearest: {three['LER']:.1f} lm/W, "
            f"{three['G']:.3f}, {three['CCT']:.0f} K; class-balanced; most in "
            + ", ".join(f"{c} {v:.1f}" for c, v in worst)
            + " lm/W). An estimate built from library lamps and their blends "
            "stays near that however many bands see the lamp: the nearest lamp "
            "the library has is that far away.",
        ]
    return "\n".join(lines) + "\n"


STUDY = Study(
    name="estimate-bands",
    out="results/estimate_bands",
    heading="## How many bands the goal needs",
    band_sets=dict(BAND_SETS),
    estimators=(DEFAULT,),
    pairs=(),
    unseen=(),
    title="Held-out measured lamps, surface unknown, Moon told: evaluate's "
    "estimator with pan + 5 bands and with 13, 26 and 52 contiguous bands",
    oracle=False,
    readme=readme_text,
    figure=figure,
    description=__doc__.splitlines()[0],
    extra=lambda records: {
        "by_class": by_class(records),
        "bands": band_definitions(),
        "nearest_lamp": library_gap(),
    },
)
"""The study `main` runs (`experiments.estimate_mix.Study`)."""


def main(argv=None) -> int:
    return _run(argv, STUDY)


if __name__ == "__main__":
    raise SystemExit(main())
