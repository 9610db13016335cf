"""A band-error model per metric: LER, G and CCT each under its own.

The inversion scores each candidate lamp with the band error `σ_rel |y_b| +
floor` (in units of the pixel's mean band radiance). `σ_rel` and the floor set
how the bands are weighted: a floor well below `σ_rel |y|` weighs them by
relative error, a floor above it nearly uniformly. One model for all three
metrics is a trade-off: on the folds of `make study NAME=estimate-mix`, LER is best
estimated with the bands weighted nearly uniformly, G and CCT nearly by
relative error. This scores `inversion-moon-mix` (the blends' inversion with
the Moon told, one `σ_rel` chosen on inner folds, floor 0.001) against
`inversion-moon-mix-metric` (each metric's estimate and interval under its
own `σ_rel` and floor from `SIGMA_REL_GRID` x `FLOOR_GRID`, chosen on the same
inner folds by that metric's error: `fit_inversion(sigma_rule="per-metric",
floor_grid=FLOOR_GRID)`; the types and the unexplained flag keep the joint
choice), with the surface unknown, for our bands and the two best reference
sensors (the same estimators for every band set), on the scenes, lamp
partitions and folds of `make estimate`, paired by partition; and on unseen
lamp types (recommended bands, partition 0) with the intervals `bandopt
evaluate` gives by default.

    make study NAME=estimate-noise [ARGS="--resume ..."]

Writes `records.jsonl`, `summary.json`, `errors.png`, `manifest.json` and the
`estimate-noise` section of `results/README.md` (default output only), as
every study does (`bandopt.studies.run`). Measured lamps only score; the
blends are built from each fit's training lamps only and never score.
"""

import dataclasses

from .._study import UNKNOWN_ONLY, Study
from .._text import diff_cells, rows_table, where_lines


ONE, PER = "inversion-moon-mix", "inversion-moon-mix-metric"
"""One band-error model for all metrics, and one per metric."""

STUDY = Study(
    name="estimate-noise",
    out="results/estimate_noise",
    heading="## A band-error model per metric",
    band_sets=dict(UNKNOWN_ONLY),
    estimators=(ONE, PER),
    pairs=((PER, ONE),),
    unseen=(f"{ONE}-loco", f"{PER}-loco"),
    title="Held-out measured lamps, surface unknown, Moon told: one band-error "
    "model vs one per metric (mean ± SD over partitions)",
    oracle=False,
)
"""The study (`bandopt.studies.Study`)."""


def readme_text(summary: dict) -> str:
    lines = [
        f"{STUDY.heading} (`results/estimate_noise/`, "
        "`make study NAME=estimate-noise`)",
        "",
        "The scenes, lamp partitions and folds of `make estimate`; surface "
        "unknown, the Moon told, blends in every prior (as `bandopt evaluate`); "
        f"class-balanced MAE, mean ± SD over {summary['partitions']} partitions; "
        "measured lamps only score. The band error is `σ_rel |y| + floor`. "
        f"`{ONE}`: one `σ_rel` for all three metrics, floor 0.001. `{PER}`: each "
        "metric's estimate and interval under its own `σ_rel` "
        f"({', '.join(f'{s:g}' for s in summary['sigma_grid'])}) and floor "
        f"({', '.join(f'{f:g}' for f in summary['floor_grid'])}), chosen on the "
        "inner folds by that metric's error; types and the unexplained flag "
        "keep the joint choice. Coverage: fraction of true values inside the "
        "90 % intervals (calibrated on held-out lamps). Generated from "
        "`summary.json`.",
        "",
        *rows_table(summary["rows"], surface=False),
    ]
    lines += [
        "",
        "Paired by partition (positive = the first is worse): per metric minus "
        "one model, same band set; reference minus recommended, same estimator.",
        "",
        "| compared | estimator | LER [lm/W] | G | CCT [K] |",
        "|---|---|---|---|---|",
    ]
    for p in summary["paired"]:
        what = (
            f"{p['band_set']}: per metric − one model"
            if p.get("vs") == ONE
            else f"{p['band_set']} − {p['vs']}"
        )
        lines.append(
            f"| {what} | {p['estimator']} | " + " | ".join(diff_cells(p)) + " |"
        )
    for label, u in (summary.get("unseen_types") or {}).items():
        o = u["overall"]
        lines += [
            "",
            f"Unseen lamp types (recommended bands, `{label}`: intervals "
            "calibrated on training classes held out in turn, as `bandopt "
            "evaluate` by default; partition 0, each scored class held out in "
            f"turn): coverage LER {o['LER_covered']:.2f}, G {o['G_covered']:.2f}, "
            f"CCT {o['CCT_covered']:.2f}; level-1 type right "
            f"{o['level1_correct']:.2f}; unexplained {o['unexplained']:.2f}; out "
            f"of range {o['out_of_range']}.",
        ]
        lines += where_lines(u.get("by_class"))
    return "\n".join(lines) + "\n"


STUDY = dataclasses.replace(
    STUDY, readme=readme_text, description=__doc__.splitlines()[0]
)
