"""How much do surface, atmosphere and Moon matter, and how many bands to use.

- `influence_identification`: train the lamp-type classifier on the scenes of
  one condition value (one surface, one atmosphere, one Moon state), test on
  the scenes of the same value and on the others (outer lamp folds, level-2
  macro F1); the drop says how much that condition must be in the training
  set.
- `influence_estimates`: the same for the LER/G/CCT ridge estimators of
  `bandopt.estimate` (class-balanced lamp MAE, same outer folds).
- `choose_band_count`: the smallest band count whose nested macro F1 is
  within `BAND_COUNT_TOLERANCE` of the best.

All use noisy radiance (photon noise of the thesis sensor, draws from
`noise_seed`, `bandopt.forward.noise_draws`) and the nested lamp folds of
`fold_seed` (`outer_splits`).
"""

import dataclasses
from collections.abc import Mapping, Sequence

import numpy as np

from ..datasets.lamps import library
from ..estimate import METRICS, LampTable, fit_estimator, lamp_abs_errors, lamp_truth
from ..forward import CONDITIONS, ScenarioTable
from ._evaluate import evaluate_band_set
from ._metrics import scores
from ._scores import class_order, outer_splits


BAND_COUNT_TOLERANCE = 0.02
"""`choose_band_count`: a band count within this much level-2 macro F1 of the
best counts as good as the best. [1]"""

FACTORS = ("surface", "atmosphere", "moon")
"""Condition factors studied by default (`bandopt.forward.CONDITIONS`)."""


@dataclasses.dataclass(frozen=True)
class IdentificationInfluence:
    """Classifier trained on `factor == train_on`: level-2 macro F1 on the
    scenes of that value (`macro_f1_same`) and of the other values
    (`macro_f1_others`), and of the classifier trained on every scene tested
    on this value (`macro_f1_trained_on_all_tested_on_this`). [1]"""

    factor: str
    train_on: str
    macro_f1_same: float
    macro_f1_others: float
    macro_f1_trained_on_all_tested_on_this: float

    @property
    def f1_drop(self) -> float:
        return self.macro_f1_same - self.macro_f1_others

    def as_dict(self) -> dict:
        return {
            "factor": self.factor,
            "train_on": self.train_on,
            "macro_f1_same": self.macro_f1_same,
            "macro_f1_others": self.macro_f1_others,
            "f1_drop": self.f1_drop,
            "macro_f1_trained_on_all_tested_on_this": (
                self.macro_f1_trained_on_all_tested_on_this
            ),
        }


@dataclasses.dataclass(frozen=True)
class EstimationInfluence:
    """Estimators trained on `factor == train_on`: class-balanced lamp MAE of
    LER, G, CCT [lm W⁻¹, 1, K] on the scenes of that value (`mae_same`) and of
    the other values (`mae_others`)."""

    factor: str
    train_on: str
    mae_same: tuple[float, float, float]
    mae_others: tuple[float, float, float]

    def as_dict(self) -> dict:
        row = {"factor": self.factor, "train_on": self.train_on}
        for m, name in enumerate(METRICS):
            row[f"{name}_mae_same"] = self.mae_same[m]
            row[f"{name}_mae_others"] = self.mae_others[m]
            row[f"{name}_mae_increase"] = self.mae_others[m] - self.mae_same[m]
        return row


def _values(table: ScenarioTable, factor: str) -> tuple[np.ndarray, list]:
    if factor not in CONDITIONS:
        raise ValueError(f"Unknown factor {factor!r}; expected one of {CONDITIONS}.")
    cond = table.condition(factor)
    return cond, list(dict.fromkeys(cond.tolist()))


def influence_identification(
    table: ScenarioTable,
    bands,
    factors: Sequence[str] = FACTORS,
    *,
    noise_seed: int = 0,
    fold_seed: int = 0,
) -> tuple[IdentificationInfluence, ...]:
    """One row per value of each factor with at least two values (module
    docstring)."""
    rad = table.band_radiance(bands, noise=True, seed=noise_seed)
    classes = class_order("level2", table.level2)
    base = evaluate_band_set(
        table, bands, radiance=rad, keep_rows=True, fold_seed=fold_seed
    )
    bidx, byt, byp = base.level2.rows
    out = []
    for factor in factors:
        cond, values = _values(table, factor)
        if len(values) < 2:
            continue
        for v in values:
            same = cond == v
            ev = evaluate_band_set(
                table,
                bands,
                radiance=rad,
                train_rows=same,
                keep_rows=True,
                fold_seed=fold_seed,
                levels=("level2",),
            )
            idx, yt, yp = ev.level2.rows
            m, bm = same[idx], same[bidx]
            out.append(
                IdentificationInfluence(
                    factor,
                    str(v),
                    scores(yt[m], yp[m], classes)["macro_f1"],
                    scores(yt[~m], yp[~m], classes)["macro_f1"],
                    scores(byt[bm], byp[bm], classes)["macro_f1"],
                )
            )
    return tuple(out)


def _class_balanced_mae(err, classes) -> tuple[float, float, float]:
    out = []
    for m in range(3):
        ok = np.isfinite(err[:, m])
        cls = classes[ok]
        out.append(
            float(np.mean([err[ok, m][cls == c].mean() for c in np.unique(cls)]))
        )
    return tuple(out)


def influence_estimates(
    table: ScenarioTable,
    bands,
    factors: Sequence[str] = FACTORS,
    *,
    noise_seed: int = 0,
    fold_seed: int = 0,
) -> tuple[EstimationInfluence, ...]:
    """One row per value of each factor with at least two values: ridge
    estimators fitted per outer fold on that value's scenes of the training
    lamps, scored on the test lamps (module docstring)."""
    lib = library()
    index = {i: k for k, i in enumerate(lib.ids)}
    missing = [i for i in table.lamp_ids if i not in index]
    if missing:
        raise ValueError(f"Lamps {missing[:5]} are not in the library (no truth).")
    values = np.asarray(lib.values)[[index[i] for i in table.lamp_ids]]
    truth, valid = lamp_truth(values, lib.wavelength_nm)
    classes = np.asarray(table.level2, dtype=object)
    rad = table.band_radiance(bands, noise=True, seed=noise_seed)
    splits = outer_splits(table, fold_seed)
    out = []
    for factor in factors:
        cond, vals = _values(table, factor)
        if len(vals) < 2:
            continue
        for v in vals:
            errs: dict[str, list] = {"same": [], "others": []}
            for s in splits:
                tr_rows = cond == v
                sub = LampTable(table.lamp[tr_rows], classes, truth, valid)
                est = fit_estimator(rad[tr_rows], sub, s.train, s.inner)
                for key, mask in (("same", cond == v), ("others", cond != v)):
                    t = LampTable(table.lamp[mask], classes, truth, valid)
                    pred = np.asarray(est.predict(rad[mask]))
                    errs[key].append(lamp_abs_errors(pred, t, s.test))
            lamps = np.concatenate([s.test for s in splits])
            out.append(
                EstimationInfluence(
                    factor,
                    str(v),
                    _class_balanced_mae(np.concatenate(errs["same"]), classes[lamps]),
                    _class_balanced_mae(np.concatenate(errs["others"]), classes[lamps]),
                )
            )
    return tuple(out)


@dataclasses.dataclass(frozen=True)
class BandCountChoice:
    """`n_bands`: the chosen count; `best_f1`: the best macro F1 over counts;
    `f1_by_n`: the scores judged; `tolerance`; `rule` in words."""

    n_bands: int
    best_f1: float
    f1_by_n: Mapping[int, float]
    tolerance: float
    rule: str


def choose_band_count(
    f1_by_n: Mapping[int, float], tolerance: float = BAND_COUNT_TOLERANCE
) -> BandCountChoice:
    """The smallest band count whose (nested, level-2) macro F1 is within
    `tolerance` of the best count's."""
    if not f1_by_n:
        raise ValueError("f1_by_n is empty: no band counts to choose from.")
    if tolerance < 0:
        raise ValueError(f"tolerance must be >= 0, got {tolerance!r}.")
    table = {int(n): float(f) for n, f in sorted(f1_by_n.items())}
    top = max(table.values())
    n = min(k for k, f in table.items() if f >= top - tolerance)
    rule = f"smallest n within {tolerance:g} of the best nested level-2 macro F1"
    return BandCountChoice(n, top, table, float(tolerance), rule)


@dataclasses.dataclass(frozen=True)
class Influence:
    """`influence`'s result: the classifier's and the estimators' rows."""

    identification: tuple[IdentificationInfluence, ...]
    estimates: tuple[EstimationInfluence, ...]


def influence(
    table: ScenarioTable,
    bands,
    factors: Sequence[str] = FACTORS,
    *,
    estimate_bands=None,
    noise_seed: int = 0,
    fold_seed: int = 0,
) -> Influence:
    """`influence_identification` with `bands` and `influence_estimates` with
    `estimate_bands` (default `bands`), same factors, seeds and folds."""
    kw = dict(noise_seed=noise_seed, fold_seed=fold_seed)
    return Influence(
        influence_identification(table, bands, factors, **kw),
        influence_estimates(
            table, bands if estimate_bands is None else estimate_bands, factors, **kw
        ),
    )
