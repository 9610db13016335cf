"""Reliability, ECE and temperature scaling (`bandopt.calibration`)."""

import numpy as np
import pytest

from bandopt.calibration import (
    expected_calibration_error,
    fit_temperature,
    reliability_curve,
    temper,
)


def test_ece_zero_when_confidence_equals_accuracy():
    # 10 rows at 0.7 of which 7 are right, 4 at 0.95 all right
    conf = np.r_[np.full(10, 0.7), np.full(4, 0.95)]
    right = np.r_[np.arange(10) < 7, np.ones(4, bool)]
    right[-1] = True
    ece = expected_calibration_error(conf, right)
    # bin 0.6-0.7: |0.7 - 0.7| = 0; bin 0.9-1: |1 - 0.95| * 4/14
    assert ece == pytest.approx(0.05 * 4 / 14)


def test_ece_of_overconfident_wrong_answers():
    conf = np.full(20, 0.99)
    right = np.arange(20) < 15  # 0.75 right
    assert expected_calibration_error(conf, right) == pytest.approx(0.24)


def test_reliability_weights_and_empty_bins():
    edges, c, a, share = reliability_curve([0.05, 0.95], [False, True], [1.0, 3.0])
    assert edges.size == 11 and share.sum() == pytest.approx(1.0)
    assert share[0] == pytest.approx(0.25) and share[-1] == pytest.approx(0.75)
    assert np.isnan(c[3]) and a[-1] == 1.0


def test_temper_keeps_order_and_softens():
    p = np.array([[0.9, 0.09, 0.01], [0.2, 0.5, 0.3]])
    soft = temper(p, 4.0)
    assert np.allclose(soft.sum(axis=1), 1.0)
    assert np.array_equal(soft.argmax(axis=1), p.argmax(axis=1))
    assert soft[0, 0] < p[0, 0]
    assert np.allclose(temper(p, 1.0), p)
    # a class with probability 0 (the prior lacks it) stays at 0
    assert temper(np.array([[0.0, 1.0]]), 10.0)[0, 0] == 0.0


def test_fit_temperature_recovers_a_known_temperature():
    # labels drawn from the tempered probabilities of a sharp classifier: the
    # Brier score is proper, so the fitted temperature undoes the sharpening
    rng = np.random.default_rng(3)
    logits = rng.normal(size=(4000, 4)) * 2.0
    true_p = np.exp(logits) / np.exp(logits).sum(1, keepdims=True)
    labels = np.array([rng.choice(4, p=q) for q in true_p])
    sharp = temper(true_p, 1 / 3)  # overconfident by T = 3
    fit = fit_temperature(sharp, labels)
    assert fit.value == pytest.approx(3.0, rel=0.1)
    assert fit.brier_after < fit.brier_before
    assert fit.ece_after < fit.ece_before and fit.ece_after < 0.03
    assert not fit.at_bound


def test_fit_temperature_counts_missing_classes_as_wrong():
    p = np.array([[0.99, 0.01]] * 50)
    y = np.r_[np.zeros(25, int), -np.ones(25, int)]  # half: a class it lacks
    fit = fit_temperature(p, y)
    # softened: it was wrong half the time at 0.99
    assert fit.value > 1.0 and fit.ece_after < fit.ece_before


def test_brier_score_values():
    from bandopt.calibration import brier_score

    assert brier_score([[1.0, 0.0]], [0]) == 0.0
    assert brier_score([[0.5, 0.5]], [0]) == pytest.approx(0.5)
    assert brier_score([[0.5, 0.5]], [-1]) == pytest.approx(1.5)


@pytest.mark.parametrize(
    ("p", "y", "msg"),
    [
        (np.ones((2, 2)) / 2, np.array([0, 2]), "labels"),
        (np.array([[np.nan, 1.0]]), np.array([0]), "probabilities"),
        (np.ones((2, 2)) / 2, np.array([0]), "shapes"),
    ],
)
def test_fit_temperature_refuses_bad_input(p, y, msg):
    with pytest.raises(ValueError, match=msg):
        fit_temperature(p, y)


def test_rounding_above_one_is_clipped_not_refused():
    assert expected_calibration_error([1.0 + 1e-12], [True]) == 0.0
    with pytest.raises(ValueError, match="confidence"):
        expected_calibration_error([1.01], [True])


def test_misfit_temperature_softens_badly_fitted_rows():
    """Rows whose misfit is large are right less often: the fitted slope is
    positive, and per-row temperatures calibrate both kinds where one
    temperature cannot."""
    rng = np.random.default_rng(5)
    n = 3000
    p = np.tile([0.97, 0.02, 0.01], (n, 1))
    misfit = np.r_[np.full(n // 2, 0.3), np.full(n // 2, 5.0)]
    acc = np.where(misfit < 1, 0.95, 0.5)
    labels = np.where(rng.random(n) < acc, 0, rng.integers(1, 3, n))
    one = fit_temperature(p, labels)
    per_row = fit_temperature(p, labels, misfit=misfit)
    assert one.slope == 0.0 and per_row.slope > 0.3
    assert per_row.brier_after < one.brier_after
    t = per_row.at(misfit)
    assert t[-1] > t[0]
    conf = temper(p, t).max(axis=1)
    right = labels == 0
    for part in (misfit < 1, misfit > 1):
        assert expected_calibration_error(conf[part], right[part]) < 0.05
    with pytest.raises(ValueError, match="misfit"):
        fit_temperature(p, labels, misfit=-misfit)


def test_temper_takes_one_temperature_per_row():
    p = np.array([[0.9, 0.1], [0.9, 0.1]])
    out = temper(p, np.array([1.0, 100.0]))
    assert out[0, 0] == pytest.approx(0.9) and out[1, 0] < 0.52
