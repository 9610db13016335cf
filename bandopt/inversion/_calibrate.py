"""Calibration on inner folds' held-out lamps: split-conformal interval factors
(`Romano2019`) and the narrowest interval unit, class-balanced row weights,
and the misfit-dependent temperatures of the type probabilities
(`bandopt.calibration`); `UNEXPLAINED_QUANTILE` and `FLAG_NOISE` set the
`unexplained` test."""

import numpy as np

from ..calibration import expected_calibration_error, fit_temperature, temper
from ..datasets.lamps import LEVEL1, LEVEL2
from ..folds import class_balanced_weights
from ._metrics import COVERAGE, INTERVAL_FLOOR, _widened, weighted_quantile
from ._prior import LampPrior


UNEXPLAINED_QUANTILE = 0.95
"""A pixel is unexplained when its cross-conformal p-value
(`Inversion.known_type_p_value`, `Vovk2015`, class-conditional) is below
1 - 0.95: its misfit at `FLAG_NOISE` under each inner fold's prior ranks
above the 95th percentile of that fold's held-out lamps of the type it is
called. The usual 5 % level of a test; not chosen on any score. The final
prior's own misfit is not compared with a threshold from the inner folds
(the pooled 95th percentile, kept as `Inversion.threshold` for fits without
inner folds): it holds more lamps than the inner priors and explains every
pixel better, so such a threshold flags far fewer than 5 % of new lamps of
known types and few of the types it lacks."""


FLAG_NOISE = (0.003, 1e-3)
"""Band error (`σ_rel`, floor) of the misfit that decides `unexplained`: the
sharpest of `SIGMA_REL_GRID` with `SIGMA_FLOOR`, whatever band error the
estimates use. With a relative band error σ a band the prior cannot produce
at all adds only ~1/σ² to χ², so at the σ of 0.1 a fit may choose no pixel
can ever exceed the held-out lamps' upper percentiles and the flag never fires;
at 0.003 a pixel unlike every lamp stands far above any held-out lamp."""


INTERVAL_OFFSET_GRID = (0.0, 0.01, 0.03, 0.1, 0.3, 1.0, 3.0, 10.0)
"""Candidate offsets of the conformal interval's unit, as fractions of the
metric's spread over the training lamps (model space), for `fit_inversion(
interval_offsets=)`: a pixel's interval is its posterior 5-95 % range
widened by `conformal x (half-width + offset)`. 0 scales with the
posterior's width alone (a concentrated posterior gets a narrow interval,
a broad one a very wide one); large offsets widen every pixel by nearly the
same amount (at 10 x the spread, far above any posterior half-width, the
interval is in effect additive, as `Romano2019`'s conformalised quantile
regression). On partition 0, fold 0 the grid up to 1 chose 1 for LER and
CCT; 3 and 10 narrowed the calibration intervals by a further 5-7 %."""


GLOBAL_LEVEL2 = tuple(dict.fromkeys((*LEVEL2, *LEVEL1)))
"""Level-2 columns of the calibration rows: every level-2 class, then the
level-1 names that stand for lamps without a level-2 class."""


def _global_probabilities(post, prior: LampPrior):
    """Level-1 (n, len(LEVEL1)) and level-2 (n, len(GLOBAL_LEVEL2))
    probabilities of posteriors `post` (n, k) on fixed columns, so rows from
    priors that lack some classes line up (a class the prior lacks: 0)."""
    m1 = np.array([[c == x for x in LEVEL1] for c in prior.level1], float)
    m2 = np.array([[c == x for x in GLOBAL_LEVEL2] for c in prior.level2], float)
    tot = np.sum(post, axis=1, keepdims=True)  # 1 to the scoring's precision
    post = post / np.where(tot > 0, tot, 1.0)
    return post @ m1, post @ m2


def _probability_temperatures(known, novel, thr, row_lamp, lamps, l2):
    """Misfit-dependent temperatures ((value, slope) for level 1 and level 2,
    `calibration.fit_temperature`) of the type probabilities, fitted on the
    held-out rows of known types `known` (inner folds, class-balanced), and
    the diagnostics: temperatures, then per group (`known` and `novel`, the
    rows of each training class held out in turn) the level-1 accuracy, ECE
    before/after and the `unexplained` rate at threshold `thr` (rows
    `(rows, lamps, level-1 probs, level-2 probs, misfit, misfit at
    FLAG_NOISE)`). A lamp of a type the prior lacks can never be named: its
    pixels are the `unexplained` flag's to catch, and fitting the temperature
    on them too made the answers on known types under-confident (level-1 ECE
    0.14 on held-out lamps, robustness suite at cc13a9a) without making
    those on new types trustworthy (0.38)."""
    groups = {"known_types": known, "left_out_types": novel}
    data = {}
    for name, items in groups.items():
        if not items:
            continue
        rows = np.concatenate([it[0] for it in items])
        w = np.concatenate([_row_weights(it[0], it[1], row_lamp, l2) for it in items])
        data[name] = (
            rows,
            w / w.sum(),
            np.vstack([it[2] for it in items]),
            np.vstack([it[3] for it in items]),
            np.concatenate([it[4] for it in items]),
            np.concatenate([it[5] for it in items]),
        )
    lab1 = np.array([LEVEL1.index(x) for x in lamps.level1])
    lab2 = np.array([GLOBAL_LEVEL2.index(x) for x in lamps.level2])
    rows, w, p1, p2, mis, _ = data["known_types"]
    fits = [
        fit_temperature(p, lab[row_lamp[rows]], w, mis)
        for p, lab in ((p1, lab1), (p2, lab2))
    ]
    diag = {
        "calibrated": True,
        "method": "temperature scaling fitted by the Brier score on held-out "
        "lamps of known types (bandopt.calibration)",
        "fitted_on": "known_types",
        "level1": fits[0].to_dict(),
        "level2": fits[1].to_dict(),
        "unexplained_false_flag_rate": 1.0 - UNEXPLAINED_QUANTILE,
        "groups": {},
    }
    for name, (r, wg, p1, _p2, m, m_flag) in data.items():
        right = p1.argmax(axis=1) == lab1[row_lamp[r]]
        flagged = m_flag > thr
        diag["groups"][name] = {
            "rows": int(r.size),
            "level1_right": float(np.sum(wg * right)),
            "ece_level1_before": expected_calibration_error(p1.max(axis=1), right, wg),
            "ece_level1_after": expected_calibration_error(
                temper(p1, fits[0].at(m)).max(axis=1), right, wg
            ),
            "unexplained_rate": float(np.sum(wg * flagged)),
        }
    return tuple((f.value, f.slope) for f in fits), diag


def _per_metric_held_out(per_metric_calib):
    """Held-out inner-fold data `(rows, mean, range, misfit, lamps)` per fold
    with metric m's columns from `per_metric_calib[m]` (the same folds scored
    at that metric's `σ_rel`); rows, misfit and lamps from the first."""
    out = []
    for folds in zip(*per_metric_calib, strict=True):
        rows, _, _, misfit, va = folds[0]
        mean = np.stack([f[1][:, m] for m, f in enumerate(folds)], axis=1)
        rng = np.stack([f[2][:, m] for m, f in enumerate(folds)], axis=1)
        out.append((rows, mean, rng, misfit, va))
    return out


def _row_weights(rows, va, row_lamp, l2) -> np.ndarray:
    """Weights of held-out rows: class-balanced over the held-out lamps `va`,
    each lamp's weight shared by its rows."""
    lamp_w = dict(zip(va, class_balanced_weights(l2[va]), strict=True))
    rl = row_lamp[rows]
    counts = {l: int((rl == l).sum()) for l in va}
    return np.array([lamp_w[l] / counts[l] for l in rl])


def _conformal_factors(held_out, row_lamp, l2, tm, valid, offset=0.0) -> np.ndarray:
    """Split-conformal factor per metric (3,): the `COVERAGE` weighted
    quantile over held-out rows of the distance of the true value outside the
    posterior 5-95 % range, in units of `max(half-width, INTERVAL_FLOOR) +
    offset` (`offset`: (3,) or scalar, model space; `held_out`: (rows, mean,
    range, misfit, lamps) per held-out set; rows class-balanced within a
    set)."""
    s_all, w_all = [], []
    for rows, _mean, rng, _misfit, va in held_out:
        rl = row_lamp[rows]
        half = np.maximum((rng[..., 1] - rng[..., 0]) / 2, INTERVAL_FLOOR) + offset
        y = tm[rl]
        score = np.maximum(rng[..., 0] - y, y - rng[..., 1]) / half
        s_all.append(np.where(valid[rl], score, np.nan))
        w_all.append(_row_weights(rows, va, row_lamp, l2))
    s_all, w_all = np.vstack(s_all), np.concatenate(w_all)
    conf = np.empty(3)
    for m in range(3):
        ok = ~np.isnan(s_all[:, m])
        conf[m] = max(
            float(weighted_quantile(s_all[ok, m], w_all[None, ok], (COVERAGE,))[0, 0]),
            0.0,
        )
    return conf


def _narrowest_intervals(held_out, row_lamp, l2, tm, valid, offsets):
    """Per metric, the candidate offset (`offsets` (C, 3), model space) whose
    conformal intervals are narrowest on the held-out rows at their
    calibrated coverage: the class-balanced mean width of the clipped
    intervals (`_widened`; ties: the first). Returns the chosen index per
    metric (3,), the conformal factors (C, 3) and the mean widths (C, 3)."""
    offsets = np.asarray(offsets, float)
    conf = np.array(
        [_conformal_factors(held_out, row_lamp, l2, tm, valid, o) for o in offsets]
    )
    width = np.zeros(offsets.shape)
    for c, o in enumerate(offsets):
        num, den = np.zeros(3), np.zeros(3)
        for rows, mean, rng, _misfit, va in held_out:
            _, lo, hi = _widened(mean, rng, conf[c], o)
            ok = valid[row_lamp[rows]]
            w = _row_weights(rows, va, row_lamp, l2)[:, None] * ok
            num += np.sum(w * np.where(ok, hi - lo, 0.0), axis=0)
            den += w.sum(axis=0)
        width[c] = num / np.maximum(den, 1e-300)
    return np.argmin(width, axis=0), conf, width
