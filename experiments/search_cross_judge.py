"""Judge both recommended band sets on clean and on perturbed scenes.

Run from the repo root:
    python -m experiments.search_cross_judge \
        results/search_perturbed/cross_judged.json

results/search/recommended_bands.json (clean search) and
results/search_perturbed/recommended_bands.json (perturbed search), each one
fixed design, scored by the study's judge (inversion scorer) on the presets
`search` and `search_perturbed`: same 2 lamp partitions x 3 outer folds, P4
photon noise, seed 0.
"""

import sys
import time

from bandopt import configure
from bandopt.search import (
    make_study_task,
    partition_summary,
    score_design,
    study_resamples,
    truth_sd,
)
from bandopt.sensor.reference import resolve_band_set
from bandopt.strict_json import strict_dumps


KEYS = ("mae_mean", "mae_sd", "f1_mean", "f1_sd", "norm_mae_mean", "partitions")
SETS = {
    "clean-search bands": "results/search/recommended_bands.json",
    "perturbed-search bands": "results/search_perturbed/recommended_bands.json",
}


def main(path: str) -> None:
    configure()
    out = {}
    for preset in ("search", "search_perturbed"):
        t = make_study_task(preset=preset, partitions=2)
        ctx, res = study_resamples(t["preset"], t["noise"], t["atmospheres"], 2, 0)
        sd = truth_sd(ctx.table)
        for name, src in SETS.items():
            t0 = time.time()
            bands = resolve_band_set(src).bands
            sc = score_design(ctx, bands, res, scorer="inversion", seed=0)
            s = partition_summary(sc, ctx.table.classes, sd)
            out[f"{name} on {preset} scenes"] = {k: s[k] for k in KEYS}
            print(name, preset, f"{time.time() - t0:.0f} s", file=sys.stderr)
    with open(path, "w") as fh:
        fh.write(strict_dumps(out, indent=1))


if __name__ == "__main__":
    main(sys.argv[1])
