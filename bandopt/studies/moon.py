"""Where the estimate's G error comes from: the Moon.

`make estimate` scores the recommended bands on the band search's scenario
preset ("search": 4 surfaces x 2 atmospheres x Moon none/full x P1/P6, no
photon noise) and finds G 0.84; the search's own judge (8 scenes per lamp at
P4, photon noise, no Moon) finds 0.37 for the same bands and estimator. This
splits the preset by Moon state, on the same lamp partitions and folds: the
same scenes without the Moon, and with the full Moon only. Inversion (surface
unknown) fitting the Moon's brightness, the inversion told it (known from the
acquisition's time and place: `inversion-moon`), and the bounded ridge;
recommended bands, measured lamps only. On the scenes of `make estimate`
also `inversion-moon-loco`: the told-Moon inversion with its 90 % intervals
calibrated on training classes held out in turn instead of held-out lamps
of known classes (same point estimates; meant for lamp types the prior does
not hold), and the unseen-types study for all three inversions.

    python -m experiments.estimate_moon [--partitions 4] [--out DIR]

Writes `summary.json` (class-balanced MAE per Moon state and estimator, mean
± SD over partitions, per class for G; paired differences; the unseen-types
study of `make estimate` with the Moon fitted and told), `records.jsonl`,
`manifest.json`
and the `estimate-moon` section of `results/README.md` (default output only).
"""

import argparse
import sys
import time
from pathlib import Path

import numpy as np

from .. import inversion as inv_mod
from ..provenance import add_allow_dirty, refuse_dirty_at_start, write_manifest
from ..results import bands_record, update_readme_section
from ..search import PRESETS, get_context
from ..strict_json import strict_dumps
from ._study import unseen_records
from ._text import diff_cells, held_out, unseen_lines
from ._units import band_set


MOON_STATES = {
    "none and full (as make estimate)": None,
    "none": (None,),
    "full": ("full",),
}
"""Moon states of each scene set (None: the preset's own, Moon none and full)."""
BAND_SETS = ("recommended", "sdgsat-1", "nightsat", "viirs-dnb")
"""Band sets scored on the scenes of `make estimate` (the Moon split: only
the recommended bands)."""
ESTIMATORS = ("inversion", "inversion-moon", "ridge")
"""The inversion fitting the Moon's brightness (as `make estimate`), the
inversion told it (`bandopt.inversion.MOON_ESTIMATOR`: known from the time
and place of the acquisition), and the bounded ridge."""
LOCO = "inversion-moon-loco"
"""`bandopt.inversion.MOON_UNSEEN_ESTIMATOR`, scored on the scenes of `make
estimate` only (its point estimates are `inversion-moon`'s)."""
UNSEEN = ("inversion", "inversion-moon", LOCO)
"""Unseen-types runs (`bandopt.inversion.options_of`): the Moon fitted,
told, and told with intervals calibrated on classes held out in turn."""


def log(msg: str) -> None:
    print(
        f"[estimate_moon {time.strftime('%H:%M:%S')}] {msg}",
        file=sys.stderr,
        flush=True,
    )


def preset_name(moons) -> str:
    """The scenario preset of a Moon state set (registered on first use)."""
    if moons is None:
        return "search"
    name = "search_moon_" + "_".join("none" if m is None else m for m in moons)
    PRESETS.setdefault(name, dict(PRESETS["search"], moons=tuple(moons)))
    return name


def g_by_class(records, estimator: str) -> dict:
    """Mean G error per level-2 class (all partitions) of one estimator."""
    out: dict[str, list] = {}
    for r in records:
        if r["estimator"] == estimator and r.get("G") is not None:
            out.setdefault(r["level2"], []).append(r["G"])
    return {c: float(np.mean(v)) for c, v in sorted(out.items())}


def readme_text(summary: dict) -> str:
    lines = [
        "## Where the G error comes from: the Moon (`results/estimate_moon/`, "
        "`make estimate-moon`)",
        "",
        "The scenes of `make estimate` (search preset, no photon noise), and for "
        "the recommended bands the same scenes split by Moon state; same lamp "
        "partitions and folds; class-balanced MAE, mean ± SD over "
        f"{summary['partitions']} partitions; measured lamps only. "
        "`inversion` fits the Moon's brightness, `inversion-moon` is told it "
        "(known from the acquisition's time and place), `inversion-moon-loco` "
        "is told it and calibrates its 90 % intervals on training classes held "
        "out in turn (same estimates as `inversion-moon`). Coverage: fraction of "
        "true values inside the 90 % intervals. Generated from `summary.json`.",
        "",
        "| Moon | band set | estimator | LER [lm/W] | G | CCT [K] | G: amber LED "
        "| G: mercury | G: metal halide | coverage LER/G/CCT |",
        "|---|---|---|---|---|---|---|---|---|---|",
    ]
    for row in summary["rows"]:
        g = row["G_by_class"]

        def cell(m, d, row=row):
            return f"{row[m]:.{d}f} ± {row[m + '_sd']:.{d}f}"

        per_class = " | ".join(
            f"{g.get(c, float('nan')):.2f}"
            for c in ("led_amber", "mercury", "metal_halide")
        )
        cov = row.get("coverage") or {}
        cov_cell = (
            "/".join(f"{cov[m]:.2f}" for m in ("LER", "G", "CCT"))
            if all(cov.get(m) is not None for m in ("LER", "G", "CCT"))
            else "n/a"
        )
        lines.append(
            f"| {row['moon']} | {row.get('band_set', 'recommended')} | "
            f"{row['estimator']} | {cell('LER', 1)} | "
            f"{cell('G', 3)} | {cell('CCT', 0)} | {per_class} | {cov_cell} |"
        )
    if summary.get("paired"):
        lines += [
            "",
            "Paired by partition on the scenes of `make estimate` (positive = the "
            "first is worse): reference sensor minus recommended, same estimator; "
            "and `inversion-moon` minus `inversion`, same band set.",
            "",
            "| compared | estimator | LER [lm/W] | G | CCT [K] |",
            "|---|---|---|---|---|",
        ]
        for p in summary["paired"]:
            what = (
                f"{p['band_set']} − {p['vs']}"
                if p["estimator"] != "inversion-moon" or p["vs"] != "inversion"
                else f"{p['band_set']}: inversion-moon − inversion"
            )
            cells = diff_cells(p)
            lines.append(f"| {what} | {p['estimator']} | " + " | ".join(cells) + " |")
    lines += unseen_lines(summary.get("unseen_types"))
    return "\n".join(lines) + "\n"


def run(argv=None) -> int:
    """Compute the study (command line `argv`) and write its outputs;
    returns the exit status."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument(
        "--partitions", type=int, default=4, help="lamp partitions (default 4)"
    )
    ap.add_argument(
        "--out", default=None, help="output folder (default results/estimate_moon)"
    )
    add_allow_dirty(ap)
    args = ap.parse_args(argv)
    if args.partitions < 1:
        ap.error("--partitions must be >= 1.")

    out = Path(args.out or "results/estimate_moon")
    refuse_dirty_at_start(ap, args, out)
    out.mkdir(parents=True, exist_ok=True)
    rows, all_recs, paired = [], [], []
    t0 = time.time()
    for label, moons in MOON_STATES.items():
        names = BAND_SETS if moons is None else ("recommended",)
        ests = (*ESTIMATORS, LOCO) if moons is None else ESTIMATORS
        recs = []
        for p in range(args.partitions):
            ctx = get_context(preset_name(moons), None, p, "auto")
            for name in names:
                r = inv_mod.cross_validate(
                    ctx,
                    band_set(name),
                    estimators=ests,
                    surface_modes=("unknown",),
                    seed=p,
                )
                recs += [x.as_record(partition=p, band_set=name, moon=label) for x in r]
                log(f"Moon {label}, partition {p}, {name}: {time.time() - t0:.0f} s")
        summ = inv_mod.summarise(recs)
        for s in summ:
            rows.append(
                {
                    "moon": label,
                    "band_set": s["band_set"],
                    "estimator": s["estimator"],
                    **{
                        k: s.get(k)
                        for k in ("LER", "LER_sd", "G", "G_sd", "CCT", "CCT_sd")
                    },
                    "coverage": {m: s.get(f"{m}_covered") for m in ("LER", "G", "CCT")},
                    "G_by_class": g_by_class(
                        [r for r in recs if r["band_set"] == s["band_set"]],
                        s["estimator"],
                    ),
                    "scenes_per_lamp": int(ctx.toa.shape[1]),
                }
            )
        if moons is None:
            for name in names[1:]:
                paired += inv_mod.paired_differences(summ, "recommended", name)
            paired += inv_mod.estimator_differences(
                summ, [(inv_mod.MOON_ESTIMATOR, "inversion")]
            )
        all_recs += recs
    # unseen lamp types (each scored class held out), recommended bands

    unseen = {}
    ctx = get_context("search", None, 0, "auto")
    for label in UNSEEN:
        recs = unseen_records(ctx, band_set("recommended"), label)
        unseen[label] = held_out(recs)
        log(f"unseen types, {label}: {time.time() - t0:.0f} s")
    summary = {
        "partitions": args.partitions,
        "unseen_types": unseen,
        "bands": {"recommended": bands_record(band_set("recommended"))},
        "rows": rows,
        "paired": paired,
    }
    (out / "summary.json").write_text(strict_dumps(summary, indent=2) + "\n")
    with (out / "records.jsonl").open("w") as fh:
        for r in all_recs:
            fh.write(strict_dumps(r, indent=None) + "\n")
    if args.out is None:
        update_readme_section(
            "estimate-moon",
            readme_text(summary),
            heading="## Where the G error comes from: the Moon",
        )
    write_manifest(
        out,
        seed=0,
        config={
            "partitions": args.partitions,
            "moon_states": {k: v for k, v in MOON_STATES.items()},
            "estimators": list(ESTIMATORS),
            "estimators_on_make_estimate_scenes": [*ESTIMATORS, LOCO],
            "unseen_types": [
                {
                    "label": u,
                    "moon_known": inv_mod.options_of(u).moon_told,
                    "interval_calibration": inv_mod.options_of(u).calibration,
                }
                for u in UNSEEN
            ],
            "scored_lamps": "measured lamps only",
            "training_lamps": "measured lamps only",
        },
    )
    log(f"done: {out} ({time.time() - t0:.0f} s)")
    return 0
