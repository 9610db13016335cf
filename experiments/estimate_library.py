"""How much of the held-out error is the library's coverage (issue 12).

`make estimate-defaults` scores `bandopt evaluate`'s estimator on lamps the
library does not hold: each outer fold's test lamps are left out of its
prior. This run scores the same estimator, scenes and lamp partitions twice
per band set (surface unknown, Moon told; our bands and the two best
reference sensors):

- held out: every outer fold's test lamps, as `make estimate-defaults`;
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

    python -m experiments.estimate_library [--partitions 4] [--out DIR]
        [--resume] [--only-partitions P ...]

Writes `records.jsonl` (one record per scored lamp; `scored`: "test" or
"train"), `summary.json`, `errors.png`, `manifest.json` and the
`estimate-library` section of `results/README.md` (default output only).
"""

import argparse
import json
import time
from pathlib import Path

from experiments.estimate import _fmt, band_set, diff_cells, load_records
from experiments.estimate_defaults import DEFAULT
from experiments.estimate_mix import UNKNOWN_ONLY, figure, log
from experiments.estimate_shift import by_class


OUT = "results/estimate_library"
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


def unit(p: int, name: str) -> list[dict]:
    """Records of one (partition, band set): held-out scores of every outer
    fold and in-library scores of fold `FOLD`'s training lamps."""
    from bandopt import inversion as inv_mod
    from bandopt.search import get_context

    ctx = get_context("search", None, p, "auto")
    bands = band_set(name)
    held = inv_mod.cross_validate(ctx, bands, estimators=(DEFAULT,), seed=p)
    own = inv_mod.cross_validate(
        ctx, bands, estimators=(DEFAULT,), seed=p, folds=[FOLD], scored="train"
    )
    for r in held:
        r["scored"] = "test"
    for r in held + own:
        r.update(partition=p, band_set=name)
    return held + own


def relabel(records: list[dict]) -> list[dict]:
    """Copies of `records` labelled for the summary: every held-out record as
    `DEFAULT`, the held-out records of lamps scored in library (same
    partition and band set) also as `HELD`, the in-library ones as `OWN`."""
    own = {
        (r["partition"], r["band_set"], r["lamp"])
        for r in records
        if r["scored"] == "train"
    }
    out = []
    for r in records:
        if r["scored"] == "train":
            out.append({**r, "estimator": OWN})
            continue
        out.append(dict(r))
        if (r["partition"], r["band_set"], r["lamp"]) in own:
            out.append({**r, "estimator": HELD})
    return out


def summarise(records: list[dict], partitions: int) -> dict:
    from bandopt import inversion as inv_mod

    recs = relabel(records)
    rows = inv_mod.summarise(recs)
    order = {b: i for i, b in enumerate(BAND_SETS)}
    labels = (DEFAULT, HELD, OWN)
    rows.sort(key=lambda r: (order[r["band_set"]], labels.index(r["estimator"])))
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
        "by_class": by_class(recs, (HELD, OWN)),
        "bands": {"recommended": "results/search/recommended_bands.json"},
        "scored_lamps": "measured lamps only",
        "modelled_lamps_used": True,
    }


def readme_text(summary: dict) -> str:
    rows = {(r["band_set"], r["estimator"]): r for r in summary["rows"]}
    lines = [
        f"{HEADING} (`results/estimate_library/`, `make estimate-library`)",
        "",
        "`bandopt evaluate`'s estimator (`"
        + DEFAULT
        + "`: surface unknown, the Moon told) on the scenes, lamp partitions and "
        "folds of `make estimate`, our bands and the two best reference sensors. "
        "*Held out*: each lamp scored by the outer fold that leaves it out of the "
        "prior (as in `make estimate-defaults`). *In library*: outer fold "
        f"{summary['fold_in_library']}'s training lamps, which its prior holds, "
        "scored by that fold: what is left when the library has a measured "
        "spectrum of the very lamp (surface, Moon, atmosphere, noise and the "
        "bands). The two are paired on the same lamps (about 4/5 of each "
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
    for r in summary["rows"]:
        cov = "/".join(
            "n/a" if r.get(f"{m}_covered") is None else f"{r[f'{m}_covered']:.2f}"
            for m in ("LER", "G", "CCT")
        )
        lines.append(
            f"| {r['band_set']} | {names[r['estimator']]} | "
            f"{r['lamps_per_partition']} | {_fmt(r, 'LER', 1)} | {_fmt(r, 'G', 3)} | "
            f"{_fmt(r, 'CCT', 0)} | {_fmt(r, 'CCT_mired', 1)} | {cov} | "
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
        if p.get("vs") != HELD:
            continue
        cells = diff_cells(p, [(c, DIGITS[c]) for c in COLUMNS])
        lines.append(f"| {p['band_set']} | " + " | ".join(cells) + " |")
    lines += [
        "",
        "Reference sensors minus recommended bands, paired by partition:",
        "",
        "| compared | scored | LER [lm/W] | G | CCT [K] |",
        "|---|---|---|---|---|",
    ]
    for p in summary["paired"]:
        if p.get("vs") == HELD:
            continue
        lines.append(
            f"| {p['band_set']} − {p['vs']} | {names[p['estimator']]} | "
            + " | ".join(diff_cells(p))
            + " |"
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
            f"{goal['G']:g} / {goal['CCT']:g} K ("
            + (
                "met for " + ", ".join(met) if met else "met for none of them"
            )
            + "); held out, the same lamps: "
            f"{held['LER']:.1f} / {held['G']:.3f} / {held['CCT']:.0f} K. The "
            "lamp's absence from the library is "
            + ", ".join(f"{share[m]:.0%} of the {m} error" for m in GOAL)
            + ".",
        ]
    classes = summary.get("by_class") or {}
    if classes.get(HELD) and classes.get(OWN):
        cells = []
        for c in classes[HELD]:
            a, b = classes[HELD][c], classes[OWN].get(c, {})
            if a.get("LER") is None or b.get("LER") is None:
                continue
            cells.append(
                f"{c} ({a['lamps']}) {a['LER']:.1f} → {b['LER']:.1f} lm/W, "
                f"CCT {a['CCT']:.0f} → {b['CCT']:.0f} K"
            )
        lines += [
            "",
            "Per class (recommended bands, mean over lamps and partitions; "
            "lamps per class), held out → in library: " + "; ".join(cells) + ".",
        ]
    return "\n".join(lines) + "\n"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--partitions", type=int, default=4, help="lamp partitions")
    ap.add_argument("--out", default=None, help=f"output (default {OUT})")
    ap.add_argument(
        "--resume",
        action="store_true",
        help="keep finished (partition, band set) units of records.jsonl",
    )
    ap.add_argument(
        "--only-partitions",
        type=int,
        nargs="+",
        default=None,
        metavar="P",
        help="compute only these partitions' units (to run partitions in "
        "parallel processes with their own --out; concatenate their "
        "records.jsonl and summarise with --resume)",
    )
    args = ap.parse_args(argv)
    if args.partitions < 1:
        ap.error("--partitions must be >= 1.")
    only = args.only_partitions
    if only is not None and any(not 0 <= p < args.partitions for p in only):
        ap.error(f"--only-partitions {only}: each must be in 0..{args.partitions - 1}.")
    if only is not None and args.out is None:
        ap.error("--only-partitions needs its own --out (a partial summary).")
    only = range(args.partitions) if only is None else only

    from bandopt._config import configure

    configure()
    from bandopt.provenance import write_manifest
    from bandopt.results import update_readme_section

    out = Path(args.out or OUT)
    out.mkdir(parents=True, exist_ok=True)
    rec_path = out / "records.jsonl"
    records, done = load_records(rec_path, keep=args.resume, say=log)
    t0 = time.time()
    units = [(p, b) for p in only for b in BAND_SETS]
    for j, (p, name) in enumerate(units):
        if (p, name) in done:
            continue
        t1 = time.time()
        recs = unit(p, name)
        with rec_path.open("a") as fh:  # a finished unit is kept
            for r in recs:
                fh.write(json.dumps(r) + "\n")
        records += recs
        log(
            f"partition {p}, {name}: {time.time() - t1:.0f} s "
            f"({j + 1}/{len(units)} units, {time.time() - t0:.0f} s)"
        )
    summary = summarise(records, args.partitions)
    (out / "summary.json").write_text(json.dumps(summary, indent=2) + "\n")
    figure(summary, out / "errors.png")
    if args.out is None:
        update_readme_section("estimate-library", readme_text(summary), heading=HEADING)
    write_manifest(
        out,
        seed=0,
        config={
            "partitions": args.partitions,
            "study": "estimate-library",
            "band_sets": list(BAND_SETS),
            "estimator": DEFAULT,
            "fold_in_library": FOLD,
            "scored_lamps": "measured lamps only",
            "training_lamps": "measured lamps, their same-class mixtures, "
            "wavelength-shifted copies of direct-emission LEDs and the library's "
            "modelled incandescent spectra (Planck's law)",
            "modelled_lamps_used": True,
        },
    )
    log(f"done: {out} ({time.time() - t0:.0f} s)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
