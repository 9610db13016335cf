"""Wavelength-shifted direct-emission LEDs in the prior.

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

    make study NAME=estimate-shift [ARGS="--resume ..."]

Writes `records.jsonl`, `summary.json`, `errors.png`, `manifest.json` and
the `estimate-shift` section of `results/README.md` (default output only),
as every study does (`bandopt.studies.run`). Measured lamps only score;
the blends and shifted copies are built from each fit's training lamps only.
"""

from .._study import UNKNOWN_ONLY, Study
from .._text import BASE, COLUMNS, SHIFT, by_class, variant_text


def readme_text(summary: dict) -> str:
    shifts = ", ".join(f"{x:+g}" for x in summary["peak_shifts_nm"])
    return variant_text(
        summary,
        SHIFT,
        "## Shifted direct-emission LEDs in the prior "
        "(`results/estimate_shift/`, `make study NAME=estimate-shift`)",
        f"`{SHIFT}` also holds, in every prior it builds, copies of that prior's "
        "own direct-emission LEDs (one visible band at most 40 nm wide: in this "
        f"library the four direct amber LEDs) shifted by {shifts} nm.",
        "without → with shifts",
    )


STUDY = Study(
    name="estimate-shift",
    out="results/estimate_shift",
    heading="## Shifted direct-emission LEDs in the prior",
    band_sets=dict(UNKNOWN_ONLY),
    estimators=(BASE, SHIFT),
    pairs=((SHIFT, BASE),),
    unseen=(f"{BASE}-loco", f"{SHIFT}-loco"),
    title="Held-out measured lamps, surface unknown, Moon told: without vs with "
    "shifted direct-emission LEDs in the prior",
    oracle=False,
    readme=readme_text,
    description=__doc__.splitlines()[0],
    paired_columns=COLUMNS,
    extra=lambda records: {"by_class": by_class(records)},
)
"""The study (`bandopt.studies.Study`)."""
