"""More measured lamps in the prior: the IES TM-30-15 set.

`make estimate-library` found that what stands between `bandopt evaluate`'s
estimate and the estimation goal is the library's coverage of lamp kinds: with
the lamp in the prior our bands meet the goal, and the held-out error falls
with the number of training lamps. The IES TM-30-15 source library
(`IES2015`, vendored from LuxPy) holds measured commercial and experimental
lamps, 210 of them not in the library (`bandopt.inversion.tm30_lamps`:
classified and deduplicated by the library's own rules). This scores
`inversion-moon-mix-metric-narrow-shift-planck` (`bandopt evaluate`'s
estimator) against `inversion-moon-mix-metric-narrow-shift-planck-tm30`, the
same with those lamps in every prior beside the never-scored measured lamps.
They train, never score: the scored lamps, scenes, partitions and folds are
those of `make estimate`, paired by partition; our bands and the two best
reference sensors, surface unknown; and on unseen lamp types (recommended
bands, partition 0, intervals calibrated on training classes held out in
turn), where the TM-30 lamps of the held-out class leave the prior too.

    make study NAME=estimate-tm30 [ARGS="--resume ..."]

Writes `records.jsonl`, `summary.json`, `errors.png`, `manifest.json` and
the `estimate-tm30` section of `results/README.md` (default output only), as
every study does (`bandopt.studies.run`).
"""

from collections import Counter

from ...datasets.lamps import library
from ...inversion import tm30_lamps
from ...spectra import GRID_1NM
from .._study import UNKNOWN_ONLY, Study
from .._text import COLUMNS, by_class, variant_text
from .defaults import DEFAULT, STUDY as DEFAULTS


TM30 = "inversion-moon-mix-metric-narrow-shift-planck-tm30"
"""`DEFAULT` with the measured IES TM-30-15 lamps the library lacks in every
prior (`bandopt.inversion.TM30_ESTIMATOR`)."""


def tm30_counts() -> dict:
    """The TM-30 lamps the prior gains: per level-2 class, in total, and how
    many of the set's measured entries the library's deduplication removed
    (copies of library lamps)."""
    # lazy: JAX is configured by the study's main before the library is built
    lamps = tm30_lamps(GRID_1NM)
    lib = library(tm30=True)
    removed = sum(
        1 for rec in lib.records for d in rec.duplicates if d.startswith("ies_tm30_")
    )
    excluded = sum(
        1 for r in lib.records if r.source_set == "ies_tm30" and r.excluded is not None
    )
    return {
        "lamps": len(lamps.ids),
        "by_class": dict(sorted(Counter(lamps.level2).items())),
        "duplicates_removed": removed,
        "excluded": excluded,
    }


def readme_text(summary: dict) -> str:
    text = variant_text(
        summary,
        TM30,
        "## More measured lamps in the prior: the IES TM-30-15 set "
        "(`results/estimate_tm30/`, `make study NAME=estimate-tm30`)",
        f"`{TM30}` also holds, in every prior it builds, the measured lamps of the "
        "IES TM-30-15 source library that the library lacks (`IES2015`, vendored "
        "from LuxPy; classified and deduplicated by the library's rules); they "
        "train, never score, and leave the prior with their class on unseen types "
        "(modelled lamps used: the Planck spectra of both estimators).",
        "without → with the TM-30 lamps",
        base=DEFAULT,
    )
    counts = (summary.get("extra") or {}).get("tm30")
    if counts:
        per = ", ".join(f"{c} {n}" for c, n in counts["by_class"].items())
        text += (
            f"\nThe TM-30 lamps in the prior: {counts['lamps']} ({per}); "
            f"{counts['duplicates_removed']} of the set's measured entries are "
            f"copies of library lamps and were removed, {counts['excluded']} "
            "coloured LED left out.\n"
        )
    return text


STUDY = Study(
    name="estimate-tm30",
    out="results/estimate_tm30",
    heading="## More measured lamps in the prior: the IES TM-30-15 set",
    band_sets=dict(UNKNOWN_ONLY),
    estimators=(DEFAULT, TM30),
    pairs=((TM30, DEFAULT),),
    unseen=(*DEFAULTS.unseen, f"{TM30}-loco"),
    title="Held-out measured lamps, surface unknown, Moon told: evaluate's "
    "estimator without vs with the measured IES TM-30-15 lamps in the prior",
    oracle=False,
    readme=readme_text,
    description=__doc__.splitlines()[0],
    paired_columns=COLUMNS,
    extra=lambda records: {
        "by_class": by_class(records, (DEFAULT, TM30)),
        "tm30": tm30_counts(),
    },
)
"""The study (`bandopt.studies.Study`)."""
