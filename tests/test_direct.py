"""`bandopt.direct`: the library-free estimate from contiguous bands, and
`bandopt evaluate --estimator direct`. Exact recovery through a synthetic
scene, the tiling check, physical values and reasons, calibrated intervals
on the library, the lamp type of the nearest library lamp, and the CLI."""

import json

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from bandopt import direct
from bandopt.cli import main
from bandopt.inversion import Conditions, band_weights_on
from bandopt.sensor import BandSet


GRID = np.arange(380.0, 901.0)


def test_direct_spectra_recover_a_lamp_through_surface_atmosphere_and_moon():
    """A flat lamp spectrum seen through a sloped surface and atmosphere,
    with moonlight and path radiance at a told brightness: dividing out the
    surface and transmittance and removing the Moon's term gives it back."""
    bands = BandSet.contiguous(13)
    w = band_weights_on(bands, GRID)
    t = 0.6 + 0.3 * (GRID - 380.0) / 520.0
    rho = np.stack([0.05 + 0.2 * (GRID - 380.0) / 520.0, np.full(GRID.size, 0.3)])
    moon_e, path = np.full(GRID.size, 2.0), np.full(GRID.size, 0.01)
    cond = Conditions(GRID, t[None], moon_e[None], path[None], ("a",))
    lamp, amp = 5.0, np.array([0.0, 0.7])
    y = (rho * t * lamp / np.pi) @ w.T
    y += amp[:, None] * ((rho * t * moon_e / np.pi) @ w.T + w @ path)
    edges = direct.tiling_edges(bands)
    s = direct.direct_spectra(y, w, cond, rho, amp, edges)
    np.testing.assert_allclose(s, lamp, rtol=1e-9)
    # too much Moon removed (noise): clipped to no light, never negative
    s = direct.direct_spectra(y, w, cond, rho, amp + 5.0, edges)
    assert s.min() == 0.0 and np.all(np.isfinite(s))


def test_piecewise_holds_each_band_from_its_lower_edge():
    edges = np.array([[480.0, 580.0], [380.0, 480.0]])  # any order
    s = direct.piecewise(
        np.array([[2.0, 1.0]]), edges, np.array([380.0, 479, 480, 900])
    )
    np.testing.assert_array_equal(s, [[1.0, 1.0, 2.0, 2.0]])


def test_contiguous_bands_tile_in_any_order():
    b = BandSet.contiguous(26)
    np.testing.assert_allclose(direct.tiling_edges(b), np.asarray(b.edges_nm))
    shuffled = BandSet.from_physical(
        np.asarray(b.centre_nm)[::-1], np.asarray(b.fwhm_nm)[::-1], min_fwhm_nm=20.0
    )
    np.testing.assert_allclose(
        direct.tiling_edges(shuffled), np.asarray(shuffled.edges_nm)
    )


@pytest.mark.parametrize(
    ("edges", "match"),
    [
        ([(380, 500), (520, 780)], "'B1' ends at 500.0 nm and 'B2' starts at 520.0 nm"
         r" \(a gap of 20.0 nm"),
        ([(380, 600), (500, 780)], "an overlap of 100.0 nm"),
        ([(400, 600), (600, 780)], "the first band starts at 400.0 nm"),
        ([(380, 600), (600, 700)], "the last band ends at 700.0 nm"),
    ],
)  # fmt: skip
def test_bands_that_do_not_tile_are_refused_saying_where(edges, match):
    with pytest.raises(ValueError, match=match):
        direct.tiling_edges(BandSet.from_edges(edges))


def test_metrics_are_physical_or_null_with_a_reason():
    red = np.exp(-0.5 * ((GRID - 650.0) / 8.0) ** 2)
    white = np.ones(GRID.size)
    values, reasons = direct.direct_metrics(
        np.stack([np.zeros(GRID.size), red, white]), GRID
    )
    assert np.all(np.isnan(values[0])) and "no light" in reasons[0]["LER"]
    assert 0.0 < values[1, 0] < 683.0 and np.isnan(values[1, 2])
    assert "CCT" in reasons[1] and set(reasons[1]) == {"CCT"}
    assert np.all(np.isfinite(values[2])) and reasons[2] == {}
    assert 1000.0 <= values[2, 2] <= 25000.0


def _estimator(halfwidth=(5.0, 0.05, 20.0)):
    bands = BandSet.contiguous(13)
    w = band_weights_on(bands, GRID)
    lib = np.stack([np.ones(GRID.size), np.exp(-0.5 * ((GRID - 600.0) / 30.0) ** 2)])
    return direct.DirectEstimator(
        direct.tiling_edges(bands), w, np.asarray(halfwidth), {"lamps": 2},
        direct._shape(lib @ w.T), ("flat", "orange"), ("incandescent", "hid"),
        ("incandescent_halogen", "hps"),
    ), w, lib  # fmt: skip


def test_rows_give_intervals_around_the_estimate_and_the_nearest_lamps_type():
    est, w, lib = _estimator()
    cond = Conditions.clear(GRID)
    rho = np.full(GRID.size, 0.1)
    y = (rho * lib / np.pi) @ w.T * 3.0  # any brightness
    rows = est.rows(y, cond, rho)
    assert [r["predicted_level2"] for r in rows] == ["incandescent_halogen", "hps"]
    assert [r["nearest_library_lamp"] for r in rows] == ["flat", "orange"]
    for r in rows:
        assert r["unexplained"] is None and r["level1_probabilities"] is None
        for m in ("LER", "G"):
            lo, hi = r["interval90"][m]
            assert lo <= r["estimate"][m] <= hi
        lo, hi = r["interval90"]["LER"]
        assert 0.0 <= lo and hi <= 683.0
        assert hi - lo == pytest.approx(10.0) or lo == 0.0 or hi == 683.0
    # the interval is ± the half-width in mired for CCT
    lo, hi = rows[0]["interval90"]["CCT"]
    mired = 1e6 / rows[0]["estimate"]["CCT"]
    assert 1e6 / lo == pytest.approx(mired + 20.0)
    assert 1e6 / hi == pytest.approx(mired - 20.0)


@pytest.fixture(scope="module")
def context():
    from bandopt._config import configure
    from bandopt.search import get_context

    configure()
    return get_context("search", None, 0, "none")


def test_intervals_are_calibrated_on_the_library_and_knowing_the_surface_narrows_them(
    context,
):
    bands = BandSet.contiguous(26)
    known = direct.fit_direct(context, bands, "class")
    unknown = direct.fit_direct(context, bands, "unknown")
    assert known.calibration["lamps"] == len(known.library_ids) > 200
    assert np.all(np.isfinite(known.halfwidth)) and np.all(known.halfwidth > 0)
    assert np.all(known.halfwidth < unknown.halfwidth)
    # the half-widths cover 90 % of the library's pixels, class-balanced
    with pytest.raises(ValueError, match="contiguous bands tiling"):
        direct.fit_direct(
            context, BandSet.from_edges([(380, 600), (650, 780)]), "class"
        )


def _lamp_file(tmp_path, name="lamp.csv"):
    from bandopt.inversion import library_lamps

    lamps = library_lamps(GRID, scored=True)
    i = lamps.ids.index("nist_traditional_hps")
    path = tmp_path / name
    np.savetxt(path, np.c_[GRID, lamps.spectra[i]], delimiter=",")
    return path


def test_evaluate_direct_on_contiguous_bands(tmp_path, capsys):
    bands = tmp_path / "c26.json"
    BandSet.contiguous(26).to_json(bands)
    lamp = _lamp_file(tmp_path)
    argv = ["evaluate", "--bands", str(bands), "--lamps", str(lamp), "--json",
            "--estimator", "direct", "--surface", "asphalt"]  # fmt: skip
    assert main(argv) == 0
    out = json.loads(capsys.readouterr().out)
    (row,) = out["lamps"]
    assert out["scene"]["estimator"] == "direct"
    assert "library-free direct estimate" in out["scene"]["estimator_description"]
    assert row["predicted_level2"] == "hps"
    assert row["nearest_library_lamp"] == "nist_traditional_hps"
    assert row["unexplained"] is None
    for m in ("LER", "G"):
        lo, hi = row["interval90"][m]
        assert lo <= row["true"][m] <= hi
    assert abs(row["estimate"]["LER"] - row["true"]["LER"]) < 5.0
    # HPS's CCT lies at the calibrated 90 % interval's edge (17 mired off, the
    # half-width 16): within two half-widths
    lo, hi = row["interval90"]["CCT"]
    half = (1e6 / lo - 1e6 / hi) / 2
    assert abs(1e6 / row["estimate"]["CCT"] - 1e6 / row["true"]["CCT"]) < 2 * half


def test_evaluate_direct_refuses_bands_that_do_not_tile(tmp_path, capsys):
    lamp = _lamp_file(tmp_path)
    argv = ["evaluate", "--bands", "sdgsat-1", "--lamps", str(lamp),
            "--estimator", "direct"]  # fmt: skip
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert "--bands sdgsat-1" in err and "contiguous bands tiling 380-780 nm" in err
    assert main([*argv, "--mixtures", "3"]) == 2
    assert "--estimator inversion only" in capsys.readouterr().err


def test_evaluate_direct_with_a_measured_reflectance_file(tmp_path, capsys):
    """A reflectance file is the surface measured: the same surface as its
    type gives the same estimate, and the description says so."""
    from bandopt.datasets import surfaces

    bands = tmp_path / "c26.json"
    BandSet.contiguous(26).to_json(bands)
    lamp = _lamp_file(tmp_path)
    _, refl = surfaces.mean_reflectance(["asphalt"], GRID)
    rfile = tmp_path / "asphalt.csv"
    np.savetxt(rfile, np.c_[GRID, refl[0]], delimiter=",")
    base = ["evaluate", "--bands", str(bands), "--lamps", str(lamp), "--json",
            "--estimator", "direct", "--surface"]  # fmt: skip
    assert main([*base, str(rfile)]) == 0
    measured = json.loads(capsys.readouterr().out)
    assert main([*base, "asphalt"]) == 0
    known = json.loads(capsys.readouterr().out)
    assert "surface measured" in measured["scene"]["estimator_description"]
    for m in ("LER", "G", "CCT"):
        assert measured["lamps"][0]["estimate"][m] == pytest.approx(
            known["lamps"][0]["estimate"][m], rel=1e-6
        )


@settings(deadline=None, max_examples=40)
@given(
    st.lists(
        st.floats(-1.0, 1e3, allow_nan=False, allow_infinity=False),
        min_size=13,
        max_size=13,
    )
)
def test_rows_never_leave_the_physical_range(values):
    """Any band values, noisy ones below zero included: every estimate and
    interval bound lies in LER 0-683 lm/W, G within its cap, CCT 1000-25000 K,
    or is null with a reason."""
    from bandopt.inversion import PHYSICAL_RANGE

    est, _, _ = _estimator()
    (row,) = est.rows(np.array([values]), Conditions.clear(GRID), 0.2)
    for m, (lo, hi) in PHYSICAL_RANGE.items():
        v, iv = row["estimate"][m], row["interval90"][m]
        if v is None:
            assert iv is None and m in row["null_reasons"]
            continue
        assert lo <= v <= hi and lo <= iv[0] <= v <= iv[1] <= hi
