"""Pruned scoring (`Inversion.predict(prune=)`): the lamps it leaves out
carry no more posterior mass than its bound, the bound is no more than the
tolerance asked for, and a pruned prediction is the unpruned one within
that tolerance (the misfit, flags and type calls the same)."""

import numpy as np
import pytest

from bandopt import inversion as inv_mod
from tests.test_inversion_chunked import fitted  # noqa: F401 (fixture)


RTOL = 1e-9
"""Quantities pruning leaves exact (the misfit, survivors' log evidence):
only the rounding of compiled calls of other shapes differs."""


def _moons(y):
    n = y.shape[0]
    return {
        "moonless": np.zeros(n),
        "told": np.random.default_rng(1).uniform(0, 1, n),
    }


def _scored(inv, y, moon, prune):
    noise = np.asarray(inv._predict_noise())
    cand, lps = inv.candidates(y.shape[0])
    a, q = inv.design
    return inv_mod.score_pruned(
        y, cand, lps, a, q, inv.prior.log_prior, noise, moon, shared=True,
        prune=prune,
    )  # fmt: skip


@pytest.mark.parametrize("moon_name", ["moonless", "told"])
@pytest.mark.parametrize("tolerance", [1e-6, 1e-2, 0.5])
def test_pruned_mass_is_within_its_bound_and_the_tolerance(
    fitted,  # noqa: F811
    moon_name,
    tolerance,
):
    """The posterior mass of the pruned lamps, measured on the unpruned
    scores relative to the best lamp's, is at most the bound
    `_score_pruned` reports, which is at most the tolerance; the
    survivors' log evidence and the misfit are the unpruned ones."""
    inv, y, _ = fitted
    moon = _moons(y)[moon_name]
    lk0, chi0 = _scored(inv, y, moon, None)
    lk1, chi1 = _scored(inv, y, moon, tolerance)
    np.testing.assert_allclose(chi1, chi0, rtol=RTOL)
    kept = np.isfinite(lk1)
    np.testing.assert_allclose(lk1[kept], lk0[kept], rtol=RTOL)
    best = lk0.max(axis=-1, keepdims=True)
    measured = np.sum(np.where(kept, 0.0, np.exp(lk0 - best)), axis=-1)
    # the bound, from the same pass (`_score` does not return it)
    noise = np.asarray(inv._predict_noise())
    cand, lps = inv.candidates(y.shape[0])
    a, q = inv.design
    c0 = cand[0]
    p = np.einsum("kabr,sr->ksab", a, c0)
    k, s, na, b = p.shape
    qf = np.einsum("abr,sr->sab", q, c0).reshape(s * na, b)
    _, _, bound = inv_mod._score_pruned(
        y, p.reshape(k, s * na, b), np.repeat(lps[0], na),
        inv.prior.log_prior, noise, tolerance, moon, qf,
    )  # fmt: skip
    assert np.all(measured <= bound * (1 + 1e-9) + 1e-300)
    assert np.all(bound <= tolerance)
    if tolerance == 0.5:  # the test can fail: lamps were pruned
        assert (~kept).any() and measured.max() > 0


@pytest.mark.parametrize("moon_name", ["moonless", "told"])
def test_pruned_prediction_is_the_unpruned_one_within_the_tolerance(
    fitted,  # noqa: F811
    moon_name,
):
    """Every output of `predict` (flag folds included) agrees: types and
    flags the same, probabilities within the tolerance, misfit and p-values
    exact, estimates and intervals within the tolerance times each metric's
    range over the prior."""
    inv, y, _ = fitted
    moon = _moons(y)[moon_name]
    tol = inv_mod.PRUNE_TOLERANCE
    r0 = inv.predict(y, None, moon)
    r1 = inv.predict(y, None, moon, prune=tol)
    assert r1.level1 == r0.level1 and r1.level2 == r0.level2
    np.testing.assert_array_equal(r1.unexplained, r0.unexplained)
    for name in ("level1_probabilities", "level2_probabilities", "cct_probability"):
        assert np.abs(getattr(r1, name) - getattr(r0, name)).max() <= tol, name
    np.testing.assert_allclose(r1.misfit, r0.misfit, rtol=RTOL)
    np.testing.assert_allclose(r1.known_type_p, r0.known_type_p, rtol=RTOL)
    spread = np.nanmax(r0.interval90, axis=(0, 2)) - np.nanmin(
        r0.interval90, axis=(0, 2)
    )
    np.testing.assert_array_equal(np.isnan(r1.estimate), np.isnan(r0.estimate))
    d_est = np.nan_to_num(np.abs(r1.estimate - r0.estimate))
    d_iv = np.nan_to_num(np.abs(r1.interval90 - r0.interval90))
    assert np.all(d_est <= tol * spread + 1e-9 * np.abs(np.nan_to_num(r0.estimate)))
    assert np.all(d_iv.max(axis=-1) <= tol * spread + 1e-9 * np.nanmax(spread))


@pytest.mark.parametrize("moon_name", ["moonless", "told"])
def test_pruned_float32_stays_within_the_float32_tolerance(
    fitted,  # noqa: F811
    moon_name,
):
    """Pruned float32 scoring against unpruned float64: within
    `FLOAT32_TOLERANCE` (pruning adds at most `PRUNE_TOLERANCE`, far
    below it), the same type calls and flags."""
    inv, y, _ = fitted
    moon = _moons(y)[moon_name]
    tol = inv_mod.FLOAT32_TOLERANCE
    r0 = inv.predict(y, None, moon)
    r1 = inv.predict(y, None, moon, dtype="float32", prune=inv_mod.PRUNE_TOLERANCE)
    assert r1.level1 == r0.level1 and r1.level2 == r0.level2
    np.testing.assert_array_equal(r1.unexplained, r0.unexplained)
    for name in ("level1_probabilities", "level2_probabilities", "cct_probability"):
        d = np.abs(getattr(r1, name) - getattr(r0, name))
        assert d.max() <= tol["type_probability"], name
    ok = np.isfinite(r0.estimate)
    np.testing.assert_array_equal(np.isfinite(r1.estimate), ok)
    np.testing.assert_allclose(
        r1.estimate[ok], r0.estimate[ok], rtol=tol["estimate_rel"]
    )
    ok = np.isfinite(r0.interval90)
    np.testing.assert_allclose(
        r1.interval90[ok], r0.interval90[ok], rtol=tol["interval_rel"]
    )


def test_a_fitted_moon_is_scored_unpruned(fitted):  # noqa: F811
    """With a Moon amplitude to fit the bound does not hold, so every lamp
    is scored: the same numbers as without pruning."""
    inv, y, moon = fitted  # NaN: fitted, on every third pixel
    lk0, chi0 = _scored(inv, y, moon, None)
    lk1, chi1 = _scored(inv, y, moon, 1e-6)
    np.testing.assert_array_equal(lk1, lk0)
    np.testing.assert_array_equal(chi1, chi0)


def test_the_margin_follows_the_tolerance():
    assert inv_mod.prune_margin(2968, 1e-6) == pytest.approx(21.81, abs=0.01)
    assert 2968 * np.exp(-inv_mod.prune_margin(2968, 1e-6)) == pytest.approx(1e-6)
    for bad in (0.0, 1.0, -1e-3):
        with pytest.raises(ValueError, match="prune tolerance must be in"):
            inv_mod.prune_margin(10, bad)


def test_posteriors_sum_to_one_when_pruned(fitted):  # noqa: F811
    inv, y, _ = fitted
    post, _ = inv.posterior(y, moon=np.zeros(len(y)), prune=0.5)
    np.testing.assert_allclose(post.sum(axis=1), 1.0, rtol=1e-12)
    assert (post == 0).any()
