"""Calibration of class probabilities: reliability, expected calibration error
and temperature scaling.

A classifier's top-class probability is *calibrated* when, among the pixels
given probability p, a fraction p is right. The expected calibration error
(ECE, `Naeini2015`) is the weighted mean gap between confidence and accuracy
over equal-width confidence bins. Temperature scaling (`Guo2017`) divides the
log probabilities by one scalar `T` fitted to held-out data; it never
changes which class is on top, only how sure the answer says it is. The fit
minimises the weighted multi-class Brier score (`Brier1950`), a proper
scoring rule that, unlike the log likelihood, also rewards lower confidence on
pixels whose true class the classifier does not have at all (a lamp type
missing from the prior): their log likelihood is -inf at every `T`.
"""

import dataclasses

import numpy as np
from scipy.optimize import minimize, minimize_scalar


ECE_BINS = 10
"""Equal-width confidence bins of `expected_calibration_error` (the usual
choice of `Naeini2015` and `Guo2017`)."""

PROBABILITY_FLOOR = 1e-12
"""Probabilities are floored here before their logarithm: a posterior that
underflowed to 0 keeps a finite log (and a finite gradient) and is still far
below any probability a reader would act on."""

ROUNDING = 1e-9
"""Confidences this far outside [0, 1] are rounding (a posterior summed over
thousands of lamps) and are clipped; further out is an error."""

TEMPERATURE_BOUNDS = (0.05, 1000.0)
"""Search range of the temperature (log scale): from much sharper to nearly
uniform; a fit on the bound is reported as such (`Temperature.at_bound`)."""


def _as_weights(weights, n: int) -> np.ndarray:
    w = np.ones(n) if weights is None else np.asarray(weights, float)
    if w.shape != (n,) or not np.all(np.isfinite(w)) or np.any(w < 0):
        raise ValueError(f"weights: need {n} finite values >= 0.")
    if w.sum() <= 0:
        raise ValueError("weights: need a positive sum.")
    return w


def reliability_curve(confidence, correct, weights=None, n_bins: int = ECE_BINS):
    """Per equal-width confidence bin on [0, 1]: (edges (n_bins+1,), mean
    confidence, accuracy, weight share), the last three (n_bins,) with NaN in
    empty bins. `confidence` (n,) in [0, 1], `correct` (n,) bool."""
    c = np.asarray(confidence, float)
    ok = np.asarray(correct, bool)
    if c.shape != ok.shape or c.ndim != 1:
        raise ValueError("confidence and correct: need equal 1-D shapes.")
    if np.any(~np.isfinite(c)) or np.any((c < -ROUNDING) | (c > 1 + ROUNDING)):
        raise ValueError("confidence: need values in [0, 1].")
    c = np.clip(c, 0.0, 1.0)
    w = _as_weights(weights, c.size)
    edges = np.linspace(0.0, 1.0, n_bins + 1)
    idx = np.clip(np.digitize(c, edges[1:-1], right=True), 0, n_bins - 1)
    tot = np.bincount(idx, w, n_bins)
    conf = np.bincount(idx, w * c, n_bins)
    acc = np.bincount(idx, w * ok, n_bins)
    with np.errstate(invalid="ignore", divide="ignore"):
        mean_c = np.where(tot > 0, conf / np.where(tot > 0, tot, 1.0), np.nan)
        mean_a = np.where(tot > 0, acc / np.where(tot > 0, tot, 1.0), np.nan)
    return edges, mean_c, mean_a, tot / w.sum()


def expected_calibration_error(
    confidence, correct, weights=None, n_bins: int = ECE_BINS
) -> float:
    """ECE: `Σ_bins share · |accuracy - mean confidence|` of the top-class
    confidence (`Naeini2015`); 0 is perfectly calibrated. [1]"""
    _, c, a, share = reliability_curve(confidence, correct, weights, n_bins)
    used = share > 0
    return float(np.sum(share[used] * np.abs(a[used] - c[used])))


def temper(probabilities, temperature) -> np.ndarray:
    """Probabilities `(n, C)` with their logs divided by `temperature` (a
    scalar or one per row, (n,)) and renormalised: `p^(1/T) / Σ p^(1/T)`.
    T > 1 softens, T < 1 sharpens, T = 1 returns them unchanged (to
    rounding); the order of the classes never changes."""
    p = np.asarray(probabilities, float)
    t = np.asarray(temperature, float)
    if not np.all(np.isfinite(t)) or np.any(t <= 0):
        raise ValueError(f"temperature {temperature!r}: need finite values > 0.")
    t = t[..., None] if t.ndim else t
    logp = np.log(np.maximum(p, PROBABILITY_FLOOR)) / t
    logp = np.where(p > 0, logp, -np.inf)  # a class the prior lacks stays at 0
    top = np.max(logp, axis=-1, keepdims=True)
    top = np.where(np.isfinite(top), top, 0.0)
    e = np.exp(logp - top)
    s = e.sum(axis=-1, keepdims=True)
    return e / np.where(s > 0, s, 1.0)


MISFIT_FLOOR = 1e-3
"""Misfits below this are taken at it in `Temperature.at`: a perfect fit is
no reason for unbounded confidence (and the log stays finite)."""

SLOPE_BOUNDS = (0.0, 2.0)
"""Bounds of the temperature's slope in log misfit: never negative (a pixel
the prior explains worse is never answered more surely), at most 2 (T grows
at most as the squared misfit)."""


@dataclasses.dataclass(frozen=True)
class Temperature:
    """A fitted temperature `T = value · max(misfit, MISFIT_FLOOR)^slope`
    (slope 0: one temperature for all rows) with what it was fitted on: the
    rows, the weighted Brier score and top-class ECE before and after, and
    whether `value` sits on `TEMPERATURE_BOUNDS`."""

    value: float
    slope: float
    n_rows: int
    brier_before: float
    brier_after: float
    ece_before: float
    ece_after: float
    at_bound: bool

    def at(self, misfit=None):
        """The temperature of rows with reduced χ² `misfit` (n,) (None: the
        value at misfit 1)."""
        if misfit is None:
            return self.value
        m = np.maximum(np.asarray(misfit, float), MISFIT_FLOOR)
        return self.value * m**self.slope

    def to_dict(self) -> dict:
        return dataclasses.asdict(self)


def brier_score(probabilities, labels, weights=None) -> float:
    """Weighted multi-class Brier score `Σ_c (p_c - [c = y])²` (`Brier1950`);
    label -1: a class outside the columns (it adds 1 + Σ p_c²). [1]"""
    p = np.asarray(probabilities, float)
    y = np.asarray(labels, int)
    w = _as_weights(weights, y.size)
    onehot = (y[:, None] == np.arange(p.shape[1])[None]).astype(float)
    per = np.sum((p - onehot) ** 2, axis=1) + (y < 0)
    return float(np.sum(w * per) / w.sum())


def fit_temperature(probabilities, labels, weights=None, misfit=None) -> Temperature:
    """The temperature minimising the weighted Brier score of the true classes
    `labels (n,)` (column indices into `probabilities (n, C)`; -1: a class the
    classifier does not have, always wrong).

    Without `misfit`: one temperature, bounded Brent search on log T over
    `TEMPERATURE_BOUNDS` (scipy). With `misfit` (n,), each row's reduced χ²:
    `log T = log value + slope · log max(misfit, MISFIT_FLOOR)`, both fitted
    (L-BFGS-B within the bounds, scipy), so a pixel the prior explains badly,
    as a lamp of a type it lacks often is, is answered less surely."""
    p = np.asarray(probabilities, float)
    y = np.asarray(labels, int)
    if p.ndim != 2 or y.shape != (p.shape[0],) or p.shape[0] == 0:
        raise ValueError("probabilities (n, C) and labels (n,): shapes disagree.")
    if np.any(~np.isfinite(p)) or np.any(p < 0):
        raise ValueError("probabilities: need finite values >= 0.")
    if np.any((y < -1) | (y >= p.shape[1])):
        raise ValueError(f"labels: need -1 or column indices < {p.shape[1]}.")
    w = _as_weights(weights, y.size)
    lo, hi = np.log(TEMPERATURE_BOUNDS)
    res = minimize_scalar(
        lambda s: brier_score(temper(p, float(np.exp(s))), y, w),
        bounds=(lo, hi),
        method="bounded",
        options={"xatol": 1e-4},
    )
    log_t, slope = float(res.x), 0.0
    if misfit is not None:  # from the best single temperature
        m = np.asarray(misfit, float)
        if m.shape != y.shape or np.any(~np.isfinite(m)) or np.any(m < 0):
            raise ValueError("misfit: need one finite value >= 0 per row.")
        lm = np.log(np.maximum(m, MISFIT_FLOOR))
        res = minimize(
            lambda th: brier_score(temper(p, np.exp(th[0] + th[1] * lm)), y, w),
            x0=np.array([log_t, 0.0]),
            method="L-BFGS-B",
            bounds=[(lo, hi), SLOPE_BOUNDS],
        )
        log_t, slope = float(res.x[0]), float(res.x[1])
    fit = Temperature(float(np.exp(log_t)), slope, int(y.size), *(0.0,) * 4, False)
    t = fit.at(misfit)
    right = p.argmax(axis=1) == y
    return dataclasses.replace(
        fit,
        brier_before=brier_score(p, y, w),
        brier_after=brier_score(temper(p, t), y, w),
        ece_before=expected_calibration_error(p.max(axis=1), right, w),
        ece_after=expected_calibration_error(temper(p, t).max(axis=1), right, w),
        at_bound=bool(min(abs(log_t - lo), abs(log_t - hi)) < 1e-3),
    )
