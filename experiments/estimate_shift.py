"""Wavelength-shifted direct-emission LEDs in the prior (issue 12).

A direct-emission (semiconductor) LED's band sits where its composition
puts it and moves with junction temperature, so a new amber LED usually has
its band a few nm from every library LED's; a prior of measured lamps and
their blends cannot represent it (a blend of two narrow bands is two bands,
not one in between). This scores `inversion-moon-mix-metric-narrow` (the
estimator of `bandopt evaluate`: blends in the prior, the Moon told, one
band-error model per metric, the narrowest calibrated interval unit)
against `inversion-moon-mix-metric-narrow-shift`, the same with copies of
every prior's own direct-emission LEDs shifted by `PEAK_SHIFTS_NM`
(`bandopt.inversion.shifted_lamps`). Surface unknown, our bands and the two
best reference sensors, the scenes, lamp partitions and folds of `make
estimate`, paired by partition; and on unseen lamp types (recommended
bands, partition 0, intervals calibrated on training classes held out in
turn, as `bandopt evaluate` by default), without and with the shifts.

    python -m experiments.estimate_shift [--partitions 4] [--out DIR]
        [--resume] [--only-partitions P ...] [--no-unseen]

Writes `records.jsonl`, `summary.json`, `errors.png`, `manifest.json` and
the `estimate-shift` section of `results/README.md` (default output only),
as `experiments.estimate_mix` does (`Study`). Measured lamps only score;
the blends and shifted copies are built from each fit's training lamps only.
"""

import numpy as np

from experiments.estimate import _fmt, diff_cells, where_lines
from experiments.estimate_mix import UNKNOWN_ONLY, Study, main as _run, row_line


BASE = "inversion-moon-mix-metric-narrow"
SHIFT = "inversion-moon-mix-metric-narrow-shift"
"""Without and with shifted copies of direct-emission LEDs in every prior."""

GRID = (0.0, 0.01, 0.03, 0.1, 0.3, 1.0, 3.0, 10.0)
"""`bandopt.inversion.INTERVAL_OFFSET_GRID` (checked by the tests; named
here so `--help` needs no JAX)."""

SHIFTS = (-10.0, -7.5, -5.0, -2.5, 2.5, 5.0, 7.5, 10.0)
"""`bandopt.inversion.PEAK_SHIFTS_NM` (checked by the tests)."""

COLUMNS = ("LER", "G", "CCT", "CCT_mired", "LER_covered", "LER_width")
"""Summary columns compared by partition, shift minus base."""
PAIRED_DIGITS = {"LER": 1, "G": 3, "CCT": 0, "CCT_mired": 1, "LER_covered": 3,
                 "LER_width": 1}  # fmt: skip

CLASS_KEYS = ("LER", "G", "CCT", "CCT_mired", "LER_covered", "level1_correct")


def by_class(records, estimators=(BASE, SHIFT)) -> dict:
    """Recommended bands: per estimator and held-out level-2 class, the mean
    over lamps and partitions of each lamp's error, coverage and level-1
    rate (where a change to the prior acts, e.g. the shifts on the amber
    LEDs, and whether any other class pays for it)."""
    out: dict = {}
    for est in estimators:
        rs = [
            r for r in records
            if r["band_set"] == "recommended" and r["estimator"] == est
        ]  # fmt: skip
        out[est] = class_means(rs)
    return out


def class_means(records, keys=CLASS_KEYS) -> dict:
    """Per level-2 class of `records`, the mean over its lamps' records of
    each of `keys` (None where no record has it) and its number of lamps."""
    out: dict = {}
    for c in sorted({r["level2"] for r in records}):
        cr = [r for r in records if r["level2"] == c]
        out[c] = {
            k: float(np.mean(v)) if v else None
            for k in keys
            for v in [[r[k] for r in cr if r.get(k) is not None]]
        }
        out[c]["lamps"] = len({r["lamp"] for r in cr})
    return out


def readme_text(summary: dict) -> str:
    shifts = ", ".join(f"{x:+g}" for x in summary["peak_shifts_nm"])
    return variant_text(
        summary,
        SHIFT,
        "## Shifted direct-emission LEDs in the prior "
        "(`results/estimate_shift/`, `make estimate-shift`)",
        f"`{SHIFT}` also holds, in every prior it builds, copies of that prior's "
        "own direct-emission LEDs (one visible band at most 40 nm wide: in this "
        f"library the four direct amber LEDs) shifted by {shifts} nm.",
        "without → with shifts",
    )


def class_change_cells(before: dict, after: dict) -> list[str]:
    """Per level-2 class of `before` ({class: by_class row}) that both hold an
    LER for: "class (lamps) LER → LER lm/W, CCT CCT → CCT K", the README's
    per-class sentence of a change."""
    cells = []
    for c, a in before.items():
        b = after.get(c, {})
        if a.get("LER") is None or b.get("LER") is None:
            continue
        cells.append(
            f"{c} ({a['lamps']}) {a['LER']:.1f} → {b['LER']:.1f} lm/W, "
            f"CCT {a['CCT']:.0f} → {b['CCT']:.0f} K"
        )
    return cells


def reference_lines(paired, title: str, column: str, label=None) -> list[str]:
    """README lines: `title` and a table of reference sensors minus the
    recommended bands (`paired` rows of `paired_differences`), LER, G and
    CCT differences; `column` heads the estimator column, whose cells are
    `label(estimator)` (default the estimator's name)."""
    lines = [
        "",
        title,
        "",
        f"| compared | {column} | LER [lm/W] | G | CCT [K] |",
        "|---|---|---|---|---|",
    ]
    for p in paired:
        est = p["estimator"] if label is None else label(p["estimator"])
        cells = " | ".join(diff_cells(p))
        lines.append(f"| {p['band_set']} − {p['vs']} | {est} | {cells} |")
    return lines


def variant_text(
    summary: dict,
    variant: str,
    heading: str,
    what: str,
    change: str,
    base: str = BASE,
) -> str:
    """The README section of a study that scores `base` (default `BASE`)
    against `variant` (the same estimator with something added to every
    prior, said by `what`): rows, paired differences, per class (`change`:
    how the per-class sentence names the two, e.g. "without → with shifts"),
    unseen types."""
    lines = [
        heading,
        "",
        "The scenes, lamp partitions and folds of `make estimate`; surface "
        "unknown, the Moon told, blends in every prior, one band-error model per "
        "metric, the narrowest calibrated interval unit (`bandopt evaluate`'s "
        f"estimator); {summary['partitions']} partitions, class-balanced MAE "
        "over held-out measured lamps, mean ± SD over partitions. "
        f"{what} Generated from `summary.json`.",
        "",
        "| band set | estimator | LER [lm/W] | G | CCT [K] | coverage LER/G/CCT "
        "| level-1 right |",
        "|---|---|---|---|---|---|---|",
    ]
    lines += [row_line(r, surface=False) for r in summary["rows"]]
    lines += [
        "",
        f"Paired by partition, `{variant}` minus `{base}` (negative = better or "
        "narrower):",
        "",
        "| band set | LER [lm/W] | G | CCT [K] | CCT [mired] | coverage LER "
        "| width LER [lm/W] |",
        "|---|---|---|---|---|---|---|",
    ]
    for p in summary["paired"]:
        if p.get("vs") != base:
            continue
        lines.append(
            f"| {p['band_set']} | "
            + " | ".join(diff_cells(p, [(c, PAIRED_DIGITS[c]) for c in COLUMNS]))
            + " |"
        )
    lines += reference_lines(
        [p for p in summary["paired"] if p.get("vs") != base],
        "Reference sensors minus recommended bands, same estimator:",
        "estimator",
    )
    classes = (summary.get("extra") or {}).get("by_class") or {}
    if classes.get(base) and classes.get(variant):
        cells = class_change_cells(classes[base], classes[variant])
        lines += [
            "",
            "Per held-out class (recommended bands, mean over lamps and "
            f"partitions; lamps per class), {change}: "
            + "; ".join(cells)
            + ".",
        ]
    for label, u in (summary.get("unseen_types") or {}).items():
        if label.endswith("(offset 0)"):
            continue  # the same fits' half-width intervals: not compared here
        o = u["overall"]
        lines += [
            "",
            f"Unseen lamp types (recommended bands, `{label}`; partition 0, each "
            "scored class held out in turn, intervals calibrated on training "
            f"classes held out in turn): coverage LER {o['LER_covered']:.2f}, G "
            f"{o['G_covered']:.2f}, CCT {o['CCT_covered']:.2f}; mean LER width "
            f"{_fmt(o, 'LER_width', 0)} lm/W; level-1 right "
            f"{o['level1_correct']:.2f}; unexplained {o['unexplained']:.2f}; out "
            f"of range {o['out_of_range']}.",
        ]
        lines += where_lines(u.get("by_class"))
    return "\n".join(lines) + "\n"


STUDY = Study(
    name="estimate-shift",
    out="results/estimate_shift",
    heading="## Shifted direct-emission LEDs in the prior",
    band_sets=dict(UNKNOWN_ONLY),
    estimators=(BASE, SHIFT),
    pairs=((SHIFT, BASE),),
    unseen=(
        (f"{BASE}-loco", None, "classes", "per-metric", GRID),
        (f"{SHIFT}-loco", None, "classes", "per-metric", GRID, {"peak_shifts": SHIFTS}),
    ),
    title="Held-out measured lamps, surface unknown, Moon told: without vs with "
    "shifted direct-emission LEDs in the prior",
    oracle=False,
    readme=readme_text,
    description=__doc__.splitlines()[0],
    paired_columns=COLUMNS,
    extra=lambda records: {"by_class": by_class(records)},
)
"""The study `main` runs (`experiments.estimate_mix.Study`)."""


def main(argv=None) -> int:
    return _run(argv, STUDY)


if __name__ == "__main__":
    raise SystemExit(main())
