"""The per-pixel result of the inversion, `InversionResult` (estimates,
intervals, type probabilities, flags; JSON-ready rows), and `top_two`, the
two most probable types of a pixel."""

import dataclasses

import numpy as np

from ..estimate import METRICS


CLOSE_CALL_RATIO = 0.5
"""A level-1 call is close when the second type is at least this fraction as
probable as the first (e.g. 0.6 against 0.3): the answer names both."""


def top_two(probabilities: dict) -> dict:
    """The two most probable types of `{type: probability}` (ties in the
    given order) and whether the call is close (`CLOSE_CALL_RATIO`): then
    both are answers a user should weigh."""
    order = sorted(probabilities, key=lambda k: -probabilities[k])[:2]
    pair = [{"type": k, "probability": float(probabilities[k])} for k in order]
    close = len(pair) == 2 and pair[1]["probability"] >= CLOSE_CALL_RATIO * max(
        pair[0]["probability"], 1e-300
    )
    return {"types": pair, "close": bool(close)}


def _finite_or_none(values, i: int) -> float | None:
    """`values[i]` as a float, None when `values` is None or it is NaN."""
    if values is None or not np.isfinite(values[i]):
        return None
    return float(values[i])


@dataclasses.dataclass(frozen=True)
class InversionResult:
    """Per pixel: `estimate` (n, 3) [lm W⁻¹], [1], [K] (CCT NaN where not
    meaningful), `interval90` (n, 3, 2), `cct_probability` (P(CCT meaningful)),
    `unexplained` (n,), `misfit` (reduced χ², n), level-1/-2 probabilities
    with their labels, and the predicted types (None where unexplained)."""

    estimate: np.ndarray
    interval90: np.ndarray
    cct_probability: np.ndarray
    unexplained: np.ndarray
    misfit: np.ndarray
    level1_labels: tuple[str, ...]
    level1_probabilities: np.ndarray
    level2_labels: tuple[str, ...]
    level2_probabilities: np.ndarray
    level1: tuple[str | None, ...]
    level2: tuple[str | None, ...]
    testable: bool
    known_type_p: np.ndarray | None = None

    def row(self, i: int) -> dict:
        """JSON-ready result of pixel `i`: metrics null with a reason where they
        cannot be estimated, never outside `PHYSICAL_RANGE`."""
        est, reasons, iv = {}, {}, {}
        for m, name in enumerate(METRICS):
            v = float(self.estimate[i, m])
            lo, hi = (float(x) for x in self.interval90[i, m])
            if self.unexplained[i]:
                est[name], iv[name] = None, None
                reasons[name] = "unexplained: no lamp of the prior fits this pixel"
            elif not np.isfinite(v):
                est[name], iv[name] = None, None
                reasons[name] = (
                    "no meaningful CCT: the posterior favours lamps whose "
                    f"chromaticity is > 0.05 Duv off the Planckian locus "
                    f"(P(meaningful) = {self.cct_probability[i]:.2f})"
                )
            else:
                est[name], iv[name] = v, [lo, hi]
        return {
            "estimate": est,
            "interval90": iv,
            "null_reasons": reasons,
            "unexplained": bool(self.unexplained[i]),
            "misfit_reduced_chi2": float(self.misfit[i]),
            "known_type_p_value": _finite_or_none(self.known_type_p, i),
            "level1_probabilities": {
                k: float(p)
                for k, p in zip(
                    self.level1_labels, self.level1_probabilities[i], strict=True
                )
            },
            "predicted_level1": self.level1[i],
            "predicted_level2": self.level2[i],
            "level1_top2": self.top2(i),
        }

    def top2(self, i: int) -> dict:
        """`top_two` of pixel `i`'s level-1 probabilities."""
        return top_two(
            dict(zip(self.level1_labels, self.level1_probabilities[i], strict=True))
        )

    @classmethod
    def concatenate(cls, parts: "list[InversionResult]") -> "InversionResult":
        """The results of consecutive chunks of pixels as one, in order; the
        parts must come from one inversion (the same type labels)."""
        if not parts:
            raise ValueError("parts: need at least one result.")
        first = parts[0]
        for p in parts[1:]:
            same = (p.level1_labels, p.level2_labels, p.testable)
            if same != (first.level1_labels, first.level2_labels, first.testable):
                raise ValueError(
                    "parts: results of different inversions (type labels or "
                    "testability differ)."
                )

        def cat(name):
            return np.concatenate([getattr(p, name) for p in parts])

        def join(name):
            return tuple(x for p in parts for x in getattr(p, name))

        nan = [np.full(len(p.misfit), np.nan) for p in parts]
        return cls(
            cat("estimate"),
            cat("interval90"),
            cat("cct_probability"),
            cat("unexplained"),
            cat("misfit"),
            first.level1_labels,
            cat("level1_probabilities"),
            first.level2_labels,
            cat("level2_probabilities"),
            join("level1"),
            join("level2"),
            first.testable,
            None
            if all(p.known_type_p is None for p in parts)
            else np.concatenate(
                [
                    x if p.known_type_p is None else p.known_type_p
                    for p, x in zip(parts, nan, strict=True)
                ]
            ),
        )
