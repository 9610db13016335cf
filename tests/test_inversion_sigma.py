"""How the inversion chooses its band-error scale `σ_rel` on inner folds:
by held-out metric error (default) or by held-out log evidence
(`sigma_rule="evidence"`, `inversion.log_evidence`)."""

import numpy as np
import pytest

from bandopt import inversion as inv_mod
from bandopt.datasets import surfaces
from bandopt.estimate import METRICS
from bandopt.folds import stratified_lamp_folds
from tests._bands import FIVE, GRID


SIGMAS = (0.003, 0.01, 0.03, 0.1, 0.3)


@pytest.fixture(scope="module")
def case():
    """4 lamps of each of four classes, pixels on asphalt without atmosphere;
    the asphalt-class surface is known to the inversion (mode 'class')."""
    everything = inv_mod.library_lamps(GRID, scored=True)
    pick = []
    for c in ("hps", "led_warm", "led_cool", "fluorescent_linear"):
        pick += [i for i, x in enumerate(everything.level2) if x == c][:4]
    lamps = everything.take(pick)
    _, refl = surfaces.mean_reflectance(["asphalt"], GRID)
    w = inv_mod.band_weights_on(FIVE, GRID)
    rows, row_lamp = [], []
    for i, s in enumerate(lamps.spectra):
        for lux in (3.0, 20.0):
            rows.append(w @ (lux * refl[0] * s / np.pi))
            row_lamp.append(i)
    return lamps, np.asarray(row_lamp), np.asarray(rows), w


def _fit_setup(case, rad, sigma_grid=SIGMAS):
    """`fit_inversion`'s positional arguments for pixels `rad` of the case
    (every lamp trains; 2 class-stratified inner folds) and its keywords
    (surface class asphalt known, `sigma_grid`)."""
    lamps, row_lamp, _, w = case
    l2 = np.asarray(lamps.level2, dtype=object)
    train = np.arange(len(lamps.ids))
    folds = stratified_lamp_folds(l2, 2, 0)
    inner = [(np.setdiff1d(train, v), np.sort(v)) for v in folds]
    kw = dict(
        basis=inv_mod.surface_basis(GRID),
        surface_mode="class",
        row_surface=["asphalt"] * len(rad),
        sigma_grid=sigma_grid,
    )
    args = (rad, row_lamp, lamps, train, inner, w, inv_mod.Conditions.clear(GRID))
    return args, kw


def test_evidence_peaks_at_the_band_error_actually_present(case):
    """Pixels rendered from a prior lamp: with no band error the evidence is
    highest at the smallest σ_rel; with ~10 % multiplicative band errors it
    peaks near 0.1. (Without the σ-dependent Gaussian normaliser it would
    always grow with σ; with a wrong sign, always fall.)"""
    lamps, _, rad, w = case
    inv = inv_mod.build_inversion(
        lamps, w, inv_mod.Conditions.clear(GRID), inv_mod.surface_basis(GRID), "class"
    )
    surf = ["asphalt"] * len(rad)
    post, red, lev = inv.posterior(rad, surf, sigmas=SIGMAS, evidence=True)
    post0, red0 = inv.posterior(rad, surf, sigmas=SIGMAS)
    np.testing.assert_array_equal(post, post0)
    np.testing.assert_array_equal(red, red0)
    assert lev.shape == (len(rad), len(SIGMAS)) and np.all(np.isfinite(lev))
    # the surface basis reproduces asphalt only approximately: compare the
    # clean pixels' evidence peak with the perturbed pixels', per pixel
    rng = np.random.default_rng(0)
    noisy = rad * np.exp(rng.normal(0.0, 0.1, rad.shape))
    _, _, lev_n = inv.posterior(noisy, surf, sigmas=SIGMAS, evidence=True)
    clean_peak = np.asarray(SIGMAS)[np.argmax(lev, axis=1)]
    noisy_peak = np.asarray(SIGMAS)[np.argmax(lev_n, axis=1)]
    assert np.median(clean_peak) <= 0.03
    assert np.median(noisy_peak) in (0.03, 0.1, 0.3)
    assert np.mean(noisy_peak > clean_peak) > 0.8
    # the single-σ call returns the same numbers as the grid's column
    _, _, one = inv_mod.build_inversion(
        lamps, w, inv_mod.Conditions.clear(GRID), inv_mod.surface_basis(GRID),
        "class", sigma_rel=0.1,
    ).posterior(noisy, surf, evidence=True)  # fmt: skip
    np.testing.assert_allclose(one, lev_n[:, SIGMAS.index(0.1)], rtol=1e-10)


def test_log_evidence_normaliser_by_hand():
    """`log_evidence` adds -Σ_b log(σ|y_b|/mean|y| + floor) - b/2 log 2π."""
    y = np.array([[1.0, 2.0, 3.0]])
    got = inv_mod.log_evidence(np.array([[-1.5, -0.5]]), y, [0.1, 0.2])
    floored = inv_mod.log_evidence(np.array([[-1.5, -0.5]]), y, [0.1, 0.2], [0.05, 0.3])
    yn = y / 2.0
    for j, s in enumerate((0.1, 0.2)):
        sd = s * yn + inv_mod.SIGMA_FLOOR
        want = [-1.5, -0.5][j] - np.log(sd).sum() - 1.5 * np.log(2 * np.pi)
        assert got[0, j] == pytest.approx(want, rel=1e-12)
        sd = s * yn + [0.05, 0.3][j]
        want = [-1.5, -0.5][j] - np.log(sd).sum() - 1.5 * np.log(2 * np.pi)
        assert floored[0, j] == pytest.approx(want, rel=1e-12)


def test_fit_chooses_sigma_by_the_rule_it_is_given(case):
    args, kw = _fit_setup(case, case[2])
    by_err = inv_mod.fit_inversion(*args, **kw)
    by_ev = inv_mod.fit_inversion(*args, sigma_rule="evidence", **kw)
    d_err, d_ev = by_err.diagnostics, by_ev.diagnostics
    assert d_err["sigma_rule"] == "error" and d_ev["sigma_rule"] == "evidence"
    assert d_err["inner_log_evidence"] == d_ev["inner_log_evidence"]
    ev = {float(k): v for k, v in d_ev["inner_log_evidence"].items()}
    err = {float(k): v for k, v in d_err["inner_scores"].items()}
    assert by_ev.sigma_rel == max(ev, key=ev.get)
    assert by_err.sigma_rel == min(err, key=err.get)
    with pytest.raises(ValueError, match="sigma_rule 'best'"):
        inv_mod.fit_inversion(*args, sigma_rule="best", **kw)


def test_each_metric_comes_from_the_posterior_at_its_own_sigma(case):
    """`metric_sigma` set: metric m's estimate is the one-σ inversion's at
    σ_m, while types, misfit and flag stay those at `sigma_rel`."""
    import dataclasses

    lamps, _, rad, w = case
    one = inv_mod.build_inversion(
        lamps, w, inv_mod.Conditions.clear(GRID), inv_mod.surface_basis(GRID),
        "class", sigma_rel=0.03,
    )  # fmt: skip
    surf = ["asphalt"] * len(rad)
    rng = np.random.default_rng(1)
    noisy = rad * np.exp(rng.normal(0.0, 0.05, rad.shape))
    per = dataclasses.replace(
        one, metric_sigma=(0.003, 0.3, 0.1), metric_floor=(0.03, 0.001, 0.001)
    )
    assert per.metric_sigmas == (0.003, 0.3, 0.1)
    assert per.metric_noise == ((0.003, 0.03), (0.3, 0.001), (0.1, 0.001))
    assert one.metric_sigmas == (0.03, 0.03, 0.03)
    assert one.metric_noise == ((0.03, inv_mod.SIGMA_FLOOR),) * 3
    got = per.predict(noisy, surf)
    base = one.predict(noisy, surf)
    for m, (s, f) in enumerate(per.metric_noise):
        at_s = dataclasses.replace(one, sigma_rel=s, sigma_floor=f).predict(noisy, surf)
        np.testing.assert_allclose(got.estimate[:, m], at_s.estimate[:, m], rtol=1e-12)
        np.testing.assert_allclose(
            got.interval90[:, m], at_s.interval90[:, m], rtol=1e-12
        )
    # the estimates do differ from the one-σ ones (else the test shows nothing)
    assert np.max(np.abs(got.estimate[:, 0] - base.estimate[:, 0])) > 0.1
    np.testing.assert_allclose(got.misfit, base.misfit, rtol=1e-9)
    assert got.level1 == base.level1 and got.level2 == base.level2
    np.testing.assert_allclose(
        got.level1_probabilities, base.level1_probabilities, rtol=1e-9, atol=1e-12
    )


def test_per_metric_rule_picks_each_metrics_best_sigma_on_inner_folds(case):
    rad = case[2]
    rng = np.random.default_rng(2)
    noisy = rad * np.exp(rng.normal(0.0, 0.05, rad.shape))
    args, kw = _fit_setup(case, noisy)
    by_err = inv_mod.fit_inversion(*args, **kw)
    per = inv_mod.fit_inversion(*args, sigma_rule="per-metric", **kw)
    d = per.diagnostics
    pm = d["inner_scores_per_metric"]
    for s in SIGMAS:  # the joint score is the sum of the metrics' scores
        assert sum(pm[str(s)].values()) == pytest.approx(d["inner_scores"][str(s)])
    want = tuple(min(SIGMAS, key=lambda s: pm[str(s)][m]) for m in METRICS)
    assert per.metric_sigma == want
    assert d["metric_sigma"] == dict(zip(METRICS, want, strict=True))
    # types, flag threshold and σ_rel are the one-σ rule's
    assert per.sigma_rel == by_err.sigma_rel
    assert per.threshold == by_err.threshold
    assert by_err.metric_sigma == ()
    for m, s in enumerate(want):  # a metric at the joint σ keeps its factor
        if s == by_err.sigma_rel:
            assert per.conformal[m] == pytest.approx(by_err.conformal[m])
    for rule in ("error", "per-metric"):  # with one candidate both agree
        a = inv_mod.fit_inversion(*args, **{**kw, "sigma_grid": (0.03,)})
        b = inv_mod.fit_inversion(
            *args, **{**kw, "sigma_grid": (0.03,)}, sigma_rule=rule
        )
        np.testing.assert_allclose(a.conformal, b.conformal, rtol=1e-12)


def test_floor_grid_chooses_the_band_error_floor_with_sigma(case):
    """`floor_grid`: every (σ_rel, floor) pair is scored on the inner folds;
    the default (one floor, `SIGMA_FLOOR`) is the fit as before, and a floor
    far above σ_rel |y| weighs the bands uniformly (the misfit is then plain
    least squares over floor², tested by hand)."""
    lamps, _, rad, w = case
    noisy = rad * np.exp(np.random.default_rng(4).normal(0.0, 0.05, rad.shape))
    args, kw = _fit_setup(case, noisy, sigma_grid=(0.01, 0.1))
    default = inv_mod.fit_inversion(*args, **kw)
    same = inv_mod.fit_inversion(*args, floor_grid=(inv_mod.SIGMA_FLOOR,), **kw)
    assert default.diagnostics["inner_scores"] == same.diagnostics["inner_scores"]
    assert set(default.diagnostics["inner_scores"]) == {"0.01", "0.1"}
    assert default.sigma_floor == inv_mod.SIGMA_FLOOR
    fl = inv_mod.fit_inversion(*args, floor_grid=(0.001, 0.5), **kw)
    d = fl.diagnostics
    assert set(d["inner_scores"]) == {"0.01/0.001", "0.1/0.001", "0.01/0.5", "0.1/0.5"}
    # the floor-0.001 candidates are the default fit's, scored the same way
    for s in ("0.01", "0.1"):
        assert d["inner_scores"][f"{s}/0.001"] == pytest.approx(
            default.diagnostics["inner_scores"][s], rel=1e-9
        )
    best = min(d["inner_scores"], key=d["inner_scores"].get)
    assert f"{fl.sigma_rel:g}/{fl.sigma_floor:g}" == best
    assert d["sigma_floor"] == fl.sigma_floor
    with pytest.raises(ValueError, match="floor_grid"):
        inv_mod.fit_inversion(*args, floor_grid=(0.0,), **kw)
    with pytest.raises(ValueError, match="sigma_floor must be > 0"):
        inv_mod.build_inversion(
            lamps, w, inv_mod.Conditions.clear(GRID), inv_mod.surface_basis(GRID),
            sigma_floor=0.0,
        )  # fmt: skip
    # a floor of 1e3 (σ_rel |y| ~ 1e-2): uniform weights, χ² = RSS / floor²
    one = inv_mod.build_inversion(
        lamps, w, inv_mod.Conditions.clear(GRID), inv_mod.surface_basis(GRID),
        "class", sigma_rel=0.01, sigma_floor=1e3,
    )  # fmt: skip
    cand, lps = one.candidates(1, ["asphalt"])
    a, _ = one.design
    y = noisy[:1]
    yn = y[0] / np.mean(np.abs(y[0]))
    p = np.einsum("kabr,sr->ksab", a, cand[0]).reshape(-1, yn.size)  # candidates
    alpha = np.maximum(p @ yn, 0) / np.sum(p * p, axis=1)
    rss = np.sum((yn[None] - alpha[:, None] * p) ** 2, axis=1)
    _, chi = inv_mod._score(y, cand, lps, a, None, np.zeros(a.shape[0]), [[0.01, 1e3]])
    # uniform weights: the best misfit is the least RSS over floor², within
    # the σ_rel |y| / floor ~ 1e-5 the floor leaves of the relative term
    assert chi[0, 0] == pytest.approx(rss.min() / 1e6, rel=1e-4)
