"""`LampScore`: one estimator's score on one lamp of one outer fold, the
record `cross_validate` returns (typed fields with units; `to_dict` is the
JSON form studies write, `from_dict` reads it back)."""

import dataclasses
from collections.abc import Mapping

import numpy as np

from ..estimate import CCT_RANGE_K, METRICS, MIRED


@dataclasses.dataclass(frozen=True)
class LampScore:
    """One estimator on one lamp's pixels (its scenes) in one outer fold.

    Who and where:

    - `estimator`, `surface` (surface-knowledge mode), `fold` (outer fold),
      `lamp` (library id), `level1`, `level2` (its true types).
    - `rows`: pixels scored; `out_of_range`: pixels with an estimate outside
      the physical range (a null CCT is not out of range).
    - `scored`: `"train"` when the lamp was a training lamp of the fit (the
      in-library error), None for a held-out test lamp.
    - `train_fraction`, `train_lamps`: the share of each type's training lamps
      kept and how many lamps trained the fold, when a smaller library was
      asked (`cross_validate(train_fraction=)`), else None.

    Errors (mean |error| over the lamp's pixels; None where the lamp's true
    value has no meaning):

    - `LER` [lm/W], `G` [1], `CCT` [K] (a null CCT estimate counts as the far
      end of `CCT_RANGE_K`), `CCT_mired` [mired], `CCT_null_rate` [1].

    Intervals (inversion only; None otherwise or where the truth has no meaning):

    - `{LER,G,CCT}_covered`: fraction of pixels whose 90 % interval holds the
      truth [1]; `{LER,G,CCT}_width`: mean interval width [lm/W, 1, K];
      `CCT_width_mired` [mired].

    Types and fit (inversion only, else None):

    - `level1_correct`, `level2_correct`: fraction of pixels typed right [1];
      `unexplained`: fraction flagged as not explained by the prior [1];
      `sigma_rel`: the fit's relative model error [1]; `metric_noise`: the
      per-metric error model when the fit has one.
    - `modelled_in_prior` (Planck lamps' ids), `tm30_in_prior` (IES TM-30
      lamps in the prior), `modelled_per_class`, `modelled_classes_added`
      (modelled lamps in a learned estimator's training set or the prior).
    """

    estimator: str
    surface: str
    fold: int
    lamp: str
    level1: str
    level2: str
    rows: int
    out_of_range: int
    scored: str | None = None
    train_fraction: float | None = None
    train_lamps: int | None = None
    LER: float | None = None
    G: float | None = None
    CCT: float | None = None
    CCT_mired: float | None = None
    CCT_null_rate: float | None = None
    LER_covered: float | None = None
    LER_width: float | None = None
    G_covered: float | None = None
    G_width: float | None = None
    CCT_covered: float | None = None
    CCT_width: float | None = None
    CCT_width_mired: float | None = None
    level1_correct: float | None = None
    level2_correct: float | None = None
    unexplained: float | None = None
    sigma_rel: float | None = None
    metric_noise: list | None = None
    modelled_in_prior: list | None = None
    tm30_in_prior: int | None = None
    modelled_per_class: int | None = None
    modelled_classes_added: dict | None = None

    def error(self, metric: str) -> float | None:
        """Mean |error| of `metric` (`"LER"`, `"G"`, `"CCT"`, `"CCT_mired"`)."""
        if metric not in (*METRICS, "CCT_mired"):
            raise ValueError(
                f"Unknown metric {metric!r}; expected one of {[*METRICS, 'CCT_mired']}."
            )
        return getattr(self, metric)

    def to_dict(self) -> dict:
        """The JSON form: every field in declaration order, the three metric
        errors always (None where undefined), every other field only when
        set."""
        out = {}
        for f in dataclasses.fields(self):
            value = getattr(self, f.name)
            if value is not None or f.name in METRICS:
                out[f.name] = value
        return out

    def as_record(self, **labels) -> dict:
        """The JSON form with a study's labels added (partition, band set,
        ...); a label that names a field replaces its value in place."""
        return {**self.to_dict(), **labels}

    @classmethod
    def from_dict(cls, record: Mapping) -> "LampScore":
        """A record's JSON form back as a `LampScore`. Raises `ValueError`
        naming keys that are not fields (e.g. a study's own additions: drop
        them first)."""
        names = {f.name for f in dataclasses.fields(cls)}
        extra = sorted(set(record) - names)
        if extra:
            raise ValueError(f"LampScore: unknown fields {extra}.")
        return cls(**record)


def record_errors(est, truth, valid) -> dict:
    """The error fields of one lamp: its pixels' estimates `est` (n, 3) in
    `METRICS` order against its `truth` (3,); the mean |error| per metric
    (None where `valid` says the truth has no meaning), CCT also in mired, a
    null CCT estimate counting as the range's far end (`CCT_RANGE_K`), and the
    rate of null CCTs."""
    rec: dict = {}
    for m, name in enumerate(METRICS):
        if not valid[m]:
            rec[name] = None
            continue
        v = est[:, m]
        if name == "CCT":
            # a null CCT (not meaningful) counts as the range's far end
            vv = np.where(np.isfinite(v), v, CCT_RANGE_K[1])
            rec["CCT"] = float(np.mean(np.abs(vv - truth[m])))
            rec["CCT_mired"] = float(np.mean(np.abs(MIRED / vv - MIRED / truth[m])))
            rec["CCT_null_rate"] = float(np.mean(~np.isfinite(v)))
        else:
            rec[name] = float(np.mean(np.abs(v - truth[m])))
    return rec


def interval_fields(iv, truth, valid) -> dict:
    """Per valid metric of one lamp: the fraction of its pixels whose 90 %
    interval `iv` (n, 3, 2) holds the true value (`{m}_covered`) and the
    intervals' mean width (`{m}_width`: lm/W, 1, K; CCT also in mired,
    `CCT_width_mired`)."""
    out = {}
    for m, name in enumerate(METRICS):
        if not valid[m]:
            continue
        lo, hi = iv[:, m, 0], iv[:, m, 1]
        out[f"{name}_covered"] = float(np.mean((lo <= truth[m]) & (truth[m] <= hi)))
        out[f"{name}_width"] = float(np.mean(hi - lo))
        if name == "CCT":
            out["CCT_width_mired"] = float(np.mean(MIRED / lo - MIRED / hi))
    return out
