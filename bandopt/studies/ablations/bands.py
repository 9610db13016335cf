"""How many bands the goal needs: evaluate's estimator on contiguous bands.

`bandopt evaluate`'s estimator (`inversion-moon-mix-metric-narrow-shift-planck`,
surface unknown, the Moon told) misses the estimation goal (5 lm/W, G 0.10,
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
buy the goal for this estimator: the library does. Two comparisons say why
and what else would: what naming each library lamp by its spectrally
nearest other library lamp costs (`nearest_lamp_gap`), and a library-free
estimate from the contiguous bands (`bandopt.direct`: the band values read
as a spectrum once the Moon, surface and atmosphere are divided out; no
lamp trains it) with the surface unknown, known, or measured by Sentinel-2.

    make study NAME=estimate-bands [ARGS="--resume ..."]

Writes `records.jsonl`, `summary.json`, `errors.png`, `manifest.json` and
the `estimate-bands` section of `results/README.md` (default output only),
as every study does (`bandopt.studies.run`). Measured lamps only score;
the priors hold the library's modelled Planck spectra (as evaluate's).
"""

import numpy as np

from ... import inversion as inv_mod
from ...direct import context_reflectance, direct_metrics, direct_spectra
from ...estimate import CCT_RANGE_K, lamp_truth
from ...folds import class_balanced_weights
from ...inversion import library_lamps
from ...search import get_context
from .._study import Study
from .._text import class_means, diff_cells, fmt_cell, rows_table
from .._units import band_set
from .defaults import DEFAULT


COUNTS = (13, 26, 52)
"""Band counts of the contiguous sets (40, 20 and 10 nm wide over 380-900 nm;
52 x 10 nm is the spectral-reconstruction test)."""

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
        out[b] = class_means(rs, CLASS_KEYS)
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

    grid = np.arange(380.0, 901.0)
    lamps = library_lamps(grid, scored=True)
    return nearest_lamp_gap(lamps.spectra, grid, lamps.level2)


DIRECT = "direct"
"""Label of the library-free estimate (`direct_metrics`)."""
DIRECT_SURFACES = ("unknown", "class", "measured")
"""What the direct estimate is told of the surface: nothing (the prior's
type-balanced mean reflectance), its class (in these scenes the class's mean
reflectance is the surface itself, so this is the surface known exactly), or
the Sentinel-2 daytime retrieval the inversion's "measured" mode uses."""


def direct_records(ctx, bands, mode: str, partition: int) -> list[dict]:
    """Records of the direct estimate (`bandopt.direct.direct_spectra` and
    `direct_metrics`) on every lamp of a `search.Context`, in the
    form `bandopt.inversion.cross_validate` gives (`record_errors`: a null
    CCT counts as 25000 K; a metric whose truth is not meaningful is not
    scored). No lamp trains
    it, so every lamp is held out; the same noise draws as the inversion's
    rows; surface `mode` of `DIRECT_SURFACES` (the Sentinel-2 draw seeded by
    `partition`, as `cross_validate` seeds it)."""
    # lazy: JAX is configured by the study's main before these are used

    lamps, _, cond, _ = inv_mod.context_setup(ctx)
    grid = ctx.wavelength_nm
    spectra = direct_spectra(
        ctx.radiance(bands),
        inv_mod.band_weights_on(bands, grid),
        cond,
        context_reflectance(ctx, mode, seed=partition),
        inv_mod.context_moon(ctx),
        np.asarray(bands.edges_nm),
    )
    est, _ = direct_metrics(spectra, grid)
    row_lamp = np.asarray(ctx.table.lamp_of)
    truth, valid = ctx.table.truth, ctx.table.valid
    out = []
    for i in range(len(lamps.ids)):
        e = est[row_lamp == i]
        rec = {
            "estimator": DIRECT, "surface": mode, "partition": partition,
            "band_set": bands.name, "lamp": lamps.ids[i],
            "level1": lamps.level1[i], "level2": lamps.level2[i],
            "rows": len(e), "out_of_range": int(inv_mod._out_of_range(e)),
        }  # fmt: skip
        rec.update(inv_mod.record_errors(e, truth[i], valid[i]))
        out.append(rec)
    return out


def direct_summary(partitions) -> dict:
    """The direct estimate's summary rows (`bandopt.inversion.summarise`) per
    contiguous band set and surface mode over the lamp `partitions`'
    contexts (partition numbers)."""
    # lazy: JAX is configured by the study's main before these are used

    records = []
    for p in partitions:
        ctx = get_context("search", None, p, "auto")
        for name in BAND_SETS:
            if name == "recommended":
                continue  # not contiguous: no piecewise-constant spectrum
            bands = band_set(name)
            for mode in DIRECT_SURFACES:
                records += direct_records(ctx, bands, mode, p)
    groups: dict = {}
    for r in records:
        groups.setdefault(f"{r['band_set']}/{r['surface']}", []).append(r)
    return {
        "rows": inv_mod.summarise(records),
        "by_class": {
            key: class_means(rs, ("LER", "G", "CCT")) for key, rs in groups.items()
        },
    }


def direct_lines(direct: dict, label) -> list[str]:
    """README lines of the direct estimate: a table per band set and surface
    mode, and which rows meet the goal (`label(band set)` names a set)."""
    rows = direct["rows"]
    order = {m: i for i, m in enumerate(DIRECT_SURFACES)}
    rows = sorted(
        rows, key=lambda r: (int(r["band_set"].split("-")[1]), order[r["surface"]])
    )
    lines = [
        "",
        "A library-free estimate, for comparison (`direct`): each pixel's band "
        "values, less the told Moon's term, divided by the band average of the "
        "lamp light's transmittance (mean over the atmospheres) times the "
        "surface's reflectance, read as a spectrum constant over each band; "
        "LER, G and CCT of that spectrum (physical by construction). No lamp "
        "trains it, so every lamp is unseen and the lamp partitions cannot "
        "change it (SD 0, except through the Sentinel-2 draw, seeded per "
        "partition); the same scenes, noise draws and lamps. Surface: "
        "`unknown` (the prior's mean reflectance), `class` (its "
        "class's mean reflectance, which in these scenes is the surface itself: "
        "the surface known), `measured` (the inversion's Sentinel-2 daytime "
        "retrieval, seeded per partition).",
        "",
        "| band set | surface | LER [lm/W] | G | CCT [K] | out of range |",
        "|---|---|---|---|---|---|",
    ]
    for r in rows:
        lines.append(
            f"| {label(r['band_set'])} | {r['surface']} | {fmt_cell(r, 'LER', 1)} | "
            f"{fmt_cell(r, 'G', 3)} | {fmt_cell(r, 'CCT', 0)} | {r['out_of_range']} |"
        )
    met = [r for r in rows if meets_goal(r)]
    near = [
        r for r in rows if r["LER"] <= GOAL["LER"] and r["CCT"] <= GOAL["CCT"]
    ]  # fmt: skip
    if met:
        first = met[0]
        lines += [
            "",
            f"The goal is met by the direct estimate with {label(first['band_set'])}"
            f" and the surface {first['surface']}.",
        ]
    elif near:
        first = near[0]
        g = direct["by_class"][f"{first['band_set']}/{first['surface']}"]
        worst = max(g.items(), key=lambda kv: kv[1]["G"] or 0.0)
        lines += [
            "",
            f"With {label(first['band_set'])} and the surface {first['surface']}, "
            f"the direct estimate meets the goal for LER ({first['LER']:.1f} lm/W) "
            f"and CCT ({first['CCT']:.0f} K) on lamps no estimator has seen, but "
            f"not for G ({first['G']:.3f}; most in {worst[0]}, "
            f"{worst[1]['G']:.2f}: lamps with almost no light below 500 nm, "
            "whose G the noise sets). With the surface unknown it does worse than "
            "the library-based estimator: without a lamp library the surface is "
            "the confounder, with one the library is.",
        ]
    return lines


def band_definitions() -> dict:
    """Each band set's bands: count, centres and FWHMs [nm]."""
    # lazy: JAX is configured by the study's main before bands are built
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
        "goal for this estimator, whose estimates are built from the library's "
        "lamps: what limits a lamp the library lacks is the prior's coverage of "
        "lamp kinds (`make estimate-library`: the same estimator meets the goal "
        "on lamps its prior holds), not the band count."
    )


def figure(summary: dict, path) -> None:
    """Class-balanced MAE per band set (mean ± SD over partitions) with the
    goal and the nearest-library-lamp error as lines, and the library-free
    direct estimate per surface mode as markers."""
    import matplotlib  # plotting only: start-up time

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt  # after matplotlib.use("Agg")

    rows = [r for r in summary["rows"] if r["estimator"] == DEFAULT]
    near = ((summary.get("extra") or {}).get("nearest_lamp") or {}).get("nearest")
    direct = ((summary.get("extra") or {}).get("direct") or {}).get("rows") or []
    fig, axes = plt.subplots(1, 3, figsize=(13, 3.2), sharey=True)
    y = np.arange(len(rows))[::-1]
    for ax, (m, unit) in zip(
        axes, (("LER", "lm/W"), ("G", "1"), ("CCT", "K")), strict=True
    ):
        ax.barh(y, [r[m] for r in rows], xerr=[r.get(f"{m}_sd") or 0 for r in rows],
                color="C8", capsize=2,
                label="evaluate's estimator, surface unknown")  # fmt: skip
        for mode, marker in zip(DIRECT_SURFACES, ("x", "o", "^"), strict=True):
            pts = [
                (y[j], d[m])
                for j, r in enumerate(rows)
                for d in direct
                if d["band_set"] == r["band_set"] and d["surface"] == mode
            ]
            if pts:
                yy, vv = zip(*pts, strict=True)
                ax.plot(vv, yy, marker, color="k", ls="none",
                        label=f"direct, surface {mode}")  # fmt: skip
        ax.axvline(GOAL[m], color="C2", ls="--", label="goal")
        if near:
            ax.axvline(near[m], color="C3", ls=":", label="nearest library lamp")
        ax.set_yticks(y, [r["band_set"] for r in rows], fontsize=8)
        ax.set_xlabel(f"class-balanced MAE {m} [{unit}]")
        ax.grid(axis="x", alpha=0.3)
    handles, labels = axes[0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="lower center", ncol=3, fontsize=8, frameon=False)
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
        "`make study NAME=estimate-bands`)",
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
        *rows_table(summary["rows"], surface=False, label=label),
    ]
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
    direct = (summary.get("extra") or {}).get("direct")
    if direct:
        lines += direct_lines(direct, label)
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
        "direct": direct_summary(sorted({r["partition"] for r in records})),
    },
)
"""The study (`bandopt.studies.Study`)."""
