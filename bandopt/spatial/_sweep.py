"""Detection against GSD: one rendered scene seen at every GSD and grid phase,
and the coarsest GSD at which single lamps are still found (thesis 4.3).

`gsd_sweep` observes a fine `SceneImage` (`render`) at each GSD with
`n_phases` sub-pixel grid phases (`phases`; the first is no shift), noise
drawn from seed `seed + 1000 k + int(gsd)` for phase k, and scores the
detections (`observe`: PSF, pixel box, photon noise, quantisation, DoG with
thresholds fixed in advance). `coarsest_gsd` applies the stated rule: the
coarsest GSD whose phase-mean F1 reaches `f1_needed`; every GSD that reaches
it is listed too, because fine GSDs can fail (a light pool is not a lamp).
"""

import dataclasses
from collections.abc import Mapping, Sequence

import numpy as np

from ._evaluate import Observation, observe, phases
from ._render import SceneImage


F1_NEEDED = 0.8
"""Phase-mean detection F1 a GSD must reach to count as "lamps detected". [1]"""


@dataclasses.dataclass(frozen=True)
class GsdScore:
    """Detection scores of one scene at one GSD, over its grid phases.

    - `gsd_m`: ground sampling distance. [m]
    - `phase_px`: fine-pixel offset of each phase, `(n_phases, 2)`.
    - `tp`, `fp`, `fn`, `precision`, `recall`, `f1`, `n_detected`: per phase.
    - `n_targets`: distinct lamps in the scene (a twin pole counts once).
    """

    gsd_m: float
    phase_px: tuple[tuple[int, int], ...]
    tp: tuple[int, ...]
    fp: tuple[int, ...]
    fn: tuple[int, ...]
    precision: tuple[float, ...]
    recall: tuple[float, ...]
    f1: tuple[float, ...]
    n_detected: tuple[int, ...]
    n_targets: int

    @property
    def n_phases(self) -> int:
        return len(self.phase_px)

    @property
    def mean_f1(self) -> float:
        """F1 averaged over phases (what `coarsest_gsd` judges). [1]"""
        return float(np.mean(self.f1))

    @property
    def min_f1(self) -> float:
        return float(np.min(self.f1))

    def phase_rows(self) -> list[dict]:
        """One JSON-ready row per phase."""
        return [
            {
                "gsd_m": self.gsd_m,
                "phase": k,
                "tp": self.tp[k],
                "fp": self.fp[k],
                "fn": self.fn[k],
                "precision": self.precision[k],
                "recall": self.recall[k],
                "f1": self.f1[k],
                "n_targets": self.n_targets,
                "n_detected": self.n_detected[k],
            }
            for k in range(self.n_phases)
        ]

    def mean_row(self) -> dict:
        """Phase means of precision, recall, F1 and detections, and the
        worst phase's F1 (JSON-ready)."""
        return {
            "gsd_m": self.gsd_m,
            "n_targets": self.n_targets,
            "n_phases": self.n_phases,
            "precision": float(np.mean(self.precision)),
            "recall": float(np.mean(self.recall)),
            "f1": self.mean_f1,
            "n_detected": float(np.mean(self.n_detected)),
            "f1_min": self.min_f1,
        }


@dataclasses.dataclass(frozen=True)
class GsdSweep:
    """`gsd_sweep`'s result: one `GsdScore` per GSD (in the order asked) and,
    if kept, the first phase's `Observation` at each GSD (for figures)."""

    scores: tuple[GsdScore, ...]
    first_phase: Mapping[float, Observation] | None = None

    def f1_by_gsd(self) -> dict[float, float]:
        """Phase-mean F1 per GSD. [1]"""
        return {s.gsd_m: s.mean_f1 for s in self.scores}


def gsd_sweep(
    scene: SceneImage,
    bands,
    gsds_m: Sequence[float],
    *,
    n_phases: int = 3,
    seed: int = 0,
    keep_observations: bool = False,
    **observe_kwargs,
) -> GsdSweep:
    """Observe `scene` at every GSD of `gsds_m` [m] with `n_phases` grid phases
    (module docstring); `observe_kwargs` go to `observe` (noise, bit depth,
    PSF). `keep_observations`: also return the first phase's observation at
    each GSD."""
    if n_phases < 1:
        raise ValueError(f"n_phases must be >= 1, got {n_phases!r}.")
    scores, first = [], {}
    for gsd in gsds_m:
        gsd = float(gsd)
        if gsd <= 0:
            raise ValueError(f"GSDs must be positive, got {gsd!r}.")
        obs = [
            observe(
                scene,
                bands,
                gsd,
                seed=seed + 1000 * k + int(gsd),
                phase_px=ph,
                **observe_kwargs,
            )
            for k, ph in enumerate(phases(scene, gsd, n_phases, seed))
        ]
        if keep_observations:
            first[gsd] = obs[0]
        sc = [o.score for o in obs]
        scores.append(
            GsdScore(
                gsd_m=gsd,
                phase_px=tuple(o.phase_px for o in obs),
                tp=tuple(s.tp for s in sc),
                fp=tuple(s.fp for s in sc),
                fn=tuple(s.fn for s in sc),
                precision=tuple(s.precision for s in sc),
                recall=tuple(s.recall for s in sc),
                f1=tuple(s.f1 for s in sc),
                n_detected=tuple(int(o.detections.xy_m.shape[0]) for o in obs),
                n_targets=sc[0].tp + sc[0].fn,
            )
        )
    return GsdSweep(tuple(scores), first if keep_observations else None)


@dataclasses.dataclass(frozen=True)
class CoarsestGsd:
    """The answer of `coarsest_gsd`.

    - `coarsest_gsd_m`: coarsest GSD with F1 >= `f1_needed`, None if none. [m]
    - `working_gsds_m`: every GSD that reaches it, ascending. [m]
    - `f1_by_gsd`: the F1 judged at each GSD, ascending in GSD. [1]
    - `f1_needed`: the threshold. [1]
    """

    coarsest_gsd_m: float | None
    working_gsds_m: tuple[float, ...]
    f1_by_gsd: Mapping[float, float]
    f1_needed: float

    def as_dict(self, digits: int = 3) -> dict:
        """JSON-ready, F1 rounded to `digits`, GSD keys as `"10"`-style text."""
        return {
            "coarsest_gsd_m": self.coarsest_gsd_m,
            "working_gsds_m": list(self.working_gsds_m),
            "f1_by_gsd": {
                f"{g:g}": round(f, digits) for g, f in self.f1_by_gsd.items()
            },
        }


def coarsest_gsd(
    f1_by_gsd: Mapping[float, float] | GsdSweep, f1_needed: float = F1_NEEDED
) -> CoarsestGsd:
    """The coarsest GSD whose (phase-mean) detection F1 reaches `f1_needed`,
    from a `{gsd_m: f1}` mapping or a `GsdSweep`. GSDs need not be monotone
    in F1: every GSD that reaches the threshold is listed."""
    if isinstance(f1_by_gsd, GsdSweep):
        f1_by_gsd = f1_by_gsd.f1_by_gsd()
    if not 0.0 <= f1_needed <= 1.0:
        raise ValueError(f"f1_needed must lie in [0, 1], got {f1_needed!r}.")
    table = {float(g): float(f) for g, f in sorted(f1_by_gsd.items())}
    ok = tuple(g for g, f in table.items() if f >= f1_needed)
    return CoarsestGsd(max(ok) if ok else None, ok, table, float(f1_needed))
