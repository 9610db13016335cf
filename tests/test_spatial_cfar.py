"""The fixed-false-alarm-rate lamp detector and what it sees besides lamps:
the DoG noise model against Monte Carlo, the false-alarm bound on
noise-only images, lamps found above it, the night-sky and moonlit
background, and the GSD study's sensor from the recommended radiometry."""

import math
from pathlib import Path

import numpy as np
import pytest
from scipy.stats import norm

from bandopt.sensor import BandSet
from bandopt.spatial import (
    Grid,
    arrangement,
    background_image,
    cfar_factor,
    detect_lamps,
    dog_noise_sigma,
    dog_response,
    noise_variance,
    render,
    sensor_image,
)


BANDS = BandSet.from_edges([(500, 600), (400, 900)], 6.0, names=["G", "PAN"])


def test_cfar_factor_is_the_gaussian_quantile_of_the_per_pixel_rate():
    for gsd, rate in ((1.0, 0.1), (10.0, 0.1), (100.0, 1.0)):
        p = rate * gsd**2 / 1e6
        assert cfar_factor(gsd, rate) == pytest.approx(norm.isf(p), rel=1e-12)
    assert cfar_factor(100.0, 0.1) < cfar_factor(1.0, 0.1)  # fewer pixels per km²
    with pytest.raises(ValueError, match="per-pixel rate"):
        cfar_factor(1000.0, 1e3)
    with pytest.raises(ValueError, match="per-pixel rate"):
        cfar_factor(10.0, 0.0)


@pytest.mark.parametrize("gsd", [1.0, 10.0])
def test_dog_noise_sigma_matches_monte_carlo(gsd):
    """σ_D from the kernel equals the spread of the DoG of white noise,
    also where the variance changes across the image."""
    rng = np.random.default_rng(0)
    var = np.ones((300, 300))
    var[:, 150:] = 4.0
    sd = dog_noise_sigma(var, gsd)
    draws = np.stack(
        [
            dog_response(rng.normal(0.0, np.sqrt(var)), gsd, mode="nearest")
            for _ in range(40)
        ]
    )
    for cols in (slice(30, 100), slice(200, 270)):
        emp = draws[:, 30:270, cols].std()
        assert emp == pytest.approx(sd[30:270, cols].mean(), rel=0.04)


@pytest.mark.parametrize("rate", [100.0, 10.0])
def test_noise_only_images_stay_under_the_false_alarm_rate(rate):
    """A uniform night-sky image with photon noise: the detections per km²
    are at most the rate (the bound of an exceedance), summed over seeds so
    the Poisson spread is small, and not zero (the bound is not vacuous)."""
    gsd, n = 10.0, 300
    rad = np.full((2, n, n), 2e-8)
    grid = Grid(0.0, 0.0, n, n, gsd)
    area = 4 * n * n * gsd**2 / 1e6
    found = 0
    for seed in range(4):
        img = sensor_image(rad, BANDS, gsd, seed=seed, bit_depth=None)
        var = noise_variance(img, BANDS, gsd, bit_depth=None)[1]
        found += len(detect_lamps(img[1], grid, variance=var,
                                  false_alarms_per_km2=rate).response)  # fmt: skip
    assert found <= rate * area + 3 * math.sqrt(rate * area)
    assert found >= rate * area / 20


def test_a_lamp_above_the_rate_is_found_and_the_threshold_follows_the_noise():
    gsd, n = 10.0, 120
    grid = Grid(0.0, 0.0, n, n, gsd)
    rad = np.full((2, n, n), 2e-8)
    yy, xx = np.mgrid[0:n, 0:n]
    rad = rad + 5e-6 * np.exp(-((yy - 60) ** 2 + (xx - 40) ** 2) / 2.0)[None]
    img = sensor_image(rad, BANDS, gsd, seed=3, bit_depth=None)
    var = noise_variance(img, BANDS, gsd, bit_depth=None)[1]
    det = detect_lamps(img[1], grid, variance=var, false_alarms_per_km2=0.1)
    assert len(det.response) == 1
    np.testing.assert_allclose(det.xy_m[0], [grid.x_m[40], grid.y_m[60]], atol=gsd)
    brighter = detect_lamps(img[1], grid, variance=4 * var, false_alarms_per_km2=0.1)
    assert brighter.threshold == pytest.approx(2 * det.threshold, rel=1e-9)
    with pytest.raises(ValueError, match="both variance"):
        detect_lamps(img[1], grid, variance=var)


def test_noise_variance_is_the_photon_model():
    """Per pixel: the variance of many noisy draws of the same radiance."""
    rad = np.full((2, 40, 40), 5e-8)
    draws = np.stack([sensor_image(rad, BANDS, 10.0, seed=s, bit_depth=None)
                      for s in range(30)])  # fmt: skip
    model = noise_variance(rad, BANDS, 10.0, bit_depth=None)
    np.testing.assert_allclose(draws.var(axis=0).mean(axis=(1, 2)),
                               model.mean(axis=(1, 2)), rtol=0.05)  # fmt: skip


def test_background_is_the_night_sky_plus_moonlit_ground():
    lay = arrangement(
        "single-sided", spacing_m=30.0, mounting_height_m=8.0, length_m=60.0,
        width_m=40.0, lamps=("nist_traditional_hps",),
    )  # fmt: skip
    scene = render(lay, BANDS, dx_m=1.0)
    dark = background_image(scene, BANDS)
    from bandopt.radiometry import background_band_radiance
    from bandopt.spectra import GRID_1NM

    sky = np.asarray(background_band_radiance(BANDS.response(GRID_1NM), GRID_1NM))
    np.testing.assert_allclose(dark, np.broadcast_to(sky[:, None, None], dark.shape))
    moon = background_image(scene, BANDS, moon="full")
    assert np.all(moon > dark)
    # brighter surfaces are brighter under the Moon: the road is asphalt
    ground = moon - dark
    road = ground[:, scene.surface_idx == 0].mean(axis=1)
    verge = ground[:, scene.surface_idx == 2].mean(axis=1)
    assert not np.allclose(road, verge)
    quarter = background_image(scene, BANDS, moon="first_quarter") - dark
    assert np.all(quarter < ground)


def test_the_gsd_study_senses_with_the_recommended_radiometry(tmp_path):
    """The study's bands are the recommended design and its quantiser the
    radiometry's: each band's detection limit and saturation from its own
    row of limits.csv, the recommended linear bit depth; a band set the
    radiometry has no rows for is refused by name."""
    import csv
    import json
    import shutil

    from bandopt.results import recommended_band_set
    from bandopt.spatial import GsdStudy, study_bands, study_sensor

    study = GsdStudy()
    bands = study_bands(study)
    assert bands.names == recommended_band_set("spectral").names
    got = study_sensor(study, bands.names)
    text = Path("results/radiometry/limits.csv").read_text().splitlines()
    rows = {r["band"]: r for r in csv.DictReader(text) if r["band_set"] == "ours"}
    want_sat = [float(rows[b]["saturation_w_m2_sr_nm"]) for b in bands.names]
    np.testing.assert_allclose(got["saturation_w_m2_sr_nm"], want_sat)
    lim = [float(rows[b]["detection_limit_w_m2_sr_nm"]) for b in bands.names]
    np.testing.assert_allclose(got["detection_limit_w_m2_sr_nm"], lim)
    summary = json.loads(Path("results/radiometry/summary.json").read_text())
    assert got["bit_depth"] == summary["bit_depth"]["recommended_linear_bits"]
    folder = tmp_path / "radiometry"
    shutil.copytree("results/radiometry", folder)
    with pytest.raises(ValueError, match="no rows of band set 'ours' for bands"):
        study_sensor(GsdStudy(radiometry=str(folder)), ("B1", "NOPE"))


def test_a_told_background_keeps_moonlit_surface_edges_from_being_lamps():
    """A scene with no lamp light under a full Moon: the edges between road,
    sidewalk and verge are structure, not noise, so the fixed-rate detector
    finds them unless it subtracts the lamp-free ground it is told; then it
    finds nothing, as on the night sky alone."""
    import dataclasses

    from bandopt.spatial import observe

    lay = arrangement(
        "single", spacing_m=30.0, mounting_height_m=8.0, length_m=200.0,
        width_m=100.0, lamps=("nist_traditional_hps",), flux_lm=0.0,
    )  # fmt: skip
    lay = dataclasses.replace(
        lay, lamps=tuple(dataclasses.replace(p, flux_lm=1e-9) for p in lay.lamps)
    )
    scene = render(lay, BANDS, dx_m=1.0)
    bg = background_image(scene, BANDS, moon="full")
    kw = dict(background=bg, false_alarms_per_km2=0.1, detection_band="PAN",
              bit_depth=None, seed=2)  # fmt: skip
    blind = observe(scene, BANDS, 2.0, **kw)
    told = observe(scene, BANDS, 2.0, known_background=True, **kw)
    assert len(blind.detections.response) >= 5
    assert len(told.detections.response) <= 1
