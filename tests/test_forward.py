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
