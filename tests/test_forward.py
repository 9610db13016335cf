"""simulate(): cropping, photon noise, quantisation, labelled tables, CLI."""

import numpy as np
import pandas as pd
import pytest

from bandopt.cli import main
from bandopt.forward import simulate, to_frame
from bandopt.scene import build_scenarios
from bandopt.sensor import BandSet


@pytest.fixture(scope="module")
def scen():
    return build_scenarios(
        lamps=("nist_traditional_hps", "cie_led_b3", "nist_traditional_mercury"),
        surfaces=("asphalt", "grass"),
        atmospheres=(("midlatitude_summer", "urban", 23.0),),
        moons=(None, "full"),
        classes=("P1", "P6"),
    )


@pytest.fixture(scope="module")
def bands():
    return BandSet.from_physical([460.0, 560.0, 820.0], [40.0, 60.0, 40.0])


def test_crop_changes_little(scen, bands):
    a = simulate(scen, bands, crop=True).radiance
    b = simulate(scen, bands, crop=False).radiance
    np.testing.assert_allclose(a, b, rtol=1e-5)


def test_noise_reproducible_and_scaled_by_signal(scen, bands):
    clean = simulate(scen, bands).radiance
    n1 = simulate(scen, bands, noise=True, seed=3)
    n2 = simulate(scen, bands, noise=True, seed=3)
    n3 = simulate(scen, bands, noise=True, seed=4)
    np.testing.assert_array_equal(n1.radiance, n2.radiance)
    assert not np.array_equal(n1.radiance, n3.radiance)
    # Shot noise: relative error ~ 1/sqrt(electrons).
    rel = np.abs(n1.radiance / clean - 1)
    expected = 1 / np.sqrt(n1.electrons)
    assert np.median(rel / expected) == pytest.approx(
        0.674, rel=0.35
    )  # |N(0,1)| median


def test_quantisation_within_half_step(scen, bands):
    clean = simulate(scen, bands).radiance
    q = simulate(scen, bands, bits=8)
    lo, hi = (np.asarray(x) for x in q.config["limits"])
    step = (hi - lo) / 255
    assert np.all(np.abs(q.radiance - clean) <= step / 2 + 1e-18)


def test_frame_labels(scen, bands):
    sim = simulate(scen, bands)
    df = to_frame(scen, sim)
    assert len(df) == scen.n_lamp_scenes
    row = df[
        (df.lamp == "cie_led_b3")
        & (df.surface == "grass")
        & (df.moon == "none")
        & (df.lighting_class == "P6")
    ].iloc[0]
    i = scen.lamp_ids.index("cie_led_b3")
    np.testing.assert_allclose(
        row[["L_B1", "L_B2", "L_B3"]].to_numpy(float), sim.radiance[i, 1, 0, 0, 1]
    )
    assert row.level2 == "led_cool" and row.illuminance_lx == 2.0


def test_simulate_cli_csv(tmp_path, capsys):
    out = tmp_path / "sim.csv"
    code = main(
        [
            "simulate",
            "--bands",
            "sdgsat-1",
            "--lamps",
            "nist_traditional_hps",
            "--surfaces",
            "asphalt",
            "--atmospheres",
            "midlatitude_summer/urban/23",
            "none",
            "--moon",
            "none",
            "--classes",
            "P1",
            "M1",
            "--out",
            str(out),
        ]
    )
    assert code == 0
    df = pd.read_csv(out)
    assert len(df) == 4 and {"lamp", "atmosphere", "lighting_class"} <= set(df.columns)
    assert sum(c.startswith("L_") for c in df.columns) == 4
    # M1 = 2 cd/m2 / 0.07 sr-1 = 28.6 lx > P1 = 15 lx.
    m1 = df[df.lighting_class == "M1"].filter(like="L_").to_numpy()
    p1 = df[df.lighting_class == "P1"].filter(like="L_").to_numpy()
    np.testing.assert_allclose(m1 / p1, (2.0 / 0.07) / 15.0, rtol=1e-9)


def test_simulate_cli_bad_atmosphere(tmp_path, capsys):
    code = main(
        [
            "simulate",
            "--bands",
            "viirs-dnb",
            "--atmospheres",
            "mars",
            "--out",
            str(tmp_path / "x.csv"),
        ]
    )
    assert code == 2 and "--atmospheres 'mars'" in capsys.readouterr().err


# ------------------------------------------------------------------------------
# one measurement path


def test_same_seed_same_noise_in_every_caller(scen, bands):
    """simulate, the classification table, the radiometry measurement and the
    band-search problem (on all lamps and on a subset) draw the same noise for
    the same scene, band and seed."""
    import jax.numpy as jnp

    from bandopt.estimate import LampTable
    from bandopt.forward import band_radiance, scenario_table
    from bandopt.radiometry import measure
    from bandopt.search import Space, make_problem, scenario_spectra

    seed = 5
    b = 3
    sim = simulate(scen, bands, noise=True, seed=seed).radiance.reshape(-1, b)
    table = scenario_table(scen)
    tab = table.band_radiance(bands, noise=True, seed=seed)
    rad = measure(scen, bands, seed=seed).noisy
    direct = np.asarray(band_radiance(scen, bands, noise=True, key=seed))
    # simulate and measure crop the grid to the bands' support (~1e-6 relative)
    np.testing.assert_array_equal(rad, sim)
    np.testing.assert_array_equal(direct.reshape(-1, b), sim)
    np.testing.assert_allclose(tab, sim, rtol=1e-5)
    clean = simulate(scen, bands).radiance.reshape(-1, b)
    assert np.all(np.abs(sim - clean) > 1e-6 * np.abs(clean))  # noise is there

    toa = scenario_spectra(scen)
    n_l, q = toa.shape[:2]
    lt = LampTable(
        np.repeat(np.arange(n_l), q), np.array(["a", "b", "a"], object),
        np.ones((n_l, 3)), np.ones((n_l, 3), bool),
    )  # fmt: skip
    wl = table.wavelength_nm
    resp = jnp.asarray(bands.response(wl))
    for lamps in ([0, 1, 2], [1, 2]):
        prob = make_problem(
            toa, wl, lt, np.asarray(lamps), [([lamps[0]], [lamps[1]])],
            target="all", space=Space(b, pan="none"), noise=True, seed=seed,
        )  # fmt: skip
        got = np.asarray(prob.radiance_from_response(resp))
        np.testing.assert_allclose(got, tab[table.rows_of_lamps(lamps)], rtol=1e-12)


def test_noise_draws_per_band_and_key():
    """Band j's draws do not depend on the number of bands; an integer seed and
    its PRNGKey give the same draws; the draws look standard normal."""
    import jax

    from bandopt.forward import noise_draws

    a = np.asarray(noise_draws(7, 2000, 2))
    b = np.asarray(noise_draws(jax.random.PRNGKey(7), 2000, 4))
    np.testing.assert_array_equal(a, b[:, :2])
    assert not np.array_equal(b[:, 0], b[:, 1])
    # mean and SD of 8000 N(0, 1) draws: 5 standard errors
    assert abs(b.mean()) < 5 / np.sqrt(b.size)
    assert abs(b.std() - 1) < 5 / np.sqrt(2 * b.size)


def test_zero_responsivity_band_reads_zero_with_finite_gradient():
    """A band with no response on the grid reads 0 (not NaN), noisy or not,
    and the gradient through the photon model stays finite."""
    import jax
    import jax.numpy as jnp

    from bandopt.forward import noise_draws, radiance_from_response

    wl = jnp.arange(400.0, 901.0, 5.0)
    spectra = jnp.stack([jnp.ones_like(wl), 1 + wl / 900.0]) * 1e-6
    resp = jnp.stack([jnp.exp(-0.5 * ((wl - 560.0) / 30.0) ** 2), 0 * wl])
    z = noise_draws(0, 2, 2)
    for noise in (None, z):
        out = np.asarray(radiance_from_response(spectra, wl, resp, noise))
        assert np.all(np.isfinite(out)) and np.all(out[:, 1] == 0)
        assert np.all(out[:, 0] > 0)

    def f(r):
        return jnp.sum(radiance_from_response(spectra, wl, r, z))

    assert np.all(np.isfinite(np.asarray(jax.grad(f)(resp))))


def test_simulate_cli_uplight_model_and_neighbourhood(tmp_path):
    """The CLI passes the uplight model and the neighbourhood to the scene:
    without an atmosphere, the only difference is the uplight factor."""
    from bandopt.scene import uplight_factor

    common = [
        "simulate",
        "--bands",
        "sdgsat-1",
        "--lamps",
        "nist_traditional_hps",
        "--surfaces",
        "asphalt",
        "--atmospheres",
        "none",
        "--moon",
        "none",
        "--classes",
        "P1",
        "--uplight",
        "0.5",
        "--neighbourhood",
        "uniform",
    ]
    frames = {}
    for model in ("profile", "lambertian"):
        out = tmp_path / f"{model}.csv"
        assert main([*common, "--uplight-model", model, "--out", str(out)]) == 0
        frames[model] = pd.read_csv(out).filter(like="L_").to_numpy()
    # uplight 1/(2π) (isotropic 50 % profile) against 1/π (Lambertian u/(1-u))
    assert uplight_factor(0.5) < uplight_factor(0.5, model="lambertian")
    assert np.all(frames["profile"] < frames["lambertian"])


def test_band_values_is_the_contraction_of_every_band_radiance(scen, bands):
    """`band_values` is `spectra @ weightsᵀ` for any leading shape, and dense
    spectra's band radiance is it with the bands' averaging weights."""
    from bandopt.forward import (
        band_radiance,
        band_values,
        band_weights_on,
        dense_spectra,
    )

    wl = np.asarray(scen.factors.wavelength_nm)
    toa = np.asarray(dense_spectra(scen)).reshape(-1, wl.size)
    w = np.asarray(band_weights_on(bands, wl))
    got = np.asarray(band_values(toa, w))
    np.testing.assert_allclose(got, toa @ w.T, rtol=1e-13)
    np.testing.assert_array_equal(
        got, np.asarray(band_radiance(toa, bands, wavelength_nm=wl))
    )
    stacked = np.asarray(band_values(toa.reshape(2, -1, wl.size), w))
    np.testing.assert_array_equal(stacked.reshape(got.shape), got)


def test_band_radiance_inputs(scen, bands):
    """Spectra need their grid; a response array on the grid equals the band
    set; noise draws of the wrong shape are refused; factors and dense spectra
    agree (uncropped: same quadrature)."""
    from bandopt.forward import band_radiance, dense_spectra

    toa = np.asarray(dense_spectra(scen)).reshape(-1, scen.factors.wavelength_nm.size)
    wl = np.asarray(scen.factors.wavelength_nm)
    with pytest.raises(ValueError, match="wavelength_nm is required"):
        band_radiance(toa, bands)
    a = np.asarray(band_radiance(toa, bands, wavelength_nm=wl))
    b = np.asarray(band_radiance(toa, bands.response(wl), wavelength_nm=wl))
    np.testing.assert_array_equal(a, b)
    c = np.asarray(band_radiance(scen, bands, crop=False)).reshape(a.shape)
    np.testing.assert_allclose(c, a, rtol=1e-10)
    with pytest.raises(ValueError, match="noise draws must have shape"):
        band_radiance(toa, bands, wavelength_nm=wl, noise=np.zeros((2, 3)))
    with pytest.raises(ValueError, match="response array"):
        band_radiance(toa, np.ones((3, 5)), wavelength_nm=wl)


def test_scenes_lit_by_lamps_outside_the_library(scen):
    """`ScenarioSet.with_lamps` + `scenario_table(level1=, level2=)`: the same
    spectra under other names give the same rows; a spectrum twice as bright
    gives a lamp term twice as large (the scene is linear in the lamp); bad
    shapes and missing labels are refused with the reason."""
    from bandopt.forward import scenario_table

    base = scenario_table(scen)
    spec = np.asarray(scen.factors.lamp)
    names = [f"model_{i}" for i in range(spec.shape[0])]
    twin = scenario_table(
        scen.with_lamps(names, spec),
        level1=list(base.level1),
        level2=list(base.level2),
    )
    np.testing.assert_array_equal(twin.toa, base.toa)
    assert twin.lamp_ids == tuple(names)
    np.testing.assert_array_equal(twin.labels(2), base.labels(2))
    dark = scenario_table(
        scen.with_lamps(names, 0 * spec), level1=list(base.level1),
        level2=list(base.level2),
    )  # fmt: skip
    bright = scenario_table(
        scen.with_lamps(names, 2 * spec), level1=list(base.level1),
        level2=list(base.level2),
    )  # fmt: skip
    np.testing.assert_allclose(
        bright.toa - dark.toa, 2 * (base.toa - dark.toa), rtol=1e-9, atol=1e-15
    )
    assert np.any(base.toa - dark.toa > 0)
    with pytest.raises(ValueError, match="expected shape"):
        scen.with_lamps(names[:1], spec)
    with pytest.raises(ValueError, match="not finite"):
        scen.with_lamps(names, np.where(np.arange(spec.shape[1]) == 3, np.nan, spec))
    with pytest.raises(ValueError, match="not in the library"):
        scenario_table(scen.with_lamps(names, spec))
    with pytest.raises(ValueError, match="both level1 and level2"):
        scenario_table(scen.with_lamps(names, spec), level1=list(base.level1))


def test_scenario_table_keeps_its_scenario_set(scen):
    """`scenario_table` keeps the set it was built from (`ScenarioTable.
    scenarios`), whose scenes relit by the table's own lamps give its rows."""
    from bandopt.forward import scenario_table

    t = scenario_table(scen)
    assert t.scenarios is scen
    again = scenario_table(
        t.scenarios.with_lamps(t.lamp_ids, np.asarray(scen.factors.lamp))
    )
    np.testing.assert_array_equal(again.toa, t.toa)


def test_noisy_band_radiance_sees_the_same_draws_in_float32():
    """float32 spectra get the float64 draws cast (`jax.random.normal` gives
    other numbers in float32), so a float32 run measures the same noise."""
    import jax.numpy as jnp

    from bandopt.forward import band_radiance
    from bandopt.sensor import BandSet

    wl = np.arange(380.0, 901.0)
    spectra = np.stack([np.ones_like(wl), 1 + wl / 900.0]) * 1e-4
    bands = BandSet.from_physical([450.0, 600.0, 800.0], [40.0, 40.0, 60.0])
    a = np.asarray(
        band_radiance(jnp.asarray(spectra), bands, wavelength_nm=wl, noise=True, key=3)
    )
    b = np.asarray(
        band_radiance(
            jnp.asarray(spectra, jnp.float32),
            bands,
            wavelength_nm=wl,
            noise=True,
            key=3,
        ),
        float,
    )
    clean = np.asarray(band_radiance(jnp.asarray(spectra), bands, wavelength_nm=wl))
    assert np.max(np.abs(a - clean) / clean) > 1e-3  # the noise is visible
    np.testing.assert_allclose(b, a, rtol=1e-4)  # float32 rounding only


def test_measure_attaches_the_rows_to_the_band_radiance(scen, bands):
    """`measure` gives `band_measurement`'s numbers for a table, with each
    row's lamp, type and scene attached; it refuses anything but a table."""
    from bandopt.forward import band_measurement, measure, scenario_table

    t = scenario_table(scen)
    m = measure(t, bands, noise=True, key=5)
    ref = band_measurement(t, bands, noise=True, key=5)
    np.testing.assert_array_equal(np.asarray(m.radiance), np.asarray(ref.radiance))
    np.testing.assert_array_equal(np.asarray(m.noise_z), np.asarray(ref.noise_z))
    assert m.rows is t and m.radiance.shape == (t.n_rows, 3)
    np.testing.assert_array_equal(m.lamp, t.lamp)
    assert list(m.labels("level2")) == [t.level2[i] for i in t.lamp]
    # the rows are the scenario set's scenes in C order: row 0 of lamp 1
    lamp1 = np.flatnonzero(t.lamp == 1)[0]
    sim = simulate(scen, bands, noise=False, crop=False).radiance
    np.testing.assert_allclose(
        np.asarray(measure(t, bands).radiance)[lamp1], sim[1, 0, 0, 0, 0], rtol=1e-10
    )
    np.testing.assert_array_equal(
        t.band_radiance(bands, noise=True, seed=5), m.radiance
    )
    with pytest.raises(TypeError, match="ScenarioTable"):
        measure(scen, bands)
    with pytest.raises(ValueError, match="no rows"):
        band_measurement(t, bands).labels("level1")


def test_scenario_table_of_repeated_scenes(scen):
    """Scenes repeated `k` times (copy axis after surface) keep every row's
    labels and say what was done to each copy's lamp (`kind`)."""
    from bandopt.forward import dense_spectra, scenario_table

    dense = np.asarray(dense_spectra(scen))  # (l, s, a, m, c, w)
    rep = np.stack([dense, 2 * dense], axis=2)  # (l, s, 2, a, m, c, w)
    kind = np.zeros(rep.shape[:-1], int)
    kind[:, :, 1] = 1
    t = scenario_table(scen, spectra=rep, kind=kind, kinds=("clean", "doubled"))
    plain = scenario_table(scen)
    assert t.n_rows == 2 * plain.n_rows and t.kinds == ("clean", "doubled")
    clean = t.kind == 0
    np.testing.assert_array_equal(t.toa[clean], plain.toa)
    np.testing.assert_array_equal(t.toa[~clean], 2 * plain.toa)
    for field in ("lamp", "surface", "atmosphere", "moon", "lighting_class"):
        np.testing.assert_array_equal(getattr(t, field)[clean], getattr(plain, field))
        np.testing.assert_array_equal(getattr(t, field)[~clean], getattr(plain, field))
    assert t.scenes_per_lamp == 2 * plain.scenes_per_lamp
    np.testing.assert_array_equal(t.per_lamp(t.toa)[1], t.toa[t.lamp == 1])
    with pytest.raises(ValueError, match="need a kind"):
        scenario_table(scen, spectra=rep)


def test_scenario_set_refuses_a_table_without_its_set(scen):
    import dataclasses

    from bandopt.forward import scenario_table

    t = scenario_table(scen)
    assert t.scenario_set() is scen
    with pytest.raises(ValueError, match="no scenario set behind it"):
        dataclasses.replace(t, scenarios=None).scenario_set()
    with pytest.raises(ValueError, match="lamps differ"):
        dataclasses.replace(t, lamp_ids=("x", *t.lamp_ids[1:])).scenario_set()
