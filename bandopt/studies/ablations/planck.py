"""Modelled incandescent spectra (Planck's law) in the prior.

An incandescent lamp is a thermal radiator: its family has physics that no
measured class carries. Without it, a halogen lamp is named by its nearest
measured family when no measured incandescent lamp trains (HID, on unseen
lamp types). This scores `inversion-moon-mix-metric-narrow` (the estimator
of `bandopt evaluate`) against `inversion-moon-mix-metric-narrow-planck`,
the same with the library's modelled incandescent spectra (Planck's law at
2400-3200 K, `bandopt.inversion.planck_lamps`) in every prior beside the
never-scored measured lamps. Modelled spectra train, never score: every
record of the second says `modelled_in_prior`, and the summary says
`modelled_lamps_used`. Surface unknown, our bands and the two best
reference sensors, the scenes, lamp partitions and folds of `make
estimate`, paired by partition; unseen lamp types (recommended bands,
partition 0, intervals calibrated on training classes held out in turn, as
`bandopt evaluate`), without and with them; and how far each measured
halogen lamp's LER and G lie from a Planck radiator at its CCT.

    make study NAME=estimate-planck [ARGS="--resume ..."]

Writes `records.jsonl`, `summary.json`, `errors.png`, `manifest.json` and
the `estimate-planck` section of `results/README.md` (default output only),
as every study does (`bandopt.studies.run`).
"""

import numpy as np

from ... import photometry
from ...datasets.lamps import library
from ...spectra import GRID_1NM, planck_radiance
from .._study import UNKNOWN_ONLY, Study
from .._text import BASE, COLUMNS, by_class, variant_text


PLANCK = "inversion-moon-mix-metric-narrow-planck"
"""`BASE` with the library's modelled incandescent spectra in every prior."""


def planck_match() -> dict:
    """Each measured (scored) halogen lamp against a Planck radiator at its
    own CCT, on the library grid: LER and G differences (lamp − Planck),
    their mean absolute difference and range: how well the model matches
    measurement."""
    grid = np.asarray(GRID_1NM, float)
    lib = library(wavelength_nm=grid).select(scored_only=True)
    idx = [i for i, r in enumerate(lib.records) if r.level1 == "incandescent"]
    lamps = np.asarray(lib.values[idx], float)
    m = photometry.metrics(lamps, grid)
    cct = np.asarray(m["CCT"], float)
    ok = np.isfinite(cct)
    model = np.array([planck_radiance(grid, t) for t in cct[ok]])
    pm = photometry.metrics(model, grid)
    d_ler = np.asarray(m["LER"], float)[ok] - np.asarray(pm["LER"], float)
    d_g = np.asarray(m["G"], float)[ok] - np.asarray(pm["G"], float)
    return {
        "lamps": int(ok.sum()),
        "CCT_range_K": [float(cct[ok].min()), float(cct[ok].max())],
        "LER_diff_mean_abs": float(np.mean(np.abs(d_ler))),
        "LER_diff_range": [float(d_ler.min()), float(d_ler.max())],
        "G_diff_mean_abs": float(np.mean(np.abs(d_g))),
        "G_diff_range": [float(d_g.min()), float(d_g.max())],
    }


def readme_text(summary: dict) -> str:
    text = variant_text(
        summary,
        PLANCK,
        "## Modelled incandescent spectra in the prior "
        "(`results/estimate_planck/`, `make study NAME=estimate-planck`)",
        f"`{PLANCK}` also holds, in every prior it builds, the library's modelled "
        "incandescent spectra (Planck's law at 2400-3200 K in 200 K steps, and "
        "their blends with measured halogen lamps): modelled spectra train, never "
        "score (modelled lamps used: yes, in that estimator only).",
        "without → with the Planck spectra",
    )
    pm = (summary.get("extra") or {}).get("planck_match")
    if pm:
        text += (
            f"\nHow well the model matches measurement: the {pm['lamps']} measured "
            f"halogen lamps ({pm['CCT_range_K'][0]:.0f}-{pm['CCT_range_K'][1]:.0f} "
            "K) against a Planck radiator at each one's CCT: LER differs by "
            f"{pm['LER_diff_mean_abs']:.1f} lm/W on average (lamp − model "
            f"{pm['LER_diff_range'][0]:+.1f} to {pm['LER_diff_range'][1]:+.1f}), "
            f"G by {pm['G_diff_mean_abs']:.3f} ({pm['G_diff_range'][0]:+.3f} to "
            f"{pm['G_diff_range'][1]:+.3f}).\n"
        )
    return text


STUDY = Study(
    name="estimate-planck",
    out="results/estimate_planck",
    heading="## Modelled incandescent spectra in the prior",
    band_sets=dict(UNKNOWN_ONLY),
    estimators=(BASE, PLANCK),
    pairs=((PLANCK, BASE),),
    unseen=(f"{BASE}-loco", f"{PLANCK}-loco"),
    title="Held-out measured lamps, surface unknown, Moon told: without vs with "
    "modelled incandescent (Planck) spectra in the prior",
    oracle=False,
    readme=readme_text,
    description=__doc__.splitlines()[0],
    paired_columns=COLUMNS,
    extra=lambda records: {
        "by_class": by_class(records, (BASE, PLANCK)),
        "planck_match": planck_match(),
    },
)
"""The study (`bandopt.studies.Study`)."""
