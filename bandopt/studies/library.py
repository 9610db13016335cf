"""How much of the held-out error is the library's coverage.

`make study NAME=estimate-defaults` scores `bandopt evaluate`'s estimator on lamps the
library does not hold: each outer fold's test lamps are left out of its
prior. This run scores the same estimator, scenes and lamp partitions twice
per band set (surface unknown, Moon told; our bands and the two best
reference sensors):

- held out: every outer fold's test lamps, as `make study NAME=estimate-defaults`;
- in library: outer fold 0's training lamps, which its prior holds
  (`cross_validate(scored="train")`): the error left when the library has a
  measured spectrum of the very lamp (the bands' and the inversion's own
  limit: surface, Moon, atmosphere and noise).

The two are paired on the same lamps (fold 0's training lamps, about 4/5 of
each partition's; their held-out scores come from folds 1-4) and by
partition: class-balanced MAE per partition, mean ± SD over partitions.
Their difference is what a lamp the library lacks costs; a library that
held every lamp kind a user meets would bring the held-out error down to
the in-library one, no better. Modelled (Planck) spectra train, never score.

What knowing the surface adds, held out and in library (our bands): the
same units with the surface's class known, or its reflectance measured by
Sentinel-2 in daytime (`SURFACES`), paired against the surface unknown.

How fast the held-out error falls with the library's size: the same folds
with each outer fold trained on `FRACTIONS` of its training lamps per class
(`cross_validate(train_fraction=)`; our bands), against the whole library,
and the size at which `E(N) = E_lib + a N^-b` (`E_lib` the in-library error,
`a`, `b` fitted to the measured sizes) would reach the goal: an
extrapolation, said as one.

    python -m experiments.estimate_library [--partitions 4] [--out DIR]
        [--resume] [--only-partitions P ...]

Writes `records.jsonl` (one record per scored lamp; `scored`: "test" or
"train"; `train_fraction` on the smaller libraries' records),
`summary.json`, `errors.png`, `library_size.png`, `manifest.json` and the
`estimate-library` section of `results/README.md` (default output only).
"""

import time
from pathlib import Path

import numpy as np

from .. import inversion as inv_mod
from ..results import bands_record
from ..search import get_context
from ._study import UNKNOWN_ONLY, figure
from ._text import by_class, class_change_cells, diff_cells, fmt_cell, reference_lines
from ._units import (
    band_set,
    keep_unit,
    load_records,
    log as _log,
    partition_args,
    write_outputs,
)
from .ablations.defaults import DEFAULT


OUT = "results/estimate_library"


def log(msg: str) -> None:
    """Progress line on stderr, `[estimate_library HH:MM:SS] msg`."""
    _log(msg, "estimate_library")


BAND_SETS = tuple(UNKNOWN_ONLY)
"""Our bands and the two best reference sensors, surface unknown."""
FOLD = 0
"""The outer fold whose training lamps are scored in library."""
HELD = f"{DEFAULT} (held out)"
"""Label of the held-out scores of the lamps scored in library."""
OWN = f"{DEFAULT} (in library)"
"""Label of the in-library scores."""
COLUMNS = ("LER", "G", "CCT", "CCT_mired", "LER_covered", "level1_correct")
"""Summary columns compared by partition, in library minus held out."""
DIGITS = {"LER": 1, "G": 3, "CCT": 0, "CCT_mired": 1, "LER_covered": 3,
          "level1_correct": 2}  # fmt: skip
GOAL = {"LER": 5.0, "G": 0.10, "CCT": 200.0}
"""Issue 12's goal for pan + 5 bands, surface unknown."""
HEADING = "## What a lamp the library lacks costs"
SURFACES = ("class", "measured")
"""What else the inversion may know of the surface (besides "unknown"), our
bands: its class, or its reflectance measured by Sentinel-2 in daytime."""
FRACTIONS = (0.25, 0.5, 0.75)
"""Shares of each outer fold's training lamps (per class) of the smaller
libraries (our bands; the whole library is the held-out run)."""


def unit_key(r: dict) -> tuple:
    """The unit a record belongs to: (partition, band set, library share,
    surface knowledge)."""
    return (r["partition"], r["band_set"], r.get("train_fraction", 1.0), r["surface"])


def unit(p: int, name: str, fraction: float = 1.0, surfaces=("unknown",)) -> list[dict]:
    """Records of one (partition, band set): held-out scores of every outer
    fold and in-library scores of fold `FOLD`'s training lamps, in each
    surface mode of `surfaces`; with `fraction` < 1, only held-out scores,
    each fold trained on that share of its training lamps."""
    ctx = get_context("search", None, p, "auto")
    bands = band_set(name)
    kw = dict(estimators=(DEFAULT,), seed=p, surface_modes=tuple(surfaces))
    held = inv_mod.cross_validate(ctx, bands, train_fraction=fraction, **kw)
    if fraction < 1.0:
        return [r.as_record(scored="test", partition=p, band_set=name) for r in held]
    own = inv_mod.cross_validate(ctx, bands, folds=[FOLD], scored="train", **kw)
    # held-out records say their fold's training lamps (the smaller ones do too)
    return [
        r.as_record(
            scored="test",
            train_lamps=len(ctx.splits[r.fold].train),
            partition=p,
            band_set=name,
        )
        for r in held
    ] + [r.as_record(partition=p, band_set=name) for r in own]


def relabel(records: list[dict]) -> list[dict]:
    """Copies of `records` labelled for the summary: every held-out record as
    `DEFAULT`, the held-out records of lamps scored in library (same
    partition, band set and surface mode) also as `HELD`, the in-library ones
    as `OWN`. The smaller libraries' records are left out."""
    records = [r for r in records if "train_fraction" not in r]
    own = {
        (r["partition"], r["band_set"], r["surface"], r["lamp"])
        for r in records
        if r["scored"] == "train"
    }
    out = []
    for r in records:
        if r["scored"] == "train":
            out.append({**r, "estimator": OWN})
            continue
        out.append(dict(r))
        if (r["partition"], r["band_set"], r["surface"], r["lamp"]) in own:
            out.append({**r, "estimator": HELD})
    return out


def library_size(records: list[dict], goal=GOAL) -> dict:
    """Our bands' held-out error against the library's size: per share of
    the training lamps (1: the whole library), the class-balanced MAE (mean
    ± SD over partitions) and the mean number of training lamps per outer
    fold; per metric the fit of `E(N) = E_lib + a N^-b` to the mean errors
    (`E_lib`: the in-library error; least squares on `log(E - E_lib)`
    against `log N`, sizes whose error is not above `E_lib` left out) and
    the number of training lamps at which it reaches the goal (None when
    `E_lib` is not below the goal, or fewer than two sizes are usable, or
    the fit does not fall)."""
    ours = [
        r for r in records
        if r["band_set"] == "recommended" and r["surface"] == "unknown"
    ]  # fmt: skip
    held = [{**r, "estimator": str(r.get("train_fraction", 1.0))} for r in ours
            if r["scored"] == "test"]  # fmt: skip
    rows = inv_mod.summarise(held, keys=("estimator",))
    sizes = []
    for row in sorted(rows, key=lambda r: float(r["estimator"])):
        f = float(row["estimator"])
        n_train = [
            r["train_lamps"] for r in held
            if r["estimator"] == row["estimator"] and "train_lamps" in r
        ]  # fmt: skip
        n_lamps = float(np.mean(n_train)) if n_train else None
        cols = [k for m in ("LER", "G", "CCT")
                for k in (m, f"{m}_sd", f"{m}_per_partition")]  # fmt: skip
        sizes.append(
            {"fraction": f, "train_lamps": n_lamps, **{k: row.get(k) for k in cols}}
        )
    own = inv_mod.summarise(
        [{**r, "estimator": OWN} for r in ours if r["scored"] == "train"],
        keys=("estimator",),
    )
    floor = {m: own[0].get(m) for m in ("LER", "G", "CCT")} if own else {}
    fits = {}
    for m in ("LER", "G", "CCT"):
        e_lib = floor.get(m)
        pts = [(s["train_lamps"], s[m]) for s in sizes
               if e_lib is not None and s[m] is not None and s["train_lamps"]
               and s[m] > e_lib]  # fmt: skip
        fit = {"E_lib": e_lib, "sizes_used": len(pts), "a": None, "b": None,
               "lamps_for_goal": None}  # fmt: skip
        if len(pts) >= 2:
            x = np.log([p[0] for p in pts])
            y = np.log([p[1] - e_lib for p in pts])
            slope, icpt = np.polyfit(x, y, 1)
            fit["a"], fit["b"] = float(np.exp(icpt)), float(-slope)
            if e_lib < goal[m] and fit["b"] > 0:
                fit["lamps_for_goal"] = float(
                    (fit["a"] / (goal[m] - e_lib)) ** (1.0 / fit["b"])
                )
        fits[m] = fit
    return {"sizes": sizes, "fit": fits}


def surface_knowledge(rows: list[dict], columns=("LER", "G", "CCT")) -> list[dict]:
    """Our bands, held out and in library: each surface mode of `SURFACES`
    minus the surface unknown, paired by partition on the same lamps (mean,
    SD ddof 1, per column of `columns`)."""
    by = {(r["estimator"], r["surface"]): r for r in rows
          if r["band_set"] == "recommended"}  # fmt: skip
    out = []
    for est in (HELD, OWN):
        base = by.get((est, "unknown"))
        for mode in SURFACES:
            row = by.get((est, mode))
            if base is None or row is None:
                continue
            d = {"estimator": est, "surface": mode, "vs": "unknown"}
            for c in columns:
                a, b = row.get(f"{c}_per_partition"), base.get(f"{c}_per_partition")
                if a and b and len(a) == len(b):
                    x = np.asarray(a) - np.asarray(b)
                    d[f"{c}_diff"] = float(x.mean())
                    d[f"{c}_diff_sd"] = float(x.std(ddof=1)) if x.size > 1 else None
            out.append(d)
    return out


def summarise(records: list[dict], partitions: int) -> dict:
    recs = relabel(records)
    rows = inv_mod.summarise(recs)
    order = {b: i for i, b in enumerate(BAND_SETS)}
    labels = (DEFAULT, HELD, OWN)
    modes = ("unknown", *SURFACES)
    rows.sort(
        key=lambda r: (
            order[r["band_set"]],
            modes.index(r["surface"]),
            labels.index(r["estimator"]),
        )
    )
    paired = inv_mod.estimator_differences(rows, ((OWN, HELD),), COLUMNS)
    for name in BAND_SETS[1:]:
        paired += [
            p
            for p in inv_mod.paired_differences(rows, "recommended", name)
            if p["estimator"] in (HELD, OWN)
        ]
    return {
        "partitions": partitions,
        "estimators": list(labels),
        "title": "Measured lamps, surface unknown, Moon told: evaluate's estimator "
        "on lamps the library lacks (held out) and holds (in library)",
        "fold_in_library": FOLD,
        "goal": GOAL,
        "rows": rows,
        "paired": paired,
        "by_class": by_class(
            [r for r in recs if r["surface"] == "unknown"], (HELD, OWN)
        ),
        "surface_knowledge": surface_knowledge(rows),
        "library_size": library_size(records),
        "bands": {"recommended": bands_record(band_set("recommended"))},
        "scored_lamps": "measured lamps only",
        "modelled_lamps_used": True,
    }


def readme_text(summary: dict) -> str:
    unknown = [r for r in summary["rows"] if r["surface"] == "unknown"]
    rows = {(r["band_set"], r["estimator"]): r for r in unknown}
    lines = [
        f"{HEADING} (`results/estimate_library/`, `make estimate-library`)",
        "",
        "`bandopt evaluate`'s estimator (`"
        + DEFAULT
        + "`: surface unknown, the Moon told) on the scenes, lamp partitions and "
        "folds of `make estimate`, our bands and the two best reference sensors. "
        "*Held out*: each lamp scored by the outer fold that leaves it out of the "
        "prior (as in `make study NAME=estimate-defaults`). *In library*: outer fold "
        f"{summary['fold_in_library']}'s training lamps, which its prior holds, "
        "scored by that fold: what is left when the library has a measured "
        "spectrum of the very lamp (surface, Moon, atmosphere, noise and the "
        "bands; these lamps' pixels also served the inner folds' choices of the "
        "band-error model and the interval factors, so their coverage is no "
        "calibration check). The two are paired on the same lamps (about 4/5 of each "
        "partition's) and by partition; class-balanced MAE, mean ± SD over "
        f"{summary['partitions']} partitions. Scored lamps are measured ones; the "
        "priors hold the library's modelled Planck spectra. Generated from "
        "`summary.json`.",
        "",
        "| band set | scored | lamps | LER [lm/W] | G | CCT [K] | CCT [mired] "
        "| coverage LER/G/CCT | level-1 right |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    names = {DEFAULT: "held out, all lamps", HELD: "held out", OWN: "in library"}
    for r in unknown:
        cov = "/".join(
            "n/a" if r.get(f"{m}_covered") is None else f"{r[f'{m}_covered']:.2f}"
            for m in ("LER", "G", "CCT")
        )
        lines.append(
            f"| {r['band_set']} | {names[r['estimator']]} | "
            f"{r['lamps_per_partition']} | {fmt_cell(r, 'LER', 1)} | "
            f"{fmt_cell(r, 'G', 3)} | "
            f"{fmt_cell(r, 'CCT', 0)} | {fmt_cell(r, 'CCT_mired', 1)} | {cov} | "
            f"{r['level1_correct']:.2f} |"
        )
    lines += [
        "",
        "Paired by partition on the same lamps, in library minus held out "
        "(negative: what the lamp's own spectrum in the library buys):",
        "",
        "| band set | LER [lm/W] | G | CCT [K] | CCT [mired] | coverage LER "
        "| level-1 right |",
        "|---|---|---|---|---|---|---|",
    ]
    for p in summary["paired"]:
        if p.get("vs") != HELD or p["surface"] != "unknown":
            continue
        cells = diff_cells(p, [(c, DIGITS[c]) for c in COLUMNS])
        lines.append(f"| {p['band_set']} | " + " | ".join(cells) + " |")
    lines += reference_lines(
        [p for p in summary["paired"] if p.get("vs") != HELD],
        "Reference sensors minus recommended bands, paired by partition:",
        "scored",
        names.get,
    )
    own, held = rows.get(("recommended", OWN)), rows.get(("recommended", HELD))
    if own and held:
        goal = summary["goal"]
        met = [m for m in GOAL if own[m] <= goal[m]]
        share = {m: 1 - own[m] / held[m] for m in GOAL}
        lines += [
            "",
            f"Our bands in library: {own['LER']:.1f} lm/W, G {own['G']:.3f}, "
            f"CCT {own['CCT']:.0f} K against the goal {goal['LER']:g} / "
            f"{goal['G']:.2f} / {goal['CCT']:g} K ("
            + ("met for " + ", ".join(met) if met else "met for none of them")
            + "); held out, the same lamps: "
            f"{held['LER']:.1f} / {held['G']:.3f} / {held['CCT']:.0f} K. The "
            "lamp's absence from the library is "
            + ", ".join(f"{share[m]:.0%} of the {m} error" for m in GOAL)
            + ".",
        ]
    size = summary.get("library_size") or {}
    if len(size.get("sizes", [])) > 1:
        lines += [
            "",
            "Our bands' held-out error against the library's size (each outer fold "
            "trained on a share of its training lamps per class, the same folds "
            "and test lamps; `library_size.png`):",
            "",
            "| training lamps | share | LER [lm/W] | G | CCT [K] |",
            "|---|---|---|---|---|",
        ]
        for z in size["sizes"]:
            n = "n/a" if z["train_lamps"] is None else f"{z['train_lamps']:.0f}"
            lines.append(
                f"| {n} | {z['fraction']:.0%} | {fmt_cell(z, 'LER', 1)} | "
                f"{fmt_cell(z, 'G', 3)} | {fmt_cell(z, 'CCT', 0)} |"
            )
        said = []
        for m, unit in (("LER", " lm/W"), ("G", ""), ("CCT", " K")):
            f = size["fit"][m]
            if f["E_lib"] is None:
                continue
            if f["E_lib"] >= summary["goal"][m]:
                said.append(
                    f"{m}: the in-library error ({f['E_lib']:.3g}{unit}) is not "
                    "below the goal, so no library size reaches it"
                )
            elif f["lamps_for_goal"] is None:
                said.append(f"{m}: the measured sizes give no falling fit")
            else:
                said.append(
                    f"{m}: E = {f['E_lib']:.3g}{unit} + {f['a']:.3g} N^-{f['b']:.2f}"
                    f", the goal at about {f['lamps_for_goal']:,.0f} training lamps"
                )
        lines += [
            "",
            "Fitted to the mean errors with the in-library error as the floor, "
            "E(N) = E_lib + a N^-b (an extrapolation beyond the sizes measured, "
            "with lamps as varied as this library's): " + "; ".join(said) + ".",
        ]
    knows = summary.get("surface_knowledge") or []
    if knows:
        by = {(r["estimator"], r["surface"]): r for r in summary["rows"]
              if r["band_set"] == "recommended"}  # fmt: skip
        lines += [
            "",
            "What knowing the surface adds (our bands; the surface's class, or its "
            "reflectance measured by Sentinel-2 in daytime, against unknown; paired "
            "by partition on the same lamps):",
            "",
            "| surface | scored | LER [lm/W] | G | CCT [K] | minus unknown: LER | G "
            "| CCT [K] |",
            "|---|---|---|---|---|---|---|---|",
        ]
        diffs = {(d["estimator"], d["surface"]): d for d in knows}
        for mode in ("unknown", *SURFACES):
            for est in (HELD, OWN):
                r = by.get((est, mode))
                if r is None:
                    continue
                d = diffs.get((est, mode))
                cells = diff_cells(d) if d else ["", "", ""]
                lines.append(
                    f"| {mode} | {names[est]} | {fmt_cell(r, 'LER', 1)} | "
                    f"{fmt_cell(r, 'G', 3)} | {fmt_cell(r, 'CCT', 0)} | "
                    + " | ".join(cells)
                    + " |"
                )
    classes = summary.get("by_class") or {}
    if classes.get(HELD) and classes.get(OWN):
        cells = class_change_cells(classes[HELD], classes[OWN])
        lines += [
            "",
            "Per class (recommended bands, mean over lamps and partitions; "
            "lamps per class), held out → in library: " + "; ".join(cells) + ".",
        ]
    return "\n".join(lines) + "\n"


def size_figure(summary: dict, path: Path) -> None:
    """Our bands' held-out error against the number of training lamps, with
    the in-library error and the goal as lines, one panel per metric."""
    import matplotlib  # plotting only: start-up time

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt  # after matplotlib.use("Agg")

    size = summary["library_size"]
    fig, axes = plt.subplots(1, 3, figsize=(13, 3.6))
    for ax, (m, unit) in zip(
        axes, (("LER", "lm/W"), ("G", "1"), ("CCT", "K")), strict=True
    ):
        z = [x for x in size["sizes"] if x["train_lamps"] and x[m] is not None]
        ax.errorbar([x["train_lamps"] for x in z], [x[m] for x in z],
                    yerr=[x[f"{m}_sd"] or 0.0 for x in z], marker="o", capsize=3,
                    label="held out")  # fmt: skip
        f = size["fit"][m]
        if f["E_lib"] is not None:
            ax.axhline(f["E_lib"], color="C2", ls="--", label="in library")
        ax.axhline(summary["goal"][m], color="C3", ls=":", label="goal")
        ax.set_xlabel("training lamps per outer fold")
        ax.set_ylabel(f"class-balanced MAE {m} [{unit}]")
        ax.set_ylim(bottom=0)
        ax.grid(alpha=0.3)
    axes[0].legend(fontsize=8)
    fig.suptitle("Our bands, evaluate's estimator: held-out error against the "
                 "library's size", fontsize=10)  # fmt: skip
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def run(argv=None) -> int:
    """Compute the study (command line `argv`: `partition_args` without
    `--no-unseen`) and write its outputs; returns the exit status."""
    args, only = partition_args(argv, __doc__.splitlines()[0], OUT, unseen=False)
    out = Path(args.out or OUT)
    out.mkdir(parents=True, exist_ok=True)
    rec_path = out / "records.jsonl"
    records, _ = load_records(rec_path, keep=args.resume, say=log)
    done = {unit_key(r) for r in records}
    t0 = time.time()
    one = ("unknown",)
    units = [(p, b, 1.0, one) for p in only for b in BAND_SETS]
    units += [(p, "recommended", f, one) for p in only for f in FRACTIONS]
    units += [(p, "recommended", 1.0, SURFACES) for p in only]
    for j, (p, name, f, modes) in enumerate(units):
        if all((p, name, f, m) in done for m in modes):
            continue
        t1 = time.time()
        records += keep_unit(rec_path, unit(p, name, f, modes))
        log(
            f"partition {p}, {name}, library share {f:g}, surface "
            f"{'/'.join(modes)}: {time.time() - t1:.0f} s "
            f"({j + 1}/{len(units)} units, {time.time() - t0:.0f} s)"
        )
    summary = summarise(records, args.partitions)
    return write_outputs(
        out,
        summary,
        [(figure, "errors.png"), (size_figure, "library_size.png")],
        section=("estimate-library", readme_text, HEADING)
        if args.out is None
        else None,
        seed=0,
        say=log,
        t0=t0,
        config={
            "partitions": args.partitions,
            "study": "estimate-library",
            "band_sets": list(BAND_SETS),
            "estimator": DEFAULT,
            "fold_in_library": FOLD,
            "library_fractions": [*FRACTIONS, 1.0],
            "surface_modes_ours": ["unknown", *SURFACES],
            "scored_lamps": "measured lamps only",
            "training_lamps": "measured lamps, their same-class mixtures, "
            "wavelength-shifted copies of direct-emission LEDs and the library's "
            "modelled incandescent spectra (Planck's law)",
            "modelled_lamps_used": True,
        },
    )
