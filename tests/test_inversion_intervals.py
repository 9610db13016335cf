"""The unit of the inversion's conformal intervals (`fit_inversion(
interval_offsets=)`): a pixel's 90 % interval is its posterior 5-95 % range
widened by `conformal x (half-width + offset)`; each metric takes the
candidate offset whose calibrated intervals are narrowest on the held-out
calibration lamps."""

import numpy as np
import pytest

from bandopt import inversion as inv_mod
from bandopt.estimate import METRICS, MIRED
from bandopt.photometry import K_M_LM_PER_W
from tests._bands import FIVE, GRID
from tests._inversion import patch_inversion
from tests.test_inversion_models import _case, _fake_context


def _held_out(displacement, half, seed=0):
    """One synthetic held-out set of 400 rows (40 lamps of 4 classes, 10 rows
    each): ranges `±half` around posterior means displaced from the truth by
    `displacement` (both (rows, 3); G's scaled by 1/1000, so every interval
    stays in the physical range)."""
    rng = np.random.default_rng(seed)
    n_lamps, per = 40, 10
    l2 = np.array([f"c{i % 4}" for i in range(n_lamps)], dtype=object)
    row_lamp = np.repeat(np.arange(n_lamps), per)
    tm = np.column_stack(
        [rng.uniform(50, 300, n_lamps), rng.uniform(-1, 1, n_lamps),
         rng.uniform(150, 450, n_lamps)]
    )  # fmt: skip
    valid = np.ones((n_lamps, 3), bool)
    rows = np.arange(row_lamp.size)
    scale = np.array([1.0, 0.001, 1.0])
    mean = tm[row_lamp] + displacement * scale
    rng_ = np.stack([mean - half * scale, mean + half * scale], axis=-1)
    held = [(rows, mean, rng_, np.zeros(rows.size), np.arange(n_lamps))]
    return held, row_lamp, l2, tm, valid


def _weighted_coverage(held, row_lamp, l2, tm, conf, offset):
    rows, mean, rng, _, va = held[0]
    _, lo, hi = inv_mod._widened(mean, rng, conf, offset)
    y = tm[row_lamp[rows]]
    inside = (lo <= y) & (y <= hi)
    w = inv_mod._row_weights(rows, va, row_lamp, l2)
    return (w[:, None] * inside).sum(axis=0) / w.sum()


def test_the_narrowest_calibrated_unit_follows_how_errors_scale():
    """Errors that do not grow with the posterior's width call for an additive
    unit (the largest offset); errors exactly proportional to it for the
    width alone (offset 0). Every candidate covers the calibration rows at
    `COVERAGE`, no more."""
    rng = np.random.default_rng(1)
    width = np.exp(rng.uniform(np.log(0.1), np.log(30), (400, 3)))  # varies
    sign = rng.choice([-1.0, 1.0], (400, 3))
    offsets = np.array([0.0, 1.0, 10.0, 100.0])[:, None] * [1.0, 0.001, 1.0]
    for disp, want in ((10.0 * rng.normal(size=(400, 3)), 3), (1.5 * width * sign, 0)):
        held, row_lamp, l2, tm, valid = _held_out(disp, width)
        pick, conf, mean_w = inv_mod._narrowest_intervals(
            held, row_lamp, l2, tm, valid, offsets
        )
        assert list(pick) == [want] * 3
        np.testing.assert_array_equal(pick, np.argmin(mean_w, axis=0))
        assert mean_w[want, 0] < 0.75 * mean_w[3 - want, 0]  # a real gain
        for c in range(len(offsets)):
            cov = _weighted_coverage(held, row_lamp, l2, tm, conf[c], offsets[c])
            # the quantile's own row may fall outside by rounding: one row
            assert np.all(cov >= inv_mod.COVERAGE - 1 / 400 - 1e-12)
            if want == 3:  # continuous scores: not wider than needed (the
                # proportional case's offset-0 scores tie: all rows covered)
                assert np.all(cov <= inv_mod.COVERAGE + 0.02)
        # the factor at offset 0 is `_conformal_factors`' (as before)
        np.testing.assert_array_equal(
            conf[0], inv_mod._conformal_factors(held, row_lamp, l2, tm, valid)
        )


@pytest.fixture(scope="module")
def case():
    return _case()


@pytest.fixture(scope="module")
def fits(case):
    lamps, row_lamp, rad, train, _test, inner, w = case
    args = (rad, row_lamp, lamps, train, inner, w, inv_mod.Conditions.clear(GRID))
    kw = dict(basis=inv_mod._basis(GRID))
    default = inv_mod.fit_inversion(*args, **kw)
    narrow = inv_mod.fit_inversion(
        *args, interval_offsets=inv_mod.INTERVAL_OFFSET_GRID, **kw
    )
    return args, kw, default, narrow


def test_offsets_change_the_intervals_only(case, fits):
    """Same posterior, estimates, types and flags; the offset-0 candidate of a
    fit with the grid is the default fit exactly; the chosen candidate per
    metric has the smallest calibration width and its own factor."""
    _lamps, row_lamp, rad, _train, test, *_ = case
    _, _, default, narrow = fits
    assert default.offsets.tolist() == [0.0, 0.0, 0.0]
    assert narrow.sigma_rel == default.sigma_rel
    assert narrow.threshold == default.threshold
    rows = np.flatnonzero(np.isin(row_lamp, test))
    a, b = default.predict(rad[rows]), narrow.predict(rad[rows])
    np.testing.assert_array_equal(a.estimate, b.estimate)
    np.testing.assert_array_equal(a.unexplained, b.unexplained)
    np.testing.assert_array_equal(a.level2_probabilities, b.level2_probabilities)
    zero = narrow.with_interval_offset(0.0)
    np.testing.assert_array_equal(zero.conformal, default.conformal)
    np.testing.assert_array_equal(zero.predict(rad[rows]).interval90, a.interval90)
    d = narrow.diagnostics
    cands = d["interval_candidates"]
    assert set(cands) == {f"{f:g}" for f in inv_mod.INTERVAL_OFFSET_GRID}
    for m, name in enumerate(METRICS):
        chosen = f"{d['interval_offset'][name]:g}"
        widths = {k: c["mean_width"][name] for k, c in cands.items()}
        assert widths[chosen] == min(widths.values())
        assert narrow.conformal[m] == cands[chosen]["conformal"][name]
        assert narrow.offsets[m] == cands[chosen]["offset"][name]
    # the intervals by hand: posterior 5-95 % range ± factor x (half + offset)
    post, _ = narrow.posterior(rad[rows])
    _mean, rng, _ = inv_mod._posterior_metrics(post, narrow.prior)
    half = np.maximum((rng[..., 1] - rng[..., 0]) / 2, inv_mod.INTERVAL_FLOOR)
    lo = np.clip(rng[:, 0, 0] - narrow.conformal[0] * (half[:, 0] + narrow.offsets[0]),
                 0.0, K_M_LM_PER_W)  # fmt: skip
    np.testing.assert_allclose(b.interval90[:, 0, 0], np.minimum(lo, b.estimate[:, 0]))


def test_bad_offsets_are_refused(fits):
    args, kw, default, _ = fits
    for bad in ((), (-0.1,), (0.0, 0.0)):
        with pytest.raises(ValueError, match="interval_offsets"):
            inv_mod.fit_inversion(*args, interval_offsets=bad, **kw)
    with pytest.raises(ValueError, match="calibrated only"):
        default.with_interval_offset(0.3)


def test_interval_fields_by_hand():
    iv = np.array([[[100.0, 200.0], [0.1, 0.3], [2500.0, 5000.0]],
                   [[150.0, 170.0], [0.2, 0.25], [3000.0, 4000.0]]])  # fmt: skip
    f = inv_mod.interval_fields(iv, np.array([160.0, 0.28, 3500.0]), [True] * 3)
    assert f["LER_covered"] == 1.0 and f["G_covered"] == 0.5
    assert f["LER_width"] == pytest.approx(60.0)
    assert f["CCT_width"] == pytest.approx((2500.0 + 1000.0) / 2)
    mired = ((1e6 / 2500 - 1e6 / 5000) + (1e6 / 3000 - 1e6 / 4000)) / 2
    assert f["CCT_width_mired"] == pytest.approx(mired)
    assert "G_width" not in inv_mod.interval_fields(iv, np.zeros(3), [1, 0, 1])


def test_cross_validate_scores_both_intervals_from_one_fit(case, monkeypatch):
    """`inversion-moon-mix-metric` asked with the narrow variant comes from the
    narrow fit at offset 0: records identical to its own fit's."""
    lamps, row_lamp, *_ = case
    setup = (lamps, None, inv_mod.Conditions.clear(GRID), ["asphalt"] * len(row_lamp))
    patch_inversion(monkeypatch, "context_setup", lambda c: setup)
    patch_inversion(monkeypatch, "context_moon", lambda c: np.zeros(len(row_lamp)))
    fitted = []
    real = inv_mod.fit_inversion

    def spy(*a, **kw):
        fitted.append(tuple(kw["interval_offsets"]))
        return real(*a, **kw)

    patch_inversion(monkeypatch, "fit_inversion", spy)
    ctx = _fake_context(case)
    base, narrow = inv_mod.MIX_METRIC_ESTIMATOR, inv_mod.NARROW_ESTIMATOR
    both = inv_mod.cross_validate(ctx, FIVE, estimators=(base, narrow), folds=[0])
    assert fitted == [inv_mod.INTERVAL_OFFSET_GRID]
    alone = inv_mod.cross_validate(ctx, FIVE, estimators=(base,), folds=[0])
    assert fitted[1:] == [(0.0,)]
    by = {}
    for r in both:
        by.setdefault(r.estimator, []).append(r)
    assert by[base] == alone
    for a, b in zip(by[base], by[narrow], strict=True):
        assert (a.lamp, a.LER, a.G) == (b.lamp, b.LER, b.G)
        assert {"LER_width", "G_width", "LER_covered"} <= set(b.to_dict())


def _reference_metrics(post, prior, m):
    """The rule `_posterior_metrics` compiles, in plain numpy: the mean and
    5-95 % weighted quantiles of metric m's valid prior values."""
    t = prior.truth[:, m].copy()
    ok = prior.valid[:, m]
    if m == 2:
        t = np.where(ok, MIRED / np.where(ok, t, 1.0), 0.0)
    w = post * ok[None]
    w = w / np.maximum(w.sum(axis=1, keepdims=True), 1e-300)
    vals = np.where(ok, t, 0.0)
    q = inv_mod.weighted_quantile(vals[ok], w[:, ok], (0.05, 0.95))
    return w @ vals, q


@pytest.mark.parametrize("rows", [1, 37])
def test_compiled_posterior_summary_is_the_weighted_quantile_rule(rows, monkeypatch):
    """Random posteriors (sharp and flat, one with no valid mass) over a prior
    with invalid entries and tied values; more rows than a compiled call
    takes (`METRIC_ROWS` patched to 16: padding and chunks)."""
    patch_inversion(monkeypatch, "METRIC_ROWS", 16)
    rng = np.random.default_rng(3)
    k = 29
    truth = np.column_stack(
        [rng.choice([80.0, 120.0, 300.0], k), rng.normal(0, 1, k),
         rng.uniform(1800, 6500, k)]
    )  # fmt: skip
    valid = rng.random((k, 3)) > 0.25
    ids = tuple(f"l{i}" for i in range(k))
    prior = inv_mod.LampPrior(
        ids, np.zeros((k, 2)), ids, ids, truth, valid, np.zeros(k)
    )
    lk = rng.normal(0, 1, (rows, k)) * rng.choice([0.1, 10.0], (rows, 1))
    post = np.exp(lk - lk.max(axis=1, keepdims=True))
    post /= post.sum(axis=1, keepdims=True)
    post[0] = np.where(valid[:, 0], 0.0, 1.0 / (~valid[:, 0]).sum())  # no valid mass
    mean, rng_, p_cct = inv_mod._posterior_metrics(post, prior)
    for m in range(3):
        want_mean, want_q = _reference_metrics(post, prior, m)
        np.testing.assert_allclose(mean[:, m], want_mean, rtol=1e-12, atol=1e-12)
        np.testing.assert_array_equal(rng_[:, m], want_q)
    np.testing.assert_allclose(p_cct, post @ valid[:, 2])
    only_g, rng_g, _ = inv_mod._posterior_metrics(post, prior, metrics=(1,))
    assert np.isnan(only_g[:, [0, 2]]).all()
    np.testing.assert_array_equal(rng_g[:, 1], rng_[:, 1])
