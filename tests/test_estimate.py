"""Estimators: closed-form ridge, brightness invariance, class balance, folds."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from bandopt.estimate import (
    Estimator,
    LampTable,
    cv_loss,
    fit_estimator,
    fit_ridge,
    log_ratio_features,
    ratio_features,
    ridge_solve,
    to_model_space,
)


@pytest.mark.parametrize("lam", [1e-6, 0.3, 5.0])
def test_ridge_solve_equals_sklearn(lam):
    from sklearn.linear_model import Ridge

    rng = np.random.default_rng(1)
    x = rng.normal(size=(40, 4))
    y = x @ np.array([1.0, -2.0, 0.5, 0.0]) + 3.0 + 0.1 * rng.normal(size=40)
    w = rng.uniform(0.1, 2.0, size=40)
    beta, b0 = ridge_solve(jnp.asarray(x), jnp.asarray(y), jnp.asarray(w), lam)
    ref = Ridge(alpha=lam, fit_intercept=True, solver="cholesky").fit(
        x, y, sample_weight=w
    )
    # tolerance: both are direct solves of the same 4x4 system in float64
    np.testing.assert_allclose(np.asarray(beta), ref.coef_, rtol=1e-9, atol=1e-10)
    np.testing.assert_allclose(float(b0), ref.intercept_, rtol=1e-9, atol=1e-10)


def test_fit_ridge_ignores_zero_weight_rows_and_constant_features():
    rng = np.random.default_rng(2)
    x = np.column_stack([rng.normal(size=30), np.ones(30)])  # 2nd feature constant
    y = 2 * x[:, 0] + 1
    w = np.r_[np.ones(20), np.zeros(10)]
    y_bad = y.copy()
    y_bad[20:] = np.nan  # NaN targets with zero weight must not matter
    f = fit_ridge(jnp.asarray(x), jnp.asarray(y_bad), jnp.asarray(w), 1e-10)
    assert np.all(np.isfinite(np.asarray(f.coef)))
    np.testing.assert_allclose(np.asarray(f.predict(jnp.asarray(x))), y, atol=1e-6)


@settings(max_examples=20, deadline=None)
@given(scale=st.floats(1e-12, 1e6), degree=st.sampled_from([1, 2]))
def test_features_are_brightness_free(scale, degree):
    rng = np.random.default_rng(3)
    rad = rng.uniform(1e-3, 2.0, size=(7, 4))
    a = log_ratio_features(jnp.asarray(rad), degree)
    b = log_ratio_features(jnp.asarray(rad * scale), degree)
    # relative floor δ scales with the pixel: identical up to rounding
    np.testing.assert_allclose(np.asarray(a), np.asarray(b), rtol=1e-9, atol=1e-9)
    r = ratio_features(jnp.asarray(rad * scale), 0, 1, log=False)
    np.testing.assert_allclose(np.asarray(r)[:, 0], rad[:, 0] / rad[:, 1], rtol=1e-12)


def _toy_table(n_lamps=12, q=3, seed=0):
    rng = np.random.default_rng(seed)
    classes = np.array(["a", "b", "c"] * (n_lamps // 3), dtype=object)
    truth = np.column_stack(
        [
            rng.uniform(100, 300, n_lamps),
            rng.uniform(0, 2, n_lamps),
            rng.uniform(2000, 6000, n_lamps),
        ]
    )
    valid = np.ones_like(truth, bool)
    return LampTable(np.repeat(np.arange(n_lamps), q), classes, truth, valid)


def test_estimator_is_brightness_invariant_and_clips_cct():
    table = _toy_table()
    rng = np.random.default_rng(4)
    rad = rng.uniform(0.1, 1.0, size=(table.lamp_of.size, 3))
    splits = [
        (np.arange(0, 12, 2), np.arange(1, 12, 2)),
        (np.arange(1, 12, 2), np.arange(0, 12, 2)),
    ]
    est = fit_estimator(rad, table, np.arange(12), splits)
    assert isinstance(est, Estimator)
    p1 = np.asarray(est.predict(jnp.asarray(rad)))
    p2 = np.asarray(est.predict(jnp.asarray(rad * 1e5)))
    np.testing.assert_allclose(p1, p2, rtol=1e-9)
    assert np.all((p1[:, 2] >= 1000 - 1e-6) & (p1[:, 2] <= 25000 + 1e-6))


def test_fixed_hyper_parameters_skip_the_inner_cv_and_refit_the_coefficients():
    table = _toy_table()
    rng = np.random.default_rng(6)
    rad = rng.uniform(0.1, 1.0, size=(table.lamp_of.size, 3))
    splits = [
        (np.arange(0, 12, 2), np.arange(1, 12, 2)),
        (np.arange(1, 12, 2), np.arange(0, 12, 2)),
    ]
    train = np.arange(12)
    est = fit_estimator(rad, table, train, splits)
    # no inner splits at all: the inner CV cannot have run
    again = fit_estimator(rad, table, train, (), degree=est.degree, lam=est.lam)
    assert (again.degree, again.lam) == (est.degree, est.lam)
    x = jnp.asarray(rad)
    np.testing.assert_array_equal(
        np.asarray(again.predict(x)), np.asarray(est.predict(x))
    )
    # other radiances: the fixed choices are kept, the coefficients refitted
    other = rad * rng.uniform(0.5, 2.0, size=rad.shape)
    refit = fit_estimator(other, table, train, (), degree=est.degree, lam=est.lam)
    assert (refit.degree, refit.lam) == (est.degree, est.lam)
    assert not np.allclose(np.asarray(refit.fits[0].coef), np.asarray(est.fits[0].coef))
    # values outside the grids are used as given
    odd = fit_estimator(rad, table, train, (), degree=(2, 1, 2), lam=(7.0, 0.5, 3.0))
    assert (odd.degree, odd.lam) == ((2, 1, 2), (7.0, 0.5, 3.0))
    with pytest.raises(ValueError, match="both"):
        fit_estimator(rad, table, train, splits, degree=est.degree)
    with pytest.raises(ValueError, match="one per metric"):
        fit_estimator(rad, table, train, (), degree=(3, 1, 1), lam=est.lam)


def test_class_balanced_split_weights():
    table = _toy_table()
    # an unbalanced lamp subset: class a has 3 lamps, b 1, c 1
    lamps = np.array([0, 3, 6, 1, 2])
    w = table.scenario_weights(lamps)
    assert np.isclose(w.sum(), 1.0)
    per_class = {
        c: w[np.isin(table.lamp_of, lamps[table.classes[lamps] == c])].sum()
        for c in "abc"
    }
    np.testing.assert_allclose(list(per_class.values()), 1 / 3)
    assert np.all(w[~np.isin(table.lamp_of, lamps)] == 0)


def test_cv_loss_matches_manual_validation_mse():
    table = _toy_table()
    rng = np.random.default_rng(5)
    x = jnp.asarray(rng.normal(size=(table.lamp_of.size, 2)))
    y, valid = table.scenario_truth()
    splits = [(np.arange(0, 6), np.arange(6, 12))]
    tr, va = table.split_weights(splits)
    spread = table.spread()
    mw = jnp.array([1.0, 0.0, 0.0])
    got = float(
        cv_loss(
            x,
            jnp.asarray(y),
            jnp.asarray(valid),
            jnp.asarray(tr),
            jnp.asarray(va),
            jnp.asarray(spread),
            mw,
            1e-3,
        )
    )
    f = fit_ridge(x, jnp.asarray(y[:, 0]), jnp.asarray(tr[0]), 1e-3)
    want = (
        float(np.sum(va[0] * (np.asarray(f.predict(x)) - y[:, 0]) ** 2))
        / spread[0] ** 2
    )
    np.testing.assert_allclose(got, want, rtol=1e-10)


def test_mired_round_trip():
    v = jnp.array([[300.0, 1.0, 2700.0]])
    np.testing.assert_allclose(np.asarray(to_model_space(v))[0, 2], 1e6 / 2700)
    assert jax.numpy.allclose(to_model_space(to_model_space(v)), v)
