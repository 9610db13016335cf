"""Interval calibration of the inversion on held-out classes
(`fit_inversion(calibration="classes")`, estimator `inversion-moon-loco`):
the point estimates do not change, the conformal factors are the
`COVERAGE` quantile of the training classes held out one at a time, and no
held-out class's prior holds it."""

import numpy as np
import pytest

from bandopt import inversion as inv_mod
from bandopt.estimate import lamp_truth
from tests._bands import FIVE, GRID
from tests._inversion import patch_inversion
from tests.test_inversion_models import _case, _fake_context


@pytest.fixture(scope="module")
def case():
    return _case()


@pytest.fixture(scope="module")
def pair(case):
    """The same fit calibrated on inner-fold lamps and on held-out classes,
    and the priors the class calibration built."""
    lamps, row_lamp, rad, train, _test, inner, w = case
    cond = inv_mod.Conditions.clear(GRID)
    kw = dict(basis=inv_mod._basis(GRID))
    built = []
    real = inv_mod.build_inversion

    def spy(pset, *a, **k):
        built.append(tuple(pset.level2))
        return real(pset, *a, **k)

    by_lamps = inv_mod.fit_inversion(rad, row_lamp, lamps, train, inner, w, cond, **kw)
    with pytest.MonkeyPatch.context() as mp:
        patch_inversion(mp, "build_inversion", spy)
        by_classes = inv_mod.fit_inversion(
            rad, row_lamp, lamps, train, inner, w, cond, calibration="classes", **kw
        )
    return by_lamps, by_classes, built


def test_same_point_estimates_other_intervals(case, pair):
    _lamps, row_lamp, rad, _train, test, *_ = case
    by_lamps, by_classes, _ = pair
    assert by_lamps.diagnostics["calibration"] == "lamps"
    assert by_classes.diagnostics["calibration"] == "classes"
    assert by_classes.sigma_rel == by_lamps.sigma_rel
    assert by_classes.threshold == by_lamps.threshold  # flags unchanged
    rows = np.flatnonzero(np.isin(row_lamp, test))
    a, b = by_lamps.predict(rad[rows]), by_classes.predict(rad[rows])
    np.testing.assert_array_equal(a.estimate, b.estimate)
    np.testing.assert_array_equal(a.unexplained, b.unexplained)
    assert not np.allclose(by_lamps.conformal, by_classes.conformal)


def test_each_training_class_is_held_out_from_its_own_prior(case, pair):
    """After the inner folds (2 priors) and before the final prior, one prior
    per training class, each without that class and with all the others."""
    lamps, _row_lamp, _rad, train, _test, inner, _w = case
    _, _, built = pair
    classes = sorted(set(np.asarray(lamps.level2, object)[train]))
    per_class = built[len(inner) : len(inner) + len(classes)]
    assert len(built) == len(inner) + len(classes) + 1
    for c, prior in zip(classes, per_class, strict=True):
        assert c not in prior
        assert set(prior) == set(classes) - {c}


def test_factors_are_the_coverage_quantile_of_the_held_out_classes(case, pair):
    """Widened by the fitted factors, the posterior ranges of the held-out
    classes' rows cover at least `COVERAGE` of the true values (class-balanced
    weights), and a slightly smaller factor covers less: the factor is the
    quantile, not merely an upper bound."""
    lamps, row_lamp, rad, train, _test, _inner, w = case
    _, by_classes, _ = pair
    truth, valid = lamp_truth(lamps.spectra, GRID)
    tm = inv_mod._to_model(np.where(valid, truth, 1.0))
    l2 = np.asarray(lamps.level2, object)
    cond = inv_mod.Conditions.clear(GRID)
    basis = inv_mod._basis(GRID)
    scores, weights = [], []
    for c in sorted(set(l2[train])):
        va = train[l2[train] == c]
        tr = train[l2[train] != c]
        rows = np.flatnonzero(np.isin(row_lamp, va))
        inv = inv_mod.build_inversion(
            lamps.take(tr), w, cond, basis, "unknown", by_classes.sigma_rel
        )
        post, _ = inv.posterior(rad[rows])
        _, rng, _ = inv_mod._posterior_metrics(post, inv.prior)
        half = np.maximum((rng[..., 1] - rng[..., 0]) / 2, inv_mod.INTERVAL_FLOOR)
        y = tm[row_lamp[rows]]
        s = np.maximum(rng[..., 0] - y, y - rng[..., 1]) / half
        scores.append(np.where(valid[row_lamp[rows]], s, np.nan))
        rl = row_lamp[rows]
        n_lamps = len(va)
        weights.append(np.array([1.0 / (n_lamps * (rl == lamp).sum()) for lamp in rl]))
    s, wt = np.vstack(scores), np.concatenate(weights)
    for m, f in enumerate(by_classes.conformal):
        ok = ~np.isnan(s[:, m])
        covered = np.sum(wt[ok] * (s[ok, m] <= f + 1e-9)) / wt[ok].sum()
        assert covered >= inv_mod.COVERAGE - 1e-9
        if f > 0:
            less = np.sum(wt[ok] * (s[ok, m] <= f * 0.98)) / wt[ok].sum()
            assert less < covered or f == pytest.approx(0.0)


def test_bad_calibration_is_refused(case):
    lamps, row_lamp, rad, train, _test, inner, w = case
    with pytest.raises(ValueError, match="calibration 'folds'"):
        inv_mod.fit_inversion(
            rad, row_lamp, lamps, train, inner, w,
            inv_mod.Conditions.clear(GRID), calibration="folds",
        )  # fmt: skip


def test_cross_validate_runs_the_loco_estimator(case, monkeypatch):
    lamps, row_lamp, *_ = case
    setup = (lamps, None, inv_mod.Conditions.clear(GRID), ["asphalt"] * len(row_lamp))
    patch_inversion(monkeypatch, "context_setup", lambda c: setup)
    patch_inversion(monkeypatch, "context_moon", lambda c: np.zeros(len(row_lamp)))
    recs = inv_mod.cross_validate(
        _fake_context(case),
        FIVE,
        estimators=(inv_mod.MOON_ESTIMATOR, inv_mod.MOON_UNSEEN_ESTIMATOR),
        folds=[0],
    )
    by = {}
    for r in recs:
        by.setdefault(r.estimator, {})[r.lamp] = r
    a, b = by[inv_mod.MOON_ESTIMATOR], by[inv_mod.MOON_UNSEEN_ESTIMATOR]
    assert set(a) == set(b)
    for lamp in a:  # same point estimates: same errors
        for m in ("LER", "G", "CCT"):
            assert getattr(a[lamp], m) == getattr(b[lamp], m)


@pytest.fixture(scope="module")
def flagged(case):
    lamps, row_lamp, rad, train, _test, inner, w = case
    return inv_mod.fit_inversion(
        rad, row_lamp, lamps, train, inner, w, inv_mod.Conditions.clear(GRID),
        basis=inv_mod._basis(GRID), calibration="flagged",
    )  # fmt: skip


def test_flagged_pixels_get_the_held_out_classes_intervals(case, pair, flagged):
    """`calibration="flagged"`: the factors of held-out lamps for pixels the
    prior explains and those of held-out classes for pixels flagged
    `unexplained`, pixel by pixel; the estimates and flags are those of the
    other two calibrations."""
    _lamps, row_lamp, rad, _train, test, *_ = case
    by_lamps, by_classes, _ = pair
    assert flagged.diagnostics["calibration"] == "flagged"
    np.testing.assert_allclose(flagged.conformal, by_lamps.conformal)
    np.testing.assert_allclose(flagged.conformal_unexplained, by_classes.conformal)
    rows = np.flatnonzero(np.isin(row_lamp, test))
    a, b, f = (x.predict(rad[rows]) for x in (by_lamps, by_classes, flagged))
    np.testing.assert_array_equal(f.estimate, a.estimate)
    np.testing.assert_array_equal(f.unexplained, a.unexplained)
    # every test pixel, once as explained and once as flagged: a threshold
    # of +inf explains all, of -inf flags all (the p-value folds dropped)
    import dataclasses

    for thr, want in ((np.inf, a), (-np.inf, b)):
        g = dataclasses.replace(flagged, threshold=thr, flag_folds=())
        got = g.predict(rad[rows])
        assert bool(np.all(got.unexplained)) == (thr < 0)
        np.testing.assert_allclose(got.interval90, want.interval90, equal_nan=True)
    mixed = f.unexplained
    if mixed.any() and (~mixed).any():
        np.testing.assert_allclose(f.interval90[~mixed], a.interval90[~mixed])
