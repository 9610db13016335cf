"""The contract every registered estimator keeps (after scikit-learn's
`BaseEstimator`): a frozen configuration whose `fit` returns a fitted
estimator, whose `predict` returns an `Estimates` record.

`Estimates` is what `bandopt evaluate` reports per pixel, typed: LER, G and
CCT with their 90 % intervals (NaN where a value is null, with the reason),
the `unexplained` flag, the lamp types and, where the estimator has them,
the level-1 probabilities; `row(i)` is pixel i as the JSON gives it.
`Surface` is what the estimator is told of a pixel's surface."""

import dataclasses
import math
from collections.abc import Sequence
from typing import ClassVar, Protocol, runtime_checkable

import numpy as np

from ..estimate import METRICS


@dataclasses.dataclass(frozen=True)
class Surface:
    """What an estimator is told of the surface under the lamp: `mode` one of
    `inversion.SURFACE_MODES` ("unknown", "class": its type `name` is known,
    "measured": its `reflectance` (w,) on the context's grid is known); the
    reflectance is given in every mode (the scene's own), for the estimators
    that divide it out."""

    mode: str
    name: str | None
    reflectance: np.ndarray

    def __post_init__(self):
        if self.mode not in ("unknown", "class", "measured"):
            raise ValueError(
                f"Surface.mode {self.mode!r}: expected unknown, class or measured."
            )
        if self.mode == "class" and not self.name:
            raise ValueError("Surface.name: a surface type is needed in mode 'class'.")


def _none_if_nan(x) -> float | None:
    return None if not math.isfinite(x) else float(x)


@dataclasses.dataclass(frozen=True, eq=False)
class Estimates:
    """Per pixel (n of them): `values` (n, 3) LER [lm W⁻¹], G [1], CCT [K],
    NaN where null; `interval90` (n, 3, 2) in the same units, NaN where
    null; `null_reasons` per pixel {metric: why it is null}; `unexplained`
    per pixel (None: the estimator has no such test); `level1` and `level2`
    the lamp types (None: none given); `level1_probabilities` {type:
    probability} per pixel, or None; `extra` per pixel the estimator's own
    JSON fields (e.g. the inversion's misfit and p-value)."""

    values: np.ndarray
    interval90: np.ndarray
    null_reasons: tuple[dict, ...]
    unexplained: tuple[bool | None, ...]
    level1: tuple[str | None, ...]
    level2: tuple[str | None, ...]
    level1_probabilities: tuple[dict | None, ...]
    extra: tuple[dict, ...]

    COMMON: ClassVar[tuple[str, ...]] = (
        "estimate",
        "interval90",
        "null_reasons",
        "unexplained",
        "level1_probabilities",
        "predicted_level1",
        "predicted_level2",
    )
    """The keys every row has, whatever the estimator."""

    def __post_init__(self):
        n = len(self.values)
        if np.shape(self.values) != (n, len(METRICS)):
            raise ValueError(
                f"Estimates.values: need shape (n, 3), got {np.shape(self.values)}."
            )
        if np.shape(self.interval90) != (n, len(METRICS), 2):
            raise ValueError(
                f"Estimates.interval90: need shape ({n}, 3, 2), got "
                f"{np.shape(self.interval90)}."
            )
        per_pixel = ("null_reasons", "unexplained", "level1", "level2")
        for f in (*per_pixel, "level1_probabilities", "extra"):
            if len(getattr(self, f)) != n:
                raise ValueError(f"Estimates.{f}: need {n} entries.")

    def __len__(self) -> int:
        return len(self.values)

    def row(self, i: int) -> dict:
        """Pixel `i` as `bandopt evaluate`'s JSON gives it (null, not NaN)."""
        est, iv = {}, {}
        for m, name in enumerate(METRICS):
            est[name] = _none_if_nan(self.values[i, m])
            lo, hi = self.interval90[i, m]
            iv[name] = (
                None if not np.isfinite([lo, hi]).all() else [float(lo), float(hi)]
            )
        return {
            "estimate": est,
            "interval90": iv,
            "null_reasons": dict(self.null_reasons[i]),
            "unexplained": self.unexplained[i],
            "level1_probabilities": self.level1_probabilities[i],
            "predicted_level1": self.level1[i],
            "predicted_level2": self.level2[i],
            **self.extra[i],
        }

    @classmethod
    def from_rows(cls, rows: Sequence[dict]) -> "Estimates":
        """The record of JSON-ready rows (`InversionResult.row`,
        `DirectEstimator.rows`); keys beyond the common ones go to `extra`."""
        common = set(cls.COMMON)
        n = len(rows)
        values = np.full((n, len(METRICS)), np.nan)
        iv = np.full((n, len(METRICS), 2), np.nan)
        for i, r in enumerate(rows):
            for m, name in enumerate(METRICS):
                v = r["estimate"].get(name)
                values[i, m] = np.nan if v is None else v
                b = (r["interval90"] or {}).get(name)
                if b is not None:
                    iv[i, m] = b
        return cls(
            values=values,
            interval90=iv,
            null_reasons=tuple(dict(r.get("null_reasons") or {}) for r in rows),
            unexplained=tuple(r.get("unexplained") for r in rows),
            level1=tuple(r.get("predicted_level1") for r in rows),
            level2=tuple(r.get("predicted_level2") for r in rows),
            level1_probabilities=tuple(r.get("level1_probabilities") for r in rows),
            extra=tuple({k: v for k, v in r.items() if k not in common} for r in rows),
        )


@runtime_checkable
class Fitted(Protocol):
    """A fitted estimator: `description` says in words what it is and how
    its intervals, types and flag are made; `predict` estimates pixels of
    `bandopt evaluate`'s scene (no atmosphere, no Moon) from band radiance
    (n, b) [W m⁻² sr⁻¹ nm⁻¹] with `surface` known as it says; `report()`
    the estimator's own fields of the evaluate JSON."""

    description: str

    def predict(self, radiance: np.ndarray, surface: Surface) -> Estimates: ...

    def report(self) -> dict: ...


@runtime_checkable
class EstimatorConfig(Protocol):
    """A registered estimator's frozen configuration: `name` its registry
    key, `own_lamps` whether a user's lamps may join what it trains on,
    `needs_surface` whether it must be told the surface; `check(bands)`
    refuses a band set it cannot use before anything trains; `fit` trains
    on a `search.Context`'s scored lamps (inner folds: its outer splits)."""

    name: ClassVar[str]
    own_lamps: ClassVar[bool]
    needs_surface: ClassVar[bool]

    def check(self, bands) -> None: ...

    def fit(self, ctx, bands, *, surface_mode: str, own=None) -> Fitted: ...


def no_report() -> dict:
    """`Fitted.report` of an estimator without a lamp prior: the evaluate
    JSON's prior fields empty."""
    return {
        "intervals": None,
        "interval_unit": None,
        "mixtures_per_class": 0,
        "cross_mixtures_per_class_pair": 0,
        "modelled_in_prior": [],
        "peak_shifts_nm": [],
        "tm30_lamps_in_prior": 0,
        "sigma_rel": None,
    }
