"""`bandopt evaluate`'s estimator as a whole: shifted LEDs and Planck spectra.

The studies `estimate-shift` and `estimate-planck` each pair one change to
the prior against `inversion-moon-mix-metric-narrow`; `bandopt evaluate` makes
both by default. This scores the two together,
`inversion-moon-mix-metric-narrow-shift-planck`, against the same base, on
the same scenes, lamp partitions and folds (surface unknown, our bands and
the two best reference sensors, paired by partition), and on unseen lamp
types (recommended bands, partition 0, intervals calibrated on training
classes held out in turn), so the README's headline numbers are those of
the estimator a user gets. Modelled (Planck) spectra train, never score.

    make study NAME=estimate-defaults [ARGS="--resume ..."]

Writes `records.jsonl`, `summary.json`, `errors.png`, `manifest.json` and
the `estimate-defaults` section of `results/README.md` (default output
only), as every study does (`bandopt.studies.run`).
"""

from .._study import UNKNOWN_ONLY, Study
from .._text import BASE, COLUMNS, by_class, variant_text


DEFAULT = "inversion-moon-mix-metric-narrow-shift-planck"
"""`BASE` with shifted direct-emission LEDs and the library's modelled
incandescent spectra in every prior: `bandopt evaluate`'s defaults."""


def readme_text(summary: dict) -> str:
    return variant_text(
        summary,
        DEFAULT,
        "## The estimator `bandopt evaluate` gives by default "
        "(`results/estimate_defaults/`, `make study NAME=estimate-defaults`)",
        f"`{DEFAULT}` holds, in every prior it builds, both the shifted copies of "
        "that prior's direct-emission LEDs (`make study NAME=estimate-shift`) and the "
        "library's modelled incandescent spectra (`make study NAME=estimate-planck`; "
        "modelled lamps used: yes, in that estimator only).",
        "without → with both",
    )


STUDY = Study(
    name="estimate-defaults",
    out="results/estimate_defaults",
    heading="## The estimator `bandopt evaluate` gives by default",
    band_sets=dict(UNKNOWN_ONLY),
    estimators=(BASE, DEFAULT),
    pairs=((DEFAULT, BASE),),
    unseen=(f"{DEFAULT}-loco",),
    title="Held-out measured lamps, surface unknown, Moon told: evaluate's "
    "estimator without vs with shifted LEDs and Planck spectra",
    oracle=False,
    readme=readme_text,
    description=__doc__.splitlines()[0],
    paired_columns=COLUMNS,
    extra=lambda records: {"by_class": by_class(records, (BASE, DEFAULT))},
)
"""The study (`bandopt.studies.Study`)."""
