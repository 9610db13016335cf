"""Options of a band-search run (`python -m experiments.search`): the
stability study's fixed settings (`STUDY`), where the shipped study writes
(`DEFAULT_OUT`) and `SearchOptions`, one field per command-line option."""

import dataclasses
from pathlib import Path

from ._study import DEFAULT_SCORER


STUDY = {
    "noise": "P4",
    "partitions": 4,
    "ns": (1, 2, 3, 4, 5, 6),
    "alphas": (0.0, 0.25, 0.5, 0.75, 1.0),
    "restarts": 8,
    "max_steps": 200,
}
"""The stability study: photon noise at the signal of EN 13201 class P4
(scenes lit to P4, thesis Table 2.3 sensor), 4 lamp partitions x 3 outer
folds = 12 resamples, band counts 1..6 (+ fixed pan), objective weights alpha
between estimation (0) and classification (1); per resample, nlopt explores
and optimistix BFGS fits from its 8 best distinct points (at most 200 steps
each, `batched_search`)."""

DEFAULT_OUT = Path("results/search")
"""Output folder of the shipped study: only a run into it replaces the
"spectral" recommendation in results/recommendation.json and the search
section of results/README.md; a run elsewhere (e.g. `--preset
search_perturbed --out results/search_perturbed`) writes both into its own
folder, so a variant never replaces what `bandopt evaluate` ships."""


@dataclasses.dataclass(frozen=True)
class SearchOptions:
    """What a band-search run does and where it writes.

    Every command reads `out`, `preset`, `seed` and `bands` (free band counts,
    pan not counted); sweeps also `workers` (spawned processes; 1: this
    process) or `scheduler` (a Dask address). The stability study
    (`run_study`) reads `partitions`, `max_steps` (optimistix steps per local
    fit), `scorer` (outer-fold estimator, `SCORERS`), `tolerance_scorer`
    (estimator of the tolerance scan) and `force` (recompute cached tasks);
    the single-split study reads `max_evals` (nlopt evaluations per search;
    None: `EVALS_PER_DIM` per search dimension)."""

    out: Path = DEFAULT_OUT
    preset: str = "search"
    seed: int = 0
    bands: tuple[int, ...] = STUDY["ns"]
    workers: int = 1
    scheduler: str | None = None
    max_evals: int | None = None
    partitions: int = STUDY["partitions"]
    max_steps: int = STUDY["max_steps"]
    scorer: str = DEFAULT_SCORER
    tolerance_scorer: str = "ridge"
    force: bool = False

    @property
    def bands_text(self) -> str:
        """`bands` as given on the command line (`1,2,3`), for manifests."""
        return ",".join(str(n) for n in self.bands)
