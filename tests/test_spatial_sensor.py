"""PSF, GSD resampling, noise, DoG detection, matching, the CLI and Mitsuba."""

import json
import math

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from bandopt.sensor import BandSet
from bandopt.spatial import (
    Grid,
    LampPlacement,
    Layout,
    block_mean,
    detect_lamps,
    dog_response,
    lamp_type_f1_when_overlapping,
    match,
    match_radius_m,
    mtf_at_nyquist,
    observe,
    psf_sigma_m,
    render,
    resample_to_gsd,
    sensor_image,
)


def test_psf_sigma_from_fwhm_and_mtf():
    assert psf_sigma_m(10.0) == pytest.approx(10.0 / 2.354820045, rel=1e-9)
    s = psf_sigma_m(10.0, mtf_nyquist=0.3)
    assert mtf_at_nyquist(s, 10.0) == pytest.approx(0.3, rel=1e-12)
    # Gaussian MTF at f = 1/(2 GSD): exp(-2 π² σ² f²), evaluated independently
    assert math.exp(-2 * math.pi**2 * s**2 / 400.0) == pytest.approx(0.3, rel=1e-12)
    with pytest.raises(ValueError, match="mtf_nyquist"):
        psf_sigma_m(10.0, mtf_nyquist=1.2)
    with pytest.raises(ValueError, match="gsd_m"):
        psf_sigma_m(0.0)


@settings(deadline=None, max_examples=10)
@given(
    gsd=st.sampled_from([2.0, 5.0, 10.0]),
    x=st.floats(30.0, 70.0),
    y=st.floats(30.0, 70.0),
)
def test_resampling_moments_of_a_point_source(gsd, x, y):
    """A point source (one fine pixel) keeps its flux, its centroid, and gets the
    variance σ² + GSD²/12 (Gaussian PSF convolved with the pixel box) per axis."""
    dx = 0.25
    img = np.zeros((400, 400))
    j, i = int(y / dx), int(x / dx)
    img[j, i] = 1.0
    out = resample_to_gsd(img, dx, gsd)
    assert out.sum() * gsd**2 == pytest.approx(dx**2, rel=1e-6)
    c = (np.arange(out.shape[1]) + 0.5) * gsd
    p = out.sum(0) / out.sum()
    mean = (p * c).sum()
    var = (p * (c - mean) ** 2).sum()
    # sampled on GSD pixels, the centroid is within half a pixel of the source and
    # the variance between σ² and σ² + GSD²/4 (GSD²/12 on average over positions)
    assert abs(mean - (i + 0.5) * dx) <= gsd / 2
    s = psf_sigma_m(gsd)
    assert s**2 - 1e-9 <= var <= s**2 + gsd**2 / 4 + 1e-9


def test_block_mean_and_errors():
    a = np.arange(16.0).reshape(4, 4)
    np.testing.assert_allclose(block_mean(a, 2), [[2.5, 4.5], [10.5, 12.5]])
    with pytest.raises(ValueError, match="smaller than one"):
        block_mean(a, 5)
    with pytest.raises(ValueError, match="whole multiple"):
        resample_to_gsd(a, 0.3, 1.0)


def _bands():
    return BandSet.from_edges([(500.0, 900.0)], names=["pan"])


def test_noise_is_seeded_and_shot_noise_sized():
    from bandopt.sensor import SensorParams, responsivity
    from bandopt.spectra import GRID_1NM

    rad = np.full((1, 60, 60), 2e-6)
    a = sensor_image(rad, _bands(), 10.0, seed=3, bit_depth=None)
    b = sensor_image(rad, _bands(), 10.0, seed=3, bit_depth=None)
    c = sensor_image(rad, _bands(), 10.0, seed=4, bit_depth=None)
    np.testing.assert_array_equal(a, b)
    assert not np.array_equal(a, c)
    params = SensorParams.for_gsd(10.0)
    r = float(
        np.asarray(responsivity(_bands().response(GRID_1NM), GRID_1NM, params))[0]
    )
    electrons = 2e-6 * r
    # relative spread = 1/sqrt(N) (Poisson), from 3600 samples: ±10 %
    assert np.std(a) / 2e-6 == pytest.approx(1 / math.sqrt(electrons), rel=0.1)
    q = sensor_image(
        rad, _bands(), 10.0, seed=3, bit_depth=8, saturation_w_m2_sr_nm=1e-5
    )
    step = 1e-5 / 255
    np.testing.assert_allclose(q / step, np.round(q / step), atol=1e-6)


def _blobs(shape, centres, sigma_px, amp=1.0):
    y, x = np.mgrid[: shape[0], : shape[1]]
    img = np.zeros(shape)
    for cy, cx in centres:
        img += amp * np.exp(-((x - cx) ** 2 + (y - cy) ** 2) / (2 * sigma_px**2))
    return img


def test_dog_detects_isolated_blobs_at_their_positions():
    grid = Grid(0.0, 0.0, 100, 60, 10.0)
    centres = [(20, 20), (30, 60), (45, 85)]
    img = _blobs(grid.shape, centres, 1.0)
    img += np.random.default_rng(0).normal(0, 1e-3, img.shape)
    det = detect_lamps(img, grid)
    truth = np.array([(grid.x_m[cx], grid.y_m[cy]) for cy, cx in centres])
    s = match(det.xy_m, truth, match_radius_m(10.0))
    assert (s.tp, s.fp, s.fn) == (3, 0, 0)
    # noise alone: the 5σ threshold keeps false detections rare
    noise = np.random.default_rng(1).normal(0, 1.0, grid.shape)
    assert detect_lamps(noise, grid).xy_m.shape[0] <= 2


def test_dog_response_of_a_flat_image_is_zero_inside():
    d = dog_response(np.ones((50, 50)), 10.0)
    np.testing.assert_allclose(d[20:30, 20:30], 0.0, atol=1e-12)


def test_match_counts():
    t = np.array([[0.0, 0.0], [30.0, 0.0], [60.0, 0.0]])
    d = np.array([[1.0, 0.0], [29.0, 2.0], [200.0, 0.0], [2.0, 1.0]])
    s = match(d, t, 5.0)
    assert (s.tp, s.fp, s.fn) == (2, 2, 1)
    assert s.precision == 0.5 and s.recall == pytest.approx(2 / 3)
    assert s.f1 == pytest.approx(2 * 0.5 * (2 / 3) / (0.5 + 2 / 3))
    assert match(np.zeros((0, 2)), t, 5.0).f1 == 0.0
    assert match_radius_m(2.0) == pytest.approx(5.0 + 2.0 / np.sqrt(2))
    assert match_radius_m(20.0) == pytest.approx(5.0 + 20.0 / np.sqrt(2))


def test_overlapping_lamp_types_are_identified():
    """Alternating HPS and LED lamps: at fine GSD most lit pixels are pure and
    their type is found; at coarse GSD pixels mix the two types."""
    from bandopt.sensor import reference_sensor
    from bandopt.spatial import arrangement, per_type_radiance, render

    bands = reference_sensor("sdgsat-1")
    lay = arrangement("single-sided", spacing_m=40.0, mounting_height_m=10.0,
                      length_m=240.0, width_m=60.0,
                      lamps=("nist_traditional_hps", "cie_led_b3"))
    scene = render(lay, bands, dx_m=1.0)
    per_type = per_type_radiance(scene, bands)
    # The per-type images add up to the scene (linearity).
    np.testing.assert_allclose(per_type.sum(axis=0), scene.radiance, rtol=1e-9)
    fine = lamp_type_f1_when_overlapping(scene, bands, 2.0, per_type=per_type, seed=1)
    coarse = lamp_type_f1_when_overlapping(scene, bands, 20.0, per_type=per_type,
                                           seed=1)
    assert set(fine.f1_per_class) == {"hps", "led_cool"}
    assert fine.n_lit > coarse.n_lit > 0
    assert 0 < fine.mixed_fraction < 1 and 0 < fine.mean_minority_share < 0.5
    # Pixels lit mostly by the HPS lamps are recognised as HPS; mixing hurts.
    assert fine.f1_per_class["hps"] > 0.6
    assert fine.f1_pure > fine.f1_mixed
    for sc in (fine, coarse):
        assert 0.0 <= sc.macro_f1 <= 1.0 and 0.0 <= sc.accuracy <= 1.0


def test_isotropic_uplight_lamp_found_at_fine_gsd():
    """A 50 % uplight lamp shows itself: detected at 2 m and 10 m."""
    lay = Layout(
        "one",
        (LampPlacement(100.1, 0.3, 8.0, "lop-50", "cie_led_b3", 8000.0),),
        length_m=200.0,
        width_m=100.0,
    )
    scene = render(lay, _bands(), dx_m=0.5)
    for gsd in (2.0, 10.0):
        obs = observe(scene, _bands(), gsd, seed=1)
        assert obs.score.tp == 1 and obs.score.fp == 0


def test_road_optic_row_is_found_at_every_gsd_down_to_its_spacing():
    """A single-sided row of road-optic lamps is seen through its light pools,
    whose brightest part lies on the sidewalk beside the pole. Every lamp is
    found at 2.5, 5 and 10 m (at 5 m the old radius, max(GSD, 5 m), missed all
    of them); at 5 m and finer the far sidewalk's pool adds about one false
    detection per lamp, and no more."""
    from bandopt.spatial import arrangement, true_targets

    lay = arrangement("single-sided", spacing_m=30.0, mounting_height_m=10.0,
                      length_m=200.0, width_m=80.0,
                      lamps=("nist_traditional_hps",))
    scene = render(lay, _bands(), dx_m=0.5)
    n = len(true_targets(scene))
    for gsd in (2.5, 5.0, 10.0):
        s = observe(scene, _bands(), gsd, seed=2).score
        assert s.tp == n, (gsd, s)
        assert s.fp <= n, (gsd, s)


def test_cli_render_writes_outputs(tmp_path):
    from bandopt.cli import main

    lay = {
        "name": "tiny",
        "length_m": 100.0,
        "width_m": 40.0,
        "lamp": [
            {
                "x_m": 50.0,
                "y_m": -2.5,
                "mounting_height_m": 8.0,
                "luminaire": "lop-50",
                "lamp": "cie_led_b3",
                "flux_lm": 8000.0,
            }
        ],
    }
    (tmp_path / "tiny.json").write_text(json.dumps(lay))
    out = tmp_path / "out"
    rc = main(
        [
            "render",
            "--layout",
            str(tmp_path / "tiny.json"),
            "--gsd",
            "5",
            "10",
            "--bands",
            "viirs-dnb",
            "--out",
            str(out),
            "--dx",
            "0.5",
        ]
    )
    assert rc == 0
    s = json.loads((out / "summary.json").read_text())
    assert [r["gsd_m"] for r in s["results"]] == [5.0, 10.0]
    assert (out / "tiny_gsd10m.png").stat().st_size > 0
    assert (out / "manifest.json").exists()
    import tifffile

    assert tifffile.imread(out / "tiny_gsd5m.tif").shape == (1, 8, 20)
    assert main(["render", "--layout", "nope", "--out", str(out)]) == 2
    assert (
        main(["render", "--layout", "single", "--gsd", "0.3", "--out", str(out)]) == 2
    )


@pytest.mark.slow
def test_analytic_renderer_matches_mitsuba_within_noise():
    """Mitsuba 3 (path tracing, box filter) vs our renderer (supersampled 16 x 16
    to the same pixel footprint) on one flat scene: a uniform luminaire
    (constant intensity below the horizon = Mitsuba's isotropic point light
    over the plane). 8 independent Monte Carlo runs give a per-pixel standard
    error; the t statistics of the difference must look like noise."""
    from bandopt.spatial import illuminance_images, lamp_arrays, montecarlo, scene_grid

    if not montecarlo.available():
        pytest.skip("mitsuba (scalar_rgb) not installed")
    h, flux, rho, ext, n, runs = 8.0, 1000.0, 0.2, 40.0, 40, 8
    kw = dict(
        intensity_cd=flux / (2 * math.pi),
        height_m=h,
        reflectance=rho,
        extent_m=ext,
        pixels=n,
    )
    mc = np.stack(
        [montecarlo.render_point_light(spp=32, seed=k + 1, **kw) for k in range(runs)]
    )
    lay = Layout(
        "mc",
        (LampPlacement(ext / 2, 0.0, h, "uniform", "cie_led_b3", flux),),
        length_m=ext,
        width_m=ext,
    )
    e = np.asarray(
        illuminance_images(
            lamp_arrays(lay), scene_grid(lay, ext / n / 16), cull_fraction=0.0
        )
    )[0]
    ours = rho / math.pi * block_mean(e, 16)
    sem = mc.std(axis=0, ddof=1) / math.sqrt(runs)
    t = (mc.mean(axis=0) - ours) / np.maximum(sem, 1e-6 * ours)
    # t has 7 degrees of freedom: E[t²] = 1.4; 1600 pixels
    assert np.mean(t**2) < 2.5
    assert np.max(np.abs(t)) < 10.0
    # no bias over the image beyond the trapezoid normalisation of the table (2e-5)
    rel = (mc.mean(axis=0) - ours) / ours
    assert abs(rel.mean()) < 4 * rel.std() / n + 2e-5


def test_cross_sections_and_phases():
    """The across-road section of a Lambertian lamp peaks under the lamp, and
    grid phases are offsets inside one GSD pixel (the first is no shift)."""
    from bandopt.spatial import cross_section, phases

    lay = Layout(
        "one",
        (LampPlacement(50.0, 0.0, 8.0, "lambertian", "cie_led_b3", 8e3),),
        length_m=100.0,
        width_m=100.0,
    )
    scene = render(lay, _bands(), dx_m=1.0)
    obs = observe(scene, _bands(), 5.0, noise=False, bit_depth=None)
    for axis in ("along", "across"):
        cs = cross_section(obs, scene, axis)
        k = int(np.argmax(cs["radiance"]))
        assert abs(cs["position_m"][k]) <= 2.5
        assert cs["dog"][k] == pytest.approx(np.max(cs["dog"]))
    with pytest.raises(ValueError, match="axis"):
        cross_section(obs, scene, "diagonal")
    ph = phases(scene, 10.0, 4, seed=0)
    assert ph[0] == (0, 0) and len(ph) == 4
    assert all(0 <= a < 10 and 0 <= b < 10 for a, b in ph)
