"""The physics-based inversion: closed-form misfit against scipy's NNLS,
self-consistency on prior lamps, brightness invariance, physical bounds on any
input (hypothesis), the Sentinel-2 surface path, reject and calibration."""

import dataclasses

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings, strategies as st
from scipy.optimize import nnls

from bandopt import inversion as inv_mod
from bandopt.datasets import surfaces
from bandopt.estimate import METRICS, lamp_truth
from bandopt.sensor import BandSet


GRID = np.arange(380.0, 901.0)


def _weights(bands):
    import jax.numpy as jnp

    from bandopt.scene import band_weights

    resp = jnp.asarray(bands.response(jnp.asarray(GRID)))
    return np.asarray(band_weights(resp, jnp.asarray(GRID)))


def _bands(spec):
    c = np.array([a for a, _ in spec], float)
    f = np.array([b for _, b in spec], float)
    f = np.clip(np.minimum(f, 2 * np.minimum(c - 380, 900 - c) - 1), 15, None)
    return BandSet.from_physical(c, f, 6.0, name="t")


FIVE = _bands([(450, 60), (530, 60), (600, 50), (680, 60), (820, 80)])


@pytest.fixture(scope="module")
def lamps():
    return inv_mod.library_lamps(GRID, scored=True)


@pytest.fixture(scope="module")
def basis():
    return inv_mod.surface_basis(GRID)


def test_chi2_matches_scipy_nnls():
    rng = np.random.default_rng(1)
    for _ in range(50):
        b = rng.integers(2, 7)
        p, q, y = rng.random((3, b))
        y = y + rng.random() * p
        w = rng.random(b) + 0.1
        chi = float(inv_mod._chi2(y, w, p[None], q[None])[0])
        sw = np.sqrt(w)
        _, res = nnls(np.column_stack([p, q]) * sw[:, None], y * sw)
        assert chi == pytest.approx(res**2, rel=1e-9, abs=1e-12)
        chi1 = float(inv_mod._chi2(y, w, p[None], None)[0])
        _, res1 = nnls((p * sw)[:, None], y * sw)
        assert chi1 == pytest.approx(res1**2, rel=1e-9, abs=1e-12)


def _pixel(spectrum_per_lm, refl, lux=10.0, weights=None):
    w = _weights(FIVE) if weights is None else weights
    return w @ (lux * refl * spectrum_per_lm / np.pi)


def test_prior_lamp_is_recovered_and_brightness_free(lamps, basis):
    inv = inv_mod.build_inversion(
        lamps, _weights(FIVE), inv_mod.Conditions.clear(GRID), basis, sigma_rel=0.003
    )
    _, refl = surfaces.mean_reflectance(["asphalt"], GRID)
    refl = basis.reflectance(basis.coords(refl))[0]  # exactly in the basis
    picks = [lamps.level2.index(c) for c in ("hps", "led_cool", "mercury")]
    y = np.stack([_pixel(lamps.spectra[i], refl) for i in picks])
    res = inv.predict(y)
    res2 = inv.predict(y * 123.4)
    np.testing.assert_allclose(res.estimate, res2.estimate, rtol=1e-9)
    _, misfit = inv.posterior(y)
    for row, i in enumerate(picks):
        # the generating lamp fits exactly (asphalt is a candidate surface)
        assert misfit[row] < 1e-8
        assert res.level2[row] == lamps.level2[i]
        assert res.level1[row] == lamps.level1[i]
    truth, valid = lamp_truth(lamps.spectra[picks], GRID)
    ok = valid[:, 0]
    np.testing.assert_allclose(res.estimate[ok, 0], truth[ok, 0], rtol=0.15)


@settings(max_examples=12, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    centres=st.lists(st.floats(400, 880), min_size=1, max_size=6),
    fwhm=st.floats(15, 150),
    seed=st.integers(0, 2**16),
    sigma=st.sampled_from(inv_mod.SIGMA_REL_GRID),
)
def test_estimates_never_leave_physical_range(lamps, basis, centres, fwhm, seed, sigma):
    bands = _bands([(c, fwhm) for c in centres])
    inv = inv_mod.build_inversion(
        lamps, _weights(bands), inv_mod.Conditions.clear(GRID), basis, sigma_rel=sigma
    )
    inv = dataclasses.replace(inv, conformal=np.array([3.0, 3.0, 3.0]))
    rng = np.random.default_rng(seed)
    y = np.vstack(
        [
            rng.random((4, len(centres))) * 10.0 ** rng.uniform(-12, 3),
            np.zeros((1, len(centres))),
            np.eye(len(centres))[:1] * 1e-30,
        ]
    )
    res = inv.predict(y)
    for m, name in enumerate(METRICS):
        lo, hi = inv_mod.PHYSICAL_RANGE[name]
        e, iv = res.estimate[:, m], res.interval90[:, m]
        fin = np.isfinite(e)
        assert name == "CCT" or fin.all()
        assert np.all((e[fin] >= lo) & (e[fin] <= hi))
        assert np.all((iv[:, 0] >= lo - 1e-9) & (iv[:, 1] <= hi + 1e-9))
        assert np.all((iv[fin, 0] <= e[fin] + 1e-9) & (e[fin] <= iv[fin, 1] + 1e-9))
    np.testing.assert_allclose(res.level1_probabilities.sum(axis=1), 1.0)


def test_sentinel2_responses_and_surface_retrieval(basis):
    names, resp = inv_mod.sentinel2_response(GRID)
    assert names[:3] == ("B01", "B02", "B03") and "B09" not in names
    centroid = dict(zip(names, resp @ GRID / resp.sum(axis=1), strict=True))
    # ESA's S2A central wavelengths (`ESA2017`): B4 664.6, B8 832.8 nm
    assert centroid["B04"] == pytest.approx(664.6, abs=3)
    assert centroid["B08"] == pytest.approx(832.8, abs=5)
    _, grass = surfaces.mean_reflectance(["grass"], GRID)
    obs = inv_mod.observe_sentinel2(np.repeat(grass, 50, axis=0), GRID, seed=3)
    rec = basis.reflectance(inv_mod.surface_from_sentinel2(obs, basis))
    band = grass @ resp.T / resp.sum(axis=1)
    rec_band = rec @ resp.T / resp.sum(axis=1)
    # the retrieval is at least as close to the truth as the noisy observation
    assert np.mean(np.abs(rec_band - band)) < np.mean(np.abs(obs - band))
    # and the red edge of vegetation survives (B8 >> B4)
    assert np.all(rec_band[:, names.index("B08")] > 3 * rec_band[:, names.index("B04")])


def test_surface_basis_is_cached_per_grid_types_and_rank(basis):
    """The cached basis is the computed one, each call owns its arrays (a
    caller modifying one changes no later call's), and a different grid,
    set of types or rank is a different basis. Two types on a 5 nm grid:
    each uncached basis here is a small SVD."""
    from bandopt.inversion import _surfaces

    fields = ("wavelength_nm", "mean", "basis", "scale", "type_coords")
    types, grid = ("asphalt", "grass"), GRID[::5]
    fresh = _surfaces._computed_surface_basis(grid.copy(), types, 4)
    first = inv_mod.surface_basis(grid, types, 4)
    again = inv_mod.surface_basis(grid, types, 4)
    for f in fields:
        np.testing.assert_array_equal(getattr(first, f), getattr(fresh, f))
        np.testing.assert_array_equal(getattr(again, f), getattr(fresh, f))
        assert not np.shares_memory(getattr(again, f), getattr(first, f))
    assert again.types == fresh.types == types
    first.mean[:] = 0.0
    first.basis[:] = 0.0
    np.testing.assert_array_equal(
        inv_mod.surface_basis(grid, types, 4).mean, fresh.mean
    )
    np.testing.assert_array_equal(
        inv_mod.surface_basis(grid, types, 4).basis, fresh.basis
    )
    assert inv_mod.surface_basis(grid, types, 3).basis.shape == (3, grid.size)
    one = inv_mod.surface_basis(grid, ("asphalt",), 4)
    assert one.types == ("asphalt",) and one.type_coords.shape[0] == 1
    coarse = inv_mod.surface_basis(GRID[::10], types, 4)
    np.testing.assert_array_equal(coarse.wavelength_nm, GRID[::10])
    assert coarse.mean.shape == coarse.basis.shape[1:] == (GRID[::10].size,)
    # the default basis (the fixture's): equal, and not the same arrays
    default = inv_mod.surface_basis(GRID)
    for f in fields:
        np.testing.assert_array_equal(getattr(default, f), getattr(basis, f))
        assert not np.shares_memory(getattr(default, f), getattr(basis, f))


def test_surface_modes_validate_input(basis):
    with pytest.raises(ValueError, match="surface mode"):
        inv_mod.surface_candidates(basis, "psychic", 1)
    with pytest.raises(ValueError, match="one surface type per pixel"):
        inv_mod.surface_candidates(basis, "class", 2, ["grass"])
    with pytest.raises(ValueError, match="basis coefficients"):
        inv_mod.surface_candidates(basis, "measured", 2, np.zeros((2, 1)))
    c, lp = inv_mod.surface_candidates(basis, "class", 2, ["grass", "asphalt"])
    assert c.shape[:2] == lp.shape and np.allclose(c[..., 0], 1.0)
    np.testing.assert_allclose(np.exp(lp).sum(axis=1), 1.0)


def test_fit_calibrates_and_flags_non_lamp_pixels():
    from bandopt.search import get_context

    ctx = get_context("tiny", None, 0, "none")
    recs = inv_mod.cross_validate(ctx, FIVE, estimators=("inversion",), folds=[0])
    assert recs and all(r.out_of_range == 0 for r in recs)
    cover = [r.LER_covered for r in recs]
    assert np.mean(cover) >= 0.6
    # the typed record and its JSON form carry the same fields both ways
    for r in recs:
        d = r.to_dict()
        assert inv_mod.LampScore.from_dict(d) == r and r.error("LER") == d["LER"]
        assert set(METRICS) <= set(d) and None not in (r.rows, r.fold)
        assert r.as_record(partition=2)["partition"] == 2
    with pytest.raises(ValueError, match="unknown fields"):
        inv_mod.LampScore.from_dict({**recs[0].to_dict(), "partition": 0})
    with pytest.raises(ValueError, match="Unknown metric"):
        recs[0].error("lux")
    lamps, always, cond, _ = inv_mod.context_setup(ctx)
    s = ctx.splits[0]
    w = _weights(FIVE)
    fit = inv_mod.fit_inversion(
        ctx.radiance(FIVE),
        ctx.table.lamp_of,
        lamps,
        s.train,
        s.inner,
        w,
        cond,
        always=always,
    )
    assert np.isfinite(fit.threshold) and np.all(fit.conformal >= 0)
    assert fit.sigma_rel in inv_mod.SIGMA_REL_GRID
    # two narrow lines at 450 and 820 nm: no lamp of the library looks like it
    weird = np.exp(-0.5 * ((GRID - 450) / 3) ** 2) + np.exp(
        -0.5 * ((GRID - 820) / 3) ** 2
    )
    _, refl = surfaces.mean_reflectance(["asphalt"], GRID)
    res = fit.predict((w @ (refl[0] * weird))[None])
    assert res.unexplained[0] and res.level1[0] is None
    row = res.row(0)
    assert (
        row["estimate"]["LER"] is None and "unexplained" in row["null_reasons"]["LER"]
    )


def test_cross_validate_scores_training_lamps_when_asked():
    """`scored="train"` scores the outer fold's training lamps (in the prior:
    the in-library bound), says so in every record, and does better on them
    than on the held-out lamps; anything else is refused."""
    from bandopt.search import get_context

    ctx = get_context("tiny", None, 0, "none")
    lamps, *_ = inv_mod.context_setup(ctx)
    s = ctx.splits[0]
    kw = dict(estimators=("inversion",), folds=[0])
    held = inv_mod.cross_validate(ctx, FIVE, **kw)
    own = inv_mod.cross_validate(ctx, FIVE, scored="train", **kw)
    assert sorted(r.lamp for r in own) == sorted(lamps.ids[i] for i in s.train)
    assert sorted(r.lamp for r in held) == sorted(lamps.ids[i] for i in s.test)
    assert all(r.scored == "train" for r in own)
    assert all(r.scored is None for r in held)
    assert all(r.out_of_range == 0 for r in own)
    err = [np.mean([r.LER for r in x if r.LER is not None]) for x in (own, held)]
    # how much better depends on the band error the inner folds choose: at
    # σ_rel 0.003 a prior lamp is pinned (~1/20 of the held-out error), at
    # 0.1 (what the tiny context chooses now) it is ~1/4
    assert err[0] < 0.5 * err[1]
    with pytest.raises(ValueError, match="scored"):
        inv_mod.cross_validate(ctx, FIVE, scored="inner", **kw)


def test_smaller_library_keeps_a_share_of_each_class():
    """`_smaller_library`: about `fraction` of each class's training lamps (at
    least one), the inner folds restricted to them, the test lamps unchanged,
    the same draw for the same seed and fold, another for another fold."""
    from bandopt.folds import NestedSplit

    level2 = ["a"] * 8 + ["b"] * 4 + ["c"]
    classes = [*level2, "a", "b"]  # the two test lamps' too
    train = np.arange(13)
    inner = ((np.arange(0, 13, 2), np.arange(1, 13, 2)),
             (np.arange(1, 13, 2), np.arange(0, 13, 2)))  # fmt: skip
    split = NestedSplit(0, train, np.array([13, 14]), inner)
    small = inv_mod._smaller_library(split, classes, 0.5, 0, 0)
    kept = np.asarray(level2, object)[small.train]
    assert (kept == "a").sum() == 4 and (kept == "b").sum() == 2
    assert (kept == "c").sum() == 1  # at least one
    assert np.array_equal(small.test, split.test)
    for tr, va in small.inner:
        assert set(tr) | set(va) <= set(small.train)
    again = inv_mod._smaller_library(split, classes, 0.5, 0, 0)
    assert np.array_equal(again.train, small.train)
    other = [
        inv_mod._smaller_library(split, classes, 0.5, 0, f).train for f in range(1, 6)
    ]
    assert any(not np.array_equal(o, small.train) for o in other)


def test_cross_validate_trains_on_a_smaller_library_when_asked():
    from bandopt.search import get_context

    ctx = get_context("tiny", None, 0, "none")
    kw = dict(estimators=("inversion",), folds=[0])
    full = inv_mod.cross_validate(ctx, FIVE, **kw)
    half = inv_mod.cross_validate(ctx, FIVE, train_fraction=0.5, **kw)
    assert [r.lamp for r in half] == [r.lamp for r in full]
    n = len(ctx.splits[0].train)
    assert all(r.train_fraction == 0.5 and r.train_lamps < n for r in half)
    assert all(r.train_fraction is None for r in full)
    with pytest.raises(ValueError, match="train_fraction"):
        inv_mod.cross_validate(ctx, FIVE, train_fraction=0.0, **kw)


def test_summaries_are_class_balanced_and_paired_by_partition():
    recs = []
    for p, (a, b) in enumerate([(1.0, 3.0), (2.0, 6.0)]):
        for bs, scale in (("recommended", 1.0), ("sdgsat-1", 2.0)):
            # class x has 3 lamps with error a, class y one lamp with error b
            for lamp, (c, e) in enumerate([("x", a)] * 3 + [("y", b)]):
                recs.append(
                    {
                        "band_set": bs,
                        "estimator": "inversion",
                        "surface": "unknown",
                        "partition": p,
                        "lamp": f"l{lamp}",
                        "level2": c,
                        "out_of_range": 0,
                        "LER": scale * e,
                        "G": None,
                    }
                )
    rows = inv_mod.summarise(recs)
    rec = next(r for r in rows if r["band_set"] == "recommended")
    # class-balanced: (a + b)/2 per partition -> 2 and 4
    assert rec["LER_per_partition"] == [2.0, 4.0]
    assert rec["LER"] == 3.0 and rec["LER_sd"] == pytest.approx(np.sqrt(2.0))
    assert "G" not in rec
    (pd,) = inv_mod.paired_differences(rows, "recommended", "sdgsat-1")
    assert pd["LER_diff"] == 3.0 and pd["LER_diff_sd"] == pytest.approx(np.sqrt(2.0))
    assert pd["LER_relative"] == pytest.approx(1.0)


def test_estimator_differences_are_paired_within_a_band_set():
    """`estimator_differences`: variant minus base of the same band set and
    surface, paired by partition; pairs without a base are skipped."""
    recs = []
    for p, err in enumerate([1.0, 2.0, 4.0]):
        for est, extra in (("ridge", 0.0), ("ridge+models", 0.5 + p)):
            for bs, scale in (("recommended", 1.0), ("sdgsat-1", 3.0)):
                recs.append(
                    {
                        "band_set": bs,
                        "estimator": est,
                        "surface": "unknown",
                        "partition": p,
                        "lamp": "l0",
                        "level2": "x",
                        "out_of_range": 0,
                        "LER": scale * err + extra,
                    }
                )
    recs.append(dict(recs[0], estimator="kernel+models"))  # no kernel base
    rows = inv_mod.summarise(recs)
    out = inv_mod.estimator_differences(rows)
    assert {(r["band_set"], r["estimator"], r["vs"]) for r in out} == {
        ("recommended", "ridge+models", "ridge"),
        ("sdgsat-1", "ridge+models", "ridge"),
    }
    for r in out:
        # differences 0.5, 1.5, 2.5 whatever the band set's own error level
        assert r["LER_diff"] == pytest.approx(1.5)
        assert r["LER_diff_sd"] == pytest.approx(1.0)
        assert "G_diff" not in r


NOISE = np.array([[0.01, 1e-3], [0.1, 0.01]])
"""Band-error models (σ_rel, floor) the scoring tests use."""


def test_shared_candidate_fast_path_matches_per_pixel_path(lamps, basis):
    inv = inv_mod.build_inversion(
        lamps.take(range(40)), _weights(FIVE), inv_mod.Conditions.clear(GRID), basis
    )
    rng = np.random.default_rng(0)
    y = rng.random((5, 5)) + 0.1
    cand, lps = inv.candidates(5)
    a, q = inv.design
    fast = inv_mod._score(y, cand, lps, a, q, inv.prior.log_prior, NOISE)
    cand2 = cand.copy()
    cand2[0, 0, 1] += 1e-9  # pixel 0 differs: the general per-pixel path runs
    slow = inv_mod._score(y, cand2, lps, a, q, inv.prior.log_prior, NOISE)
    np.testing.assert_allclose(fast[0][1:], slow[0][1:], rtol=1e-10, atol=1e-10)
    np.testing.assert_allclose(fast[1][1:], slow[1][1:], rtol=1e-10, atol=1e-12)
    with pytest.raises(ValueError, match=r"noise: expected \(S, 2\)"):
        inv_mod._score(y, cand, lps, a, q, inv.prior.log_prior, [0.01, 0.1])


@pytest.mark.parametrize("hood", ["lit_street_dark_district", "uniform"])
def test_design_matches_the_scene_in_its_neighbourhood(hood):
    """The inversion's lamp x surface term is the scene's `lamp_surface` band
    radiance in the scenes' neighbourhood (`T_dir + k T_dif` for a lit street
    in a dark district, not the total `T_up`), and its Moon term uses `T_up`."""
    import jax.numpy as jnp

    from bandopt.scene import band_terms, band_weights, build_scenarios

    s = build_scenarios(
        lamps=("nist_traditional_hps", "cie_led_b3"),
        surfaces=("asphalt",),
        atmospheres=(("tropical", "urban", 5.0),),
        moons=("full",),
        classes=("P4",),
        neighbourhood=hood,
    )
    f = s.factors
    wl = np.asarray(f.wavelength_nm)
    w = np.asarray(
        band_weights(jnp.asarray(FIVE.response(jnp.asarray(wl))), jnp.asarray(wl))
    )
    cond = inv_mod.Conditions.from_scenarios(s)
    assert (cond.t_lamp is None) == (hood == "uniform")
    refl = np.asarray(f.reflectance)[0]
    one = inv_mod.SurfaceBasis(
        wl, refl, np.zeros((1, wl.size)), np.ones(1), ("asphalt",), np.zeros((1, 1))
    )
    a, q = inv_mod._design(np.asarray(f.lamp), w, cond, one)
    terms = band_terms(f, jnp.asarray(w))
    np.testing.assert_allclose(
        a[:, 0, :, 0], np.asarray(terms.lamp_surface)[:, 0, 0], rtol=1e-10
    )
    np.testing.assert_allclose(
        q[0, :, 0] - np.asarray(terms.path)[0, 0],
        np.asarray(terms.moon)[0, 0, 0],
        rtol=1e-10,
    )
    if hood != "uniform":  # the lamp term is below the total-transmittance one
        assert np.all(cond.t_lamp < cond.t_up)


@pytest.mark.parametrize("moon", [True, False])
def test_shared_candidate_path_matches_the_per_pixel_path(moon):
    """The GEMM form of the shared-surface path gives the per-pixel
    broadcast path's log evidence and χ² (an independent implementation)."""
    import jax.numpy as jnp

    rng = np.random.default_rng(3)
    k, r, a, b, n, s = 37, 4, 2, 5, 300, 6
    amat = rng.random((k, a, b, r)) * np.array([1.0, 0.1, 0.1, 0.1])
    q = rng.random((a, b, r)) * 0.3 if moon else None
    cand = np.concatenate([np.ones((s, 1)), rng.normal(0, 0.3, (s, r - 1))], 1)
    log_ps = np.log(rng.dirichlet(np.ones(s)))
    log_pk = np.log(rng.dirichlet(np.ones(k)))
    y = rng.random((n, b)) + 0.1
    y[:5] = 0.0  # dark pixels stay finite
    sig = np.array([[0.01, 1e-3], [0.05, 0.01], [0.2, 1e-3]])  # (σ_rel, floor)
    lk, chi = inv_mod._score(
        y,
        np.repeat(cand[None], n, 0),
        np.repeat(log_ps[None], n, 0),
        amat,
        q,
        log_pk,
        sig,
    )
    ref_lk, ref_chi = inv_mod._score_chunk(
        jnp.asarray(y),
        jnp.asarray(np.repeat(cand[None], n, 0)),
        jnp.asarray(np.repeat(log_ps[None], n, 0)),
        jnp.asarray(amat),
        None if q is None else jnp.asarray(q),
        jnp.asarray(log_pk),
        jnp.asarray(sig),
    )
    assert np.all(np.isfinite(lk)) and np.all(np.isfinite(chi))
    np.testing.assert_allclose(lk, np.asarray(ref_lk), rtol=1e-9, atol=1e-9)
    np.testing.assert_allclose(chi, np.asarray(ref_chi), rtol=1e-9, atol=1e-9)


@pytest.mark.parametrize("scale", [1.0, 1e4])
def test_two_pass_log_sum_is_jaxs(scale):
    """The scoring kernels' `_log_sum_chi` gives jax's `logsumexp` of
    `-χ²/2 + lps` and the least `χ²` per row, whatever the scale of `χ²`
    (no underflow to -inf at 1e4, where every plain `exp(-χ²/2)` is 0), with
    candidate priors that are not uniform."""
    import jax.numpy as jnp
    from jax.scipy.special import logsumexp

    rng = np.random.default_rng(5)
    chi = rng.random((4, 7, 26)) * 60 * scale
    chi[0, 0, 3] = 0.0
    lps = np.log(rng.dirichlet(np.ones(26)))[None, None, :]
    lk, cmin = inv_mod._log_sum_chi(jnp.asarray(chi), jnp.asarray(lps))
    ref = logsumexp(jnp.asarray(-0.5 * chi + lps), axis=2)
    np.testing.assert_allclose(np.asarray(lk), np.asarray(ref), rtol=1e-12)
    np.testing.assert_allclose(np.asarray(cmin), chi.min(axis=2), rtol=0)
    assert np.all(np.isfinite(np.asarray(lk)))


def test_band_weights_are_the_forward_models():
    """The inversion's band weights come from `forward.band_weights_on`, the
    weights of every forward band radiance: a flat spectrum reads 1 in every
    band, and a forward band radiance equals the weights' contraction."""
    import jax.numpy as jnp

    from bandopt import forward

    wl = np.arange(380.0, 901.0)
    w = inv_mod.band_weights_on(FIVE, wl)
    np.testing.assert_array_equal(w, np.asarray(forward.band_weights_on(FIVE, wl)))
    np.testing.assert_allclose(w.sum(axis=1), 1.0, rtol=1e-12)
    spectra = np.exp(-0.5 * ((wl - np.array([[500.0], [650.0]])) / 40.0) ** 2)
    grid = jnp.asarray(wl)
    resp = FIVE.response(grid)
    rad = forward.radiance_from_response(jnp.asarray(spectra), grid, resp)
    np.testing.assert_allclose(np.asarray(rad), spectra @ w.T, rtol=1e-12)
