"""The data types, folds and row selection that every lamp-type evaluator of
`bandopt.classify` shares: the KNN (`_evaluate`) and the inversion
(`_inversion`) both build on this module, so neither imports the other late.
"""

import dataclasses
from collections.abc import Mapping, Sequence

import numpy as np

from ..datasets.lamps import LEVEL1, LEVEL2
from ..folds import nested_lamp_splits
from ..forward import ScenarioTable, resolve_level
from ._features import deduplicate


LEVEL_KEYS = ("level1", "level2")

REJECT_GRID: tuple[float, ...] = (0.0, 0.4, 0.5, 0.6, 0.7, 0.8, 0.9, 1.0)
"""Confidence thresholds of the reported reject curve. [1]"""


@dataclasses.dataclass(frozen=True)
class LevelScores:
    """Scores of one classification level over the pooled outer test rows.

    The first fields are those of `bandopt.classify.scores` (with per-lamp
    accuracy); then the reject option at `REJECT_THRESHOLD` with its curve,
    the per-fold records, fold mean and SD of macro F1, the number of test
    rows and, with `keep_rows`, `rows` = (row index, true label, predicted
    label) arrays (not JSON-ready, left out of `to_dict`); for the inversion
    with `keep_rows` also `reject_rows` = (probability of the predicted class,
    unexplained flag) of the same rows (likewise left out).
    """

    labels: list[str]
    f1: dict[str, float]
    precision: dict[str, float]
    recall: dict[str, float]
    support: dict[str, int]
    macro_f1: float
    accuracy: float
    coverage: float
    confusion: list[list[int]]
    confusion_columns: list[str]
    lamp_accuracy: dict[str, float]
    lamp_accuracy_by_class: dict[str, float]
    mean_lamp_accuracy: float
    reject: dict
    folds: list[dict]
    macro_f1_fold_mean: float
    macro_f1_fold_sd: float
    n_test_rows: int
    rows: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None
    reject_rows: tuple[np.ndarray, np.ndarray] | None = None

    def to_dict(self, *, rows: bool = False) -> dict:
        """The JSON-ready dict (the form `evaluate_band_set` returned before
        it returned this class); `rows=True` adds the `rows` (and
        `reject_rows`) arrays that exist."""
        out = {f.name: getattr(self, f.name) for f in dataclasses.fields(self)}
        for key in ("rows", "reject_rows"):
            if not rows or out[key] is None:
                del out[key]
        return out


@dataclasses.dataclass(frozen=True)
class BandSetScores:
    """What `evaluate_band_set` returns: `level1`/`level2` scores (None for a
    level not evaluated) and the evaluation settings `config`."""

    level1: LevelScores | None
    level2: LevelScores | None
    config: Mapping
    order: tuple[str, ...] = LEVEL_KEYS
    """Order of the levels as requested (kept by `to_dict`)."""

    def level(self, name: str) -> LevelScores:
        """The scores of level `name` (`level1`/`level2`, aliases allowed)."""
        key = resolve_level(name)
        found = getattr(self, key)
        if found is None:
            raise ValueError(f"level {key!r} was not evaluated ({list(self.order)}).")
        return found

    @property
    def levels(self) -> tuple[str, ...]:
        """The evaluated levels, in the requested order."""
        return self.order

    def to_dict(self, *, rows: bool = False) -> dict:
        """JSON-ready dict: one entry per evaluated level, then `config` (the
        form `evaluate_band_set` returned before; `rows=True` keeps `rows`)."""
        out: dict = {lv: getattr(self, lv).to_dict(rows=rows) for lv in self.order}
        out["config"] = dict(self.config)
        return out


def class_order(level: str, present: Sequence[str] | np.ndarray) -> list[str]:
    """Classes of `level` in the library's identifier order, only those present."""
    ref = LEVEL1 if resolve_level(level) == "level1" else LEVEL2
    present = set(present)
    return [c for c in ref if c in present]


def outer_splits(table: ScenarioTable, seed: int = 0):
    """The nested lamp splits of the table's lamps, stratified by level 2."""
    return nested_lamp_splits(table.level2, seed=seed)


def usable_rows(x: np.ndarray, table: ScenarioTable, noise: bool) -> np.ndarray:
    """Boolean mask: all rows with noise; without noise, one row per group of
    identical feature rows of a lamp (`deduplicate`)."""
    keep = np.zeros(table.n_rows, bool)
    if noise:
        keep[:] = True
    else:
        keep[deduplicate(x, table.lamp)] = True
    return keep
