"""The inversion told the Moon's brightness (known from the acquisition's time
and place) instead of fitting it: `Inversion.posterior(moon=...)`,
`fit_inversion(row_moon=...)`, `context_moon`."""

import dataclasses

import jax.numpy as jnp
import numpy as np
import pytest

from bandopt import inversion as inv_mod
from bandopt.forward import dense_spectra
from bandopt.scene import build_scenarios
from tests._bands import FIVE, GRID
from tests._inversion import moonlit_scenarios, patch_inversion


def test_known_amplitude_misfit_is_least_squares_with_the_moon_subtracted():
    rng = np.random.default_rng(1)
    yn, w = rng.random(5) + 0.5, rng.random(5) + 0.2
    p, q = rng.random((3, 5)), rng.random((3, 5))
    for beta in (0.0, 0.3, 2.0):
        got = np.asarray(inv_mod._chi2(jnp.asarray(yn), jnp.asarray(w), p, q, beta))
        for k in range(3):
            r = yn - beta * q[k]
            a = max(np.sum(w * p[k] * r) / np.sum(w * p[k] ** 2), 0.0)
            want = np.sum(w * (r - a * p[k]) ** 2)
            assert got[k] == pytest.approx(want, rel=1e-9, abs=1e-12)


@pytest.fixture(scope="module")
def moonlit():
    """Lamps, a scenario set with a moonless and a full-Moon state, its
    conditions, band weights, pixels and their Moon state."""
    lamps = inv_mod.library_lamps(GRID, scored=True).take(range(0, 120, 6))
    scen = moonlit_scenarios(lamps.ids[0])
    cond = inv_mod.Conditions.from_scenarios(scen)
    w = inv_mod.band_weights_on(FIVE, GRID)
    rows, moon, types = [], [], []
    for i, name in enumerate(("asphalt", "grass")):
        lit = scen.with_lamps(list(lamps.ids[:8]), lamps.spectra[:8])
        toa = np.asarray(dense_spectra(lit))[:, i, 0]  # (l, m, c, w)
        for j, m in enumerate((0.0, 1.0)):
            rows.append(toa[:, j, 0] @ w.T)
            moon += [m] * 8
            types += [name] * 8
    return lamps, cond, w, np.vstack(rows), np.asarray(moon), types


@pytest.mark.parametrize("mode", ["unknown", "class"])
def test_moonless_pixels_told_no_moon_match_an_inversion_without_the_moon(
    moonlit, mode
):
    """Told 'no Moon', a pixel is scored exactly as by an inversion whose
    conditions have no Moon term; told nothing (NaN) as before; and knowing
    the Moon changes the moonlit pixels' scores."""
    lamps, cond, w, rad, moon, types = moonlit
    basis = inv_mod.surface_basis(GRID)
    inv = inv_mod.build_inversion(lamps, w, cond, basis, mode)
    no_moon = dataclasses.replace(cond, moon=None, path=None)
    inv0 = inv_mod.build_inversion(lamps, w, no_moon, basis, mode)
    surf = types if mode == "class" else None
    dark = moon == 0
    told = inv.posterior(rad, surf, moon=np.where(dark, 0.0, np.nan))
    surf_dark = None if surf is None else list(np.array(surf)[dark])
    ref = inv0.posterior(rad[dark], surf_dark)
    np.testing.assert_allclose(told[0][dark], ref[0], rtol=1e-8, atol=1e-12)
    np.testing.assert_allclose(told[1][dark], ref[1], rtol=1e-8, atol=1e-12)
    free = inv.posterior(rad, surf)
    np.testing.assert_array_equal(told[0][~dark], free[0][~dark])  # NaN: fitted
    np.testing.assert_array_equal(
        inv.posterior(rad, surf, moon=np.full(len(rad), np.nan))[0], free[0]
    )
    known = inv.posterior(rad, surf, moon=moon)
    assert np.abs(known[0][~dark] - free[0][~dark]).max() > 1e-3
    with pytest.raises(ValueError, match="amplitudes for"):
        inv.posterior(rad, surf, moon=moon[:3])
    with pytest.raises(ValueError, match="no Moon term"):
        inv0.posterior(rad, surf, moon=moon)


def test_all_told_pixels_take_the_known_moon_path_only(moonlit):
    """When every pixel is told its Moon (the shared-surface path skips the
    fitted-Moon misfit), the scores are those of the same pixels scored next
    to one pixel that is not told (both misfits computed, then chosen)."""
    lamps, cond, w, rad, moon, _ = moonlit
    inv = inv_mod.build_inversion(lamps, w, cond, inv_mod.surface_basis(GRID))
    told = inv.posterior(rad, moon=moon)
    mixed = inv.posterior(np.vstack([rad, rad[:1]]), moon=np.r_[moon, np.nan])
    np.testing.assert_allclose(told[0], mixed[0][:-1], rtol=1e-10, atol=1e-14)
    np.testing.assert_allclose(told[1], mixed[1][:-1], rtol=1e-10, atol=1e-12)


def test_context_moon_follows_the_scene_order():
    from bandopt.forward import scenario_table
    from bandopt.search import _task, get_context

    preset = dict(surfaces=("asphalt",), moons=(None, "full"), classes=("P4", "P6"))
    _task.PRESETS.setdefault("test_moon", preset)
    ctx = get_context("test_moon", None, 0, "none")
    amp = inv_mod.context_moon(ctx)
    sc = ctx.config["scenarios"]
    table = scenario_table(
        build_scenarios(
            scored_only=True, surfaces=sc["surfaces"], atmospheres=("none",),
            moons=tuple(sc["moons"]), classes=tuple(sc["classes"]),
        )
    )  # fmt: skip
    full = np.array([str(m).startswith("full") for m in table.moon])
    assert full.any() and not full.all()
    np.testing.assert_array_equal(amp, np.where(full, 1.0, 0.0))


@pytest.fixture(scope="module")
def moon_ctx():
    from bandopt.search import _task, get_context

    preset = dict(surfaces=("asphalt",), moons=(None, "full"), classes=("P4", "P6"))
    _task.PRESETS.setdefault("test_moon", preset)
    return get_context("test_moon", None, 0, "none")


def test_cross_validate_tells_the_moon_only_to_inversion_moon(moon_ctx, monkeypatch):
    seen = []
    real = inv_mod.fit_inversion

    def spy(*a, **kw):
        seen.append(kw.get("row_moon"))
        return real(*a, **kw)

    patch_inversion(monkeypatch, "fit_inversion", spy)
    recs = inv_mod.cross_validate(
        moon_ctx, FIVE, estimators=("inversion", inv_mod.MOON_ESTIMATOR), folds=[0]
    )
    assert seen[0] is None
    np.testing.assert_array_equal(seen[1], inv_mod.context_moon(moon_ctx))
    by = {}
    for r in recs:
        by.setdefault(r.estimator, []).append(r)
    assert set(by) == {"inversion", inv_mod.MOON_ESTIMATOR}
    assert all(r.out_of_range == 0 for r in recs)
    assert [r.lamp for r in by["inversion"]] == [
        r.lamp for r in by[inv_mod.MOON_ESTIMATOR]
    ]
    assert any(
        a.G != b.G
        for a, b in zip(by["inversion"], by[inv_mod.MOON_ESTIMATOR], strict=True)
        if a.G is not None
    )

    class StopError(Exception):
        pass

    def stop(*a, **kw):
        seen.append(kw.get("row_moon"))
        raise StopError

    patch_inversion(monkeypatch, "fit_inversion", stop)
    with pytest.raises(StopError):
        inv_mod.leave_one_class_out(moon_ctx, FIVE, moon_known=True)
    np.testing.assert_array_equal(seen[-1], inv_mod.context_moon(moon_ctx))


@pytest.fixture(scope="module")
def three_moons():
    """A small classification table with no Moon, a full and a first-quarter
    Moon (one lamp per scored level-2 class, asphalt, no atmosphere)."""
    from bandopt.classify import scenario_table
    from bandopt.datasets.lamps import library

    lib = library().select(scored_only=True)
    first: dict[str, str] = {}
    for r in lib.records:
        first.setdefault(r.level2, r.id)
    return scenario_table(
        build_scenarios(
            lamps=sorted(first.values()),
            surfaces=("asphalt",),
            atmospheres=("none",),
            moons=(None, "full", "first_quarter"),
            classes=("P4",),
        )
    )


def test_table_moon_is_each_rows_moon_state_relative_to_the_brightest(three_moons):
    """0 moonless, 1 full Moon, and for the first quarter the ratio of its
    moonlit TOA radiance (scene minus the same scene without Moon) to the
    full Moon's, within the 'same lunar spectrum shape' approximation."""
    from bandopt.classify import table_moon

    t = three_moons
    amp = table_moon(t)
    labels = np.asarray(t.moon, dtype=object)
    state = np.array([str(m).split("@")[0] for m in labels])
    assert amp.shape == (t.n_rows,)
    np.testing.assert_array_equal(amp[state == "none"], 0.0)
    np.testing.assert_array_equal(amp[state == "full"], 1.0)
    fq = amp[state == "first_quarter"]
    assert fq.size and np.all(fq == fq[0]) and 0.0 < fq[0] < 1.0
    toa = np.asarray(t.toa)
    ratios = []
    for lamp in np.unique(t.lamp):
        at = {s: np.flatnonzero((t.lamp == lamp) & (state == s))[0] for s in
              ("none", "full", "first_quarter")}  # fmt: skip
        moonlit_full = toa[at["full"]] - toa[at["none"]]
        moonlit_fq = toa[at["first_quarter"]] - toa[at["none"]]
        ratios.append(moonlit_fq.sum() / moonlit_full.sum())
    assert np.allclose(ratios, fq[0], rtol=0.05)


def test_classifier_told_the_moon_fits_and_predicts_with_table_moon(
    three_moons, monkeypatch
):
    from bandopt.classify import evaluate_band_set, table_moon
    from bandopt.sensor import load_band_set

    seen = {}
    real_predict = inv_mod.Inversion.predict

    class StopError(Exception):
        pass

    def fit_spy(rad, row_lamp, *a, **kw):
        seen["fit"] = (np.asarray(row_lamp), kw.get("row_moon"))
        return real_fit(rad, row_lamp, *a, **kw)

    def predict_spy(self, radiance, surface=None, moon=None):
        seen["predict"] = (np.asarray(radiance).shape[0], moon)
        raise StopError

    real_fit = inv_mod.fit_inversion
    patch_inversion(monkeypatch, "fit_inversion", fit_spy)
    monkeypatch.setattr(inv_mod.Inversion, "predict", predict_spy)
    bands = load_band_set("sdgsat-1")
    with pytest.raises(StopError):
        evaluate_band_set(
            three_moons, bands, estimator="inversion", noise=False, moon_known=True
        )
    amp = table_moon(three_moons)
    row_lamp, moon = seen["fit"]
    assert moon is not None and moon.shape == row_lamp.shape
    assert set(np.unique(moon)) == set(np.unique(amp))
    n, told = seen["predict"]
    assert told is not None and told.shape == (n,)
    assert set(np.unique(told)) <= set(np.unique(amp))
    monkeypatch.setattr(inv_mod.Inversion, "predict", real_predict)
    with pytest.raises(ValueError, match="KNN"):
        evaluate_band_set(three_moons, bands, noise=False, moon_known=True)
