"""Mixtures in the prior: what fills the gaps between the library's lamps.

The inversion's posterior is a weighted set of measured training lamps. Told
the test lamp itself (in its prior), its error on the scenes of `make
estimate` drops to ~0 (0.04 lm/W): the scene (surface, atmosphere, Moon) is
not what limits it; the prior's coverage of lamp space is. This scores the
told-Moon inversion (`inversion-moon`) against the same inversion whose
priors also hold pairwise same-class mixtures of their own lamps
(`inversion-moon-mix`, `bandopt.inversion.mixture_lamps`), on the scenes,
lamp partitions and folds of `make estimate`, for the recommended bands and
the reference sensors (same estimators for every band set), and on unseen
lamp types (each scored class held out; recommended bands, partition 0).
The other studies run the same machinery (`bandopt.studies.run`) on their
own configuration.

    make study NAME=estimate-mix [ARGS="--resume ..."]

Writes `records.jsonl` (one line per test lamp; resumable per (partition,
band set)), `summary.json` (class-balanced MAE, coverage and level-1 per
band set, estimator and surface mode, mean ± SD over partitions; paired
differences: mix − no mix per band set, reference − recommended per
estimator; the unseen-types study), `errors.png`, `manifest.json` and the
`estimate-mix` section of `results/README.md` (default output only).
Measured lamps only score; the mixtures are built from each fit's training
lamps only and never score.
"""

from .._study import BAND_SETS, Study
from .._text import diff_cells, rows_table, unseen_lines


ESTIMATORS = ("inversion-moon", "inversion-moon-mix")
"""The told-Moon inversion without and with mixtures in its priors."""
PAIRS = (("inversion-moon-mix", "inversion-moon"),)
"""(variant, base) estimators compared paired by partition."""
UNSEEN = ("inversion-moon", "inversion-moon-mix", "inversion-moon-mix-loco")
"""Unseen-types runs (`inversion.options_of`): without and with blends,
and with blends and intervals calibrated on classes held out in turn."""


def readme_text(summary: dict) -> str:
    lines = [
        "## Mixtures in the prior (`results/estimate_mix/`, "
        "`make study NAME=estimate-mix`)",
        "",
        "The scenes, lamp partitions and folds of `make estimate`; class-balanced "
        f"MAE, mean ± SD over {summary['partitions']} partitions; measured lamps "
        "only score. Both estimators are told the Moon's brightness. "
        "`inversion-moon-mix` also holds, in every prior it builds, pairwise "
        f"mixtures of that prior's own lamps of one class (up to "
        f"{summary['mix_pairs']} pairs per class, flux fractions "
        f"{', '.join(f'{f:g}' for f in summary['mix_fractions'])}). With the "
        "test lamp itself in the prior the error is ~0 (partition 0, fold 0: "
        f"{summary['oracle']['LER']:.2f} lm/W, G {summary['oracle']['G']:.3f}): "
        "the prior's coverage of lamp space, not the scene, limits the estimate. "
        "Coverage: fraction of true values inside the 90 % intervals. Generated "
        "from `summary.json`.",
        "",
        *rows_table(summary["rows"]),
    ]
    lines += [
        "",
        "Paired by partition (positive = the first is worse): mixtures minus "
        "none, same band set and surface; reference minus recommended, same "
        "estimator and surface.",
        "",
        "| compared | estimator | surface | LER [lm/W] | G | CCT [K] |",
        "|---|---|---|---|---|---|",
    ]
    for p in summary["paired"]:
        what = {
            "inversion-moon": f"{p['band_set']}: mix − no mix",
            "inversion-moon-mix": f"{p['band_set']}: per-metric − one error model",
        }.get(p.get("vs"), f"{p['band_set']} − {p['vs']}")
        lines.append(
            f"| {what} | {p['estimator']} | {p['surface']} | "
            + " | ".join(diff_cells(p))
            + " |"
        )
    unseen = summary.get("unseen_types") or {}
    if any(k.endswith("-loco") for k in unseen):
        lines += [
            "",
            "Unseen types: `-loco` calibrates the 90 % intervals on training "
            "classes held out in turn instead of held-out lamps (`bandopt "
            "evaluate --intervals any-type`, with the blends: "
            "`inversion-moon-mix-loco`; its default `by-flag` does so for "
            "pixels flagged unexplained); the estimates are the same.",
        ]
    lines += unseen_lines(unseen)
    return "\n".join(lines) + "\n"


TITLE = (
    "Held-out measured lamps, Moon told: prior of measured lamps vs with "
    "same-class mixtures (mean ± SD over partitions)"
)
"""The figure's title (a summary's `"title"` replaces it)."""


STUDY = Study(
    name="estimate-mix",
    out="results/estimate_mix",
    heading="## Mixtures in the prior",
    band_sets=dict(BAND_SETS),
    estimators=ESTIMATORS,
    pairs=PAIRS,
    unseen=UNSEEN,
    title=TITLE,
    oracle=True,
    readme=readme_text,
    description=__doc__.splitlines()[0],
)
"""The study (`bandopt.studies.Study`)."""
