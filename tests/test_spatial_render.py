"""Analytic renderer: closed forms, flux conservation, culling, linearity, layouts."""

import dataclasses
import json
import math

import jax.numpy as jnp
import numpy as np
import pytest

from bandopt.scene import Neighbourhood, class_illuminance_lx
from bandopt.sensor import BandSet
from bandopt.spatial import (
    Grid,
    LampPlacement,
    Layout,
    arrangement,
    cull_radius_m,
    cutoff,
    illuminance_images,
    lamp_arrays,
    layout_from_dict,
    layout_names,
    load_layout,
    point_illuminance_lx,
    read_layout,
    render,
    resolve_flux,
    road_optic,
    scene_grid,
    uplight_images,
)
from bandopt.spatial._render import road_mask_for_class


def _one(lum: str, h=8.0, flux=1000.0, x=20.0, y=0.0, rot=0.0):
    lay = Layout(
        "t",
        (LampPlacement(x, y, h, lum, "nist_traditional_hps", flux, rot),),
        length_m=40.0,
        width_m=40.0,
    )
    return lay, lamp_arrays(lay)


def _points(lamps, lum_tables, xs, ys):
    arr = {
        "x": lamps.x_m,
        "y": lamps.y_m,
        "h": lamps.h_m,
        "flux": lamps.flux_lm,
        "rot": lamps.rotation_rad,
    }
    arr = {k: jnp.asarray(v) for k, v in arr.items()}
    arr["lum"] = jnp.asarray(lamps.luminaire_index)
    return np.asarray(
        point_illuminance_lx(lum_tables, arr, jnp.asarray(xs), jnp.asarray(ys))
    )


def _tables(lamps):
    return jnp.stack([lum.intensity_cd_per_lm for lum in lamps.luminaires])


def test_point_source_closed_form_uniform():
    """E = I cos³θ / h² under a constant-intensity source, I = Φ / 2π."""
    lay, lamps = _one("uniform", h=8.0, flux=1000.0)
    grid = scene_grid(lay, 0.5)
    e = np.asarray(illuminance_images(lamps, grid, cull_fraction=0.0))[0]
    x, y = np.meshgrid(grid.x_m - 20.0, grid.y_m)
    cos = 8.0 / np.sqrt(x**2 + y**2 + 64.0)
    ref = 1000.0 / (2 * math.pi) * cos**3 / 64.0
    # the table is normalised by the trapezoid rule at 0.5° (error ~ Δγ²/12 = 6e-6)
    np.testing.assert_allclose(e, ref, rtol=2e-5)


def test_point_source_closed_form_lambertian():
    """Lambertian I = Φ cos γ / π: E = Φ cos⁴θ / (π h²) (table interpolation
    at 0.5° steps: relative error below 1e-4 away from the horizon)."""
    lay, lamps = _one("lambertian", h=6.0, flux=2000.0)
    grid = scene_grid(lay, 0.5)
    e = np.asarray(illuminance_images(lamps, grid, cull_fraction=0.0))[0]
    x, y = np.meshgrid(grid.x_m - 20.0, grid.y_m)
    cos = 6.0 / np.sqrt(x**2 + y**2 + 36.0)
    ref = 2000.0 / math.pi * cos**4 / 36.0
    np.testing.assert_allclose(e, ref, rtol=1e-4)


@pytest.mark.parametrize("lum", ["road-optic", "lop-10", "lop-50", "cutoff"])
def test_flux_conservation_ground_plus_up_equals_output(lum):
    """∫ E dA over the infinite plane + upward flux = the luminaire's flux.
    The plane is integrated in polar coordinates with r = h tan γ (midpoints in γ
    up to the horizon and in azimuth) through the renderer's own
    point-illuminance function; the upward flux is the luminaire's."""
    h, flux = 7.0, 1000.0
    _, lamps = _one(lum, h=h, flux=flux, rot=0.7)
    n_g = 1800  # midpoints, Δγ = 0.05° (the table is piecewise linear at 0.5°)
    gam = (np.arange(n_g) + 0.5) * (math.pi / 2) / n_g
    wg = np.full(n_g, (math.pi / 2) / n_g)
    phi = (np.arange(180) + 0.5) * 2 * math.pi / 180
    g, p = np.meshgrid(gam, phi)
    r = h * np.tan(g)
    xs, ys = 20.0 + r * np.cos(p), r * np.sin(p)
    e = _points(lamps, _tables(lamps), xs, ys)[0]
    # dA = r dr dφ, dr = h sec²γ dγ
    ground = np.sum(e * r * h / np.cos(g) ** 2 * wg[None, :]) * 2 * math.pi / 180
    up = flux * lamps.luminaires[0].uplight_fraction
    assert ground + up == pytest.approx(
        flux, rel=2e-3
    )  # interpolant vs grid quadrature


def test_flux_conservation_on_the_image_grid():
    """A 70° cut-off lights a disc of radius h tan 70°: the rendered image sums
    to the flux (pixel sum x area) within the discretisation error."""
    lay, lamps = _one("cutoff", h=5.0, flux=1500.0)
    grid = scene_grid(lay, 0.1)
    e = np.asarray(illuminance_images(lamps, grid, cull_fraction=0.0))[0]
    assert e.sum() * 0.1**2 == pytest.approx(1500.0, rel=2e-3)


def test_culling_error_bound_and_tile_independence():
    lay = arrangement(
        "staggered",
        spacing_m=15.0,
        length_m=200.0,
        width_m=60.0,
        luminaire="road-optic",
    )
    lamps = lamp_arrays(lay)
    grid = scene_grid(lay, 0.5)
    ref = np.asarray(illuminance_images(lamps, grid, cull_fraction=0.0)).sum(0)
    f = 1e-3
    cul = np.asarray(illuminance_images(lamps, grid, cull_fraction=f)).sum(0)
    bound = f * np.sum(
        lamps.flux_lm
        * np.array([lu.max_cd_per_lm for lu in lamps.luminaires])[lamps.luminaire_index]
        / lamps.h_m**2
    )
    err = np.abs(ref - cul).max()
    assert 0 < err <= bound
    other = np.asarray(
        illuminance_images(lamps, grid, cull_fraction=f, tile_px=32)
    ).sum(0)
    np.testing.assert_allclose(other, cul, rtol=1e-12, atol=1e-15)
    assert np.isinf(cull_radius_m(8.0, 0.0))
    with pytest.raises(ValueError, match="cull_fraction"):
        cull_radius_m(8.0, 1.5)


def _bands():
    return BandSet.from_edges(
        [(450.0, 520.0), (560.0, 650.0), (780.0, 880.0)], names=["b", "g", "nir"]
    )


def test_band_image_is_the_sum_of_single_lamp_images():
    """Linearity: a mixed-type scene equals the sum of its lamps rendered alone."""
    lamps = (
        LampPlacement(30.0, -2.5, 8.0, "road-optic", "nist_traditional_hps", 8000.0),
        LampPlacement(45.0, 2.5, 10.0, "lop-50", "cie_led_b3", 5000.0, 180.0),
        LampPlacement(52.0, -2.5, 6.0, "lambertian", "nist_traditional_hps", 3000.0),
    )
    lay = Layout("mix", lamps, length_m=80.0, width_m=40.0)
    full = render(lay, _bands(), dx_m=1.0).radiance
    parts = sum(
        render(dataclasses.replace(lay, lamps=(p,)), _bands(), dx_m=1.0).radiance
        for p in lamps
    )
    np.testing.assert_allclose(full, parts, rtol=1e-9, atol=1e-20)
    # doubling one lamp's flux doubles its contribution
    dbl = dataclasses.replace(lamps[0], flux_lm=16000.0)
    a = render(dataclasses.replace(lay, lamps=(dbl,)), _bands(), dx_m=1.0).radiance
    b = render(dataclasses.replace(lay, lamps=(lamps[0],)), _bands(), dx_m=1.0).radiance
    np.testing.assert_allclose(a, 2 * b, rtol=1e-12)


def test_radiance_units_against_hand_computation():
    """Road pixel below a uniform lamp: L = T ρ/π E S averaged over the band,
    computed here with plain numpy from the library and surface data."""
    from bandopt.datasets.lamps import library
    from bandopt.datasets.surfaces import mean_reflectance
    from bandopt.spectra import GRID_1NM

    lay, _ = _one("uniform", h=8.0, flux=1000.0, x=20.125, y=0.375)
    bands = _bands()
    img = render(lay, bands, dx_m=0.25)
    wl = GRID_1NM
    lib = library(wavelength_nm=wl)
    s = lib.values[lib.index("nist_traditional_hps")]
    _, rho = mean_reflectance(["asphalt"], wl)
    resp = np.asarray(bands.response(jnp.asarray(wl)))
    q = np.gradient(wl)
    q[0] = q[-1] = 0.5
    j, i = img.grid.pixel_of(20.125, 0.375)
    # this pixel's centre is exactly below the lamp: E = Φ/(2π h²)
    e0 = 1000.0 / (2 * math.pi * 64.0)
    ref = (resp * q) @ (rho[0] / math.pi * e0 * s) / (resp * q).sum(-1)
    direct = 0.0  # uniform: no uplight
    # 2e-5: trapezoid normalisation of the table (see the closed-form test)
    np.testing.assert_allclose(img.radiance[:, j, i], ref + direct, rtol=2e-5)


def test_rendered_band_values_are_forwards_of_the_pixel_spectra():
    """The renderer measures through `bandopt.forward`: each pixel's band
    values equal `forward.band_radiance` of its TOA spectrum, assembled here
    pixel by pixel from the per-type illuminance and uplight images, the lamp
    spectra, the surface under it and the 6S upward transmittance."""
    from bandopt import forward
    from bandopt.datasets import atmosphere as atm
    from bandopt.datasets.lamps import library
    from bandopt.datasets.surfaces import mean_reflectance
    from bandopt.spatial import SURFACE_ROLES
    from bandopt.spectra import GRID_1NM

    lamps = (
        LampPlacement(30.0, -2.5, 8.0, "road-optic", "nist_traditional_hps", 8000.0),
        LampPlacement(52.0, 2.5, 10.0, "lop-50", "cie_led_b3", 5000.0, 180.0),
    )
    lay = Layout("mix", lamps, length_m=80.0, width_m=40.0)
    sky = ("tropical", "urban", 5.0)
    bands = _bands()
    img = render(lay, bands, dx_m=1.0, atmosphere=sky, neighbourhood="uniform")
    cull = img.config["cull_fraction"]
    e = np.asarray(illuminance_images(img.lamps, img.grid, cull_fraction=cull))
    up = uplight_images(img.lamps, img.grid)
    wl = np.asarray(GRID_1NM, float)
    lib = library(wavelength_nm=wl)
    s = np.stack([lib.values[lib.index(t)] for t in img.lamps.lamp_types])
    _, rho = mean_reflectance([lay.surface_map[r] for r in SURFACE_ROLES], wl)
    t_up = atm.transmittance("up", *sky, 0.0, wl)
    # every lamp's own pixel (uplight), and pixels on each surface
    lit = np.argwhere(up.sum(axis=0) > 0)
    rows = np.argwhere(img.surface_idx[:, :1] >= 0)[::7, 0]
    cols = np.full(rows.size, 30)
    j = np.concatenate([lit[:, 0], rows])
    i = np.concatenate([lit[:, 1], cols])
    assert set(img.surface_idx[j, i]) == {0, 1, 2}
    ground = (e[:, j, i].T @ s) * rho[img.surface_idx[j, i]] / math.pi
    spectra = t_up * (ground + up[:, j, i].T @ s)  # (pixels, w)
    ref = np.asarray(forward.band_radiance(spectra, bands, wavelength_nm=wl))
    np.testing.assert_allclose(img.radiance[:, j, i].T, ref, rtol=1e-12)


def test_uplight_goes_into_the_lamp_pixel():
    lay, lamps = _one("lop-50", h=8.0, flux=1000.0, x=20.1, y=0.1)
    grid = scene_grid(lay, 0.5)
    up = uplight_images(lamps, grid)[0]
    j, i = grid.pixel_of(20.1, 0.1)
    assert np.count_nonzero(up) == 1
    # isotropic 50 % uplight: I(180°) = Φ / 4π, spread over the pixel area
    assert up[j, i] == pytest.approx(1000.0 / (4 * math.pi) / 0.25, rel=1e-3)


def test_flux_from_lighting_class():
    lay = arrangement(
        "single-sided",
        spacing_m=30.0,
        length_m=300.0,
        width_m=60.0,
        flux_lm=None,
        lighting_class="M3",
    )
    lamps = resolve_flux(lay)
    assert np.all(lamps.flux_lm > 1000) and np.ptp(lamps.flux_lm) == 0
    # an independent check on the scene grid at 0.1 m (road 7 m = 70 rows)
    grid = scene_grid(lay, 0.1)
    e = np.asarray(illuminance_images(lamps, grid)).sum(0)
    mask = road_mask_for_class(lay, lamps, grid)
    assert mask.sum(0).max() == 70
    assert e[mask].mean() == pytest.approx(class_illuminance_lx("M3"), rel=2e-3)


def test_shipped_layouts_load_and_render_small():
    names = layout_names()
    assert {"single", "single-sided", "staggered", "opposite", "central-twin"} <= set(
        names
    )
    for n in names:
        lay = load_layout(n)
        assert len(lay.lamps) >= 1
    mixed = load_layout("Mixed_LED_HPS")
    assert len({p.lamp for p in mixed.lamps}) == 3
    small = dataclasses.replace(mixed, length_m=100.0, width_m=20.0)
    img = render(small, _bands(), dx_m=1.0)
    assert np.all(np.isfinite(img.radiance)) and img.radiance.max() > 0


def test_arrangements_geometry():
    for kind, per in [("single-sided", 1), ("opposite", 2), ("central-twin", 2)]:
        lay = arrangement(kind, spacing_m=25.0, length_m=400.0)
        xs = np.unique([p.x_m for p in lay.lamps])
        assert np.allclose(np.diff(xs), 25.0)
        assert len(lay.lamps) == per * xs.size
    st = arrangement("staggered", spacing_m=30.0, length_m=400.0)
    ys = np.array([p.y_m for p in st.lamps])
    xs = np.array([p.x_m for p in st.lamps])
    assert np.allclose(np.diff(xs), 15.0) and np.all(ys[:-1] * ys[1:] < 0)


@pytest.mark.parametrize(
    "data, message",
    [
        (
            {"arrangement": {"kind": "zigzag", "flux_lm": 1.0}},
            r"arrangement: field 'kind'",
        ),
        (
            {"arrangement": {"spacing_m": 30, "flux_lm": 1.0}},
            r"field 'kind' is missing",
        ),
        (
            {"arrangement": {"kind": "row", "spacing_m": "x", "flux_lm": 1.0}},
            r"field 'spacing_m' must be a number",
        ),
        ({"arrangement": {"kind": "row"}}, r"give 'flux_lm' or 'lighting_class'"),
        (
            {"lamp": [{"x_m": 1, "y_m": 0, "flux_lm": 5.0}]},
            r"lamp\[0\]: field 'mounting_height_m' is missing",
        ),
        (
            {"lamp": [{"x_m": 1, "y_m": 0, "mounting_height_m": 8, "colour": 1}]},
            r"lamp\[0\]: unknown field\(s\) \['colour'\]",
        ),
        (
            {"road_width_m": -3, "arrangement": {"kind": "row", "flux_lm": 1.0}},
            r"field 'road_width_m' must be > 0",
        ),
        (
            {
                "surfaces": {"road": "lava"},
                "arrangement": {"kind": "row", "flux_lm": 1.0},
            },
            r"surfaces.road: Unknown surface",
        ),
        (
            {"lighting_class": "Z9", "arrangement": {"kind": "row"}},
            r"field 'lighting_class': Unknown lighting class",
        ),
        ({}, r"no lamps"),
    ],
)
def test_layout_errors_name_file_and_field(tmp_path, data, message):
    p = tmp_path / "bad.json"
    p.write_text(json.dumps(data))
    with pytest.raises(ValueError, match=r"bad\.json: (arrangement: )?" + message):
        read_layout(p)


def test_layout_toml_roundtrip_and_relative_luminaire_path(tmp_path):
    from pathlib import Path

    src = Path(__file__).resolve().parents[1] / "bandopt/spatial/data/synthetic"
    (tmp_path / "lum.ldt").write_bytes((src / "batwing_isym4.ldt").read_bytes())
    (tmp_path / "lay.toml").write_text(
        'name = "mine"\nlength_m = 60.0\nwidth_m = 30.0\n'
        "[[lamp]]\nx_m = 30.0\ny_m = 0.0\nmounting_height_m = 5.0\n"
        'luminaire = "lum.ldt"\nlamp = "cie_led_b1"\nflux_lm = 2000.0\n'
    )
    lay = read_layout(tmp_path / "lay.toml")
    img = render(lay, _bands(), dx_m=0.5)
    assert img.layout.name == "mine" and img.radiance.max() > 0
    bad = tmp_path / "broken.toml"
    bad.write_text("name = \n")
    with pytest.raises(ValueError, match=r"broken\.toml: cannot parse"):
        read_layout(bad)
    assert layout_from_dict({"arrangement": {"kind": "single", "flux_lm": 1e3}}).lamps


def test_grid_pixel_lookup():
    g = Grid(0.0, -5.0, 10, 10, 1.0)
    j, i = g.pixel_of(np.array([0.2, 9.9]), np.array([-4.9, 4.9]))
    assert list(i) == [0, 9] and list(j) == [0, 9]


def test_road_optic_throws_along_the_road():
    """The road optic lights the road more along x than across it."""
    lay = Layout(
        "t",
        (LampPlacement(50.0, -2.5, 8.0, "road-optic", "nist_traditional_hps", 1000.0),),
        length_m=100.0,
        width_m=100.0,
    )
    lamps = lamp_arrays(lay)
    along = _points(lamps, _tables(lamps), np.array([70.0]), np.array([-2.5]))[0, 0]
    across = _points(lamps, _tables(lamps), np.array([50.0]), np.array([17.5]))[0, 0]
    behind = _points(lamps, _tables(lamps), np.array([50.0]), np.array([-22.5]))[0, 0]
    assert along > across > behind
    assert road_optic().uplight_fraction == pytest.approx(0.0, abs=1e-12)
    assert cutoff(60.0).uplight_fraction == pytest.approx(0.0, abs=1e-12)


def test_adjacency_split_and_the_uniform_neighbourhood():
    """With an atmosphere a pixel sees its own ground through T_dir and k times
    the tile's mean through T_dif; "uniform" is the total-transmittance image
    of earlier versions, "isolated" the direct part alone."""
    lamps = (
        LampPlacement(30.0, -2.5, 8.0, "road-optic", "nist_traditional_hps", 8000.0),
        LampPlacement(52.0, 2.5, 10.0, "lop-50", "cie_led_b3", 5000.0, 180.0),
    )
    lay = Layout("mix", lamps, length_m=80.0, width_m=40.0)
    atm = ("tropical", "urban", 5.0)
    kw = dict(dx_m=1.0, atmosphere=atm)
    uni = render(lay, _bands(), neighbourhood="uniform", **kw).radiance
    iso = render(lay, _bands(), neighbourhood="isolated", **kw).radiance
    lit = render(lay, _bands(), **kw)
    none = render(lay, _bands(), dx_m=1.0, atmosphere=None).radiance
    assert lit.config["neighbourhood"]["name"] == "lit_street_dark_district"
    # uniform - isolated = (T_up - T_dir) L(x) = T_dif L(x)
    diffuse = uni - iso
    assert np.all(diffuse >= 0) and np.any(diffuse > 0)
    np.testing.assert_allclose(
        lit.radiance, iso + 0.1 * diffuse.mean(axis=(1, 2), keepdims=True), rtol=1e-9
    )
    # the adjacency term blurs: lit pixels lose, dark pixels gain against uniform
    peak = np.unravel_index(np.argmax(none[0]), none[0].shape)
    assert lit.radiance[0][peak] < uni[0][peak]
    dark = np.unravel_index(np.argmin(none[0]), none[0].shape)
    assert lit.radiance[0][dark] >= iso[0][dark]
    # the diffuse part is largest in the blue (Rayleigh): 6S total/direct
    ratio = uni.sum(axis=(1, 2)) / iso.sum(axis=(1, 2))
    assert ratio[0] > ratio[1] > ratio[2] > 1.0
    with pytest.raises(ValueError, match="background surface"):
        render(lay, _bands(), neighbourhood=Neighbourhood(0.1, 1.0, "snow"), **kw)
