"""Scenario sets: the factorised contraction equals the term-by-term spectrum."""

import math

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from bandopt import scene
from bandopt.scene import (
    band_terms,
    band_weights,
    build_scenarios,
    class_illuminance_lx,
    full_toa_radiance,
    lamp_scenes,
    moon_scenes,
)


LAMPS = (
    "nist_traditional_hps",
    "nist_traditional_lps",
    "cie_led_b3",
    "li1800_osram_hqit_400w",
)


@pytest.fixture(scope="module")
def scen():
    return build_scenarios(
        lamps=LAMPS,
        surfaces=("asphalt", "grass", "snow"),
        atmospheres=(("midlatitude_summer", "urban", 23.0), "none"),
        moons=(None, "full"),
        classes=("P1", "M4", "C0"),
        uplight_ratio=0.1,
        fire_temperatures_k=(900.0,),
    )


def _weights(w, centres=(450.0, 560.0, 660.0, 820.0), fwhm=(40.0, 80.0, 50.0, 60.0)):
    x = 2 * (w[None, :] - jnp.asarray(centres)[:, None]) / jnp.asarray(fwhm)[:, None]
    return band_weights(jnp.exp2(-(jnp.abs(x) ** 6)), w)


def test_classes_and_m_conversion():
    assert class_illuminance_lx("P1") == 15.0
    assert class_illuminance_lx("c0") == 50.0
    assert class_illuminance_lx("M1") == pytest.approx(2.0 / 0.07)
    assert class_illuminance_lx("M1", q0_per_sr=0.10) == pytest.approx(20.0)
    with pytest.raises(ValueError, match="expected one of"):
        class_illuminance_lx("Q7")


def test_contraction_equals_term_by_term(scen):
    w = scen.factors.wavelength_nm
    weights = _weights(w)
    full = lamp_scenes(band_terms(scen.factors, weights))
    assert full.shape == (*scen.shape, 4)
    rng = np.random.default_rng(0)
    for _ in range(20):
        idx = [int(rng.integers(n)) for n in scen.shape]
        spectrum = full_toa_radiance(scen.factors, *idx)
        np.testing.assert_allclose(full[tuple(idx)], weights @ spectrum, rtol=1e-12)


def test_linear_in_illuminance_and_lamp(scen):
    f = scen.factors
    weights = _weights(f.wavelength_nm)
    t = band_terms(f, weights)
    twice = band_terms(
        scene.Factors(
            f.wavelength_nm,
            2 * f.lamp,
            f.reflectance,
            f.t_up,
            f.moon_ground,
            f.path,
            f.illuminance_lx,
            f.uplight,
            f.fire,
        ),
        weights,
    )
    np.testing.assert_allclose(twice.lamp_surface, 2 * t.lamp_surface, rtol=1e-13)
    # Without Moon, radiance is proportional to the class illuminance.
    moonless = lamp_scenes(t)[:, :, :, 0]
    ratio = moonless[..., 0, :] / moonless[..., 2, :]
    ok = moonless[..., 2, :] > 0
    np.testing.assert_allclose(ratio[ok], 15.0 / 50.0, rtol=1e-12)


def test_absent_terms_cost_nothing():
    s = build_scenarios(
        lamps=LAMPS[:2],
        surfaces=("asphalt",),
        atmospheres=("none",),
        moons=(),
        classes=("P1",),
    )
    assert s.factors.moon_ground is None and s.factors.path is None
    assert s.factors.uplight is None and s.factors.fire is None
    t = band_terms(s.factors, _weights(s.factors.wavelength_nm))
    assert t.moon is None and t.path is None and t.uplight is None and t.fire is None
    with pytest.raises(ValueError, match="no Moon"):
        moon_scenes(t)
    # No atmosphere: T = 1, so band radiance = ρ/π E S exactly.
    f = s.factors
    expected = _weights(f.wavelength_nm) @ (
        f.reflectance[0] / math.pi * 15.0 * f.lamp[0]
    )
    np.testing.assert_allclose(lamp_scenes(t)[0, 0, 0, 0, 0], expected, rtol=1e-12)


def test_atmosphere_and_moon_physics(scen):
    t = band_terms(scen.factors, _weights(scen.factors.wavelength_nm))
    full = lamp_scenes(t)
    atm, none = 0, 1
    # The atmosphere dims the lamp signal; moonlight adds a positive signal.
    assert np.all(full[:, :, atm, 0] <= full[:, :, none, 0] + 1e-30)
    assert np.all(full[:, :, :, 1] >= full[:, :, :, 0])
    moon = moon_scenes(t)
    assert np.all(moon[:, :, 1] > 0)
    # Path radiance exists only with an atmosphere and a Moon.
    assert np.all(t.path[none] == 0) and np.all(t.path[atm, 1] > 0)
    # Snow (bright) reflects more moonlight than asphalt.
    assert np.all(moon[2, :, 1] > moon[0, :, 1])


def test_uplight_term(scen):
    t = band_terms(scen.factors, _weights(scen.factors.wavelength_nm))
    u = 0.1
    assert scen.factors.uplight == pytest.approx(u / (1 - u) / math.pi)
    # Uplight does not depend on the surface.
    assert t.uplight.shape == (len(LAMPS), 2, 4)


def test_fire_scene_is_planck(scen):
    f = scen.factors
    w = np.asarray(f.wavelength_nm)
    h, c, k = 6.62607015e-34, 2.99792458e8, 1.380649e-23
    lam = w * 1e-9
    b = 2 * h * c**2 / lam**5 / np.expm1(h * c / (lam * k * 900.0)) * 1e-9
    np.testing.assert_allclose(f.fire[0], 0.01 * 0.9 * b, rtol=1e-10)


def test_crop_keeps_band_radiance(scen):
    f = scen.factors
    centres, fwhm = (540.0, 600.0), (30.0, 40.0)
    full = band_terms(f, _weights(f.wavelength_nm, centres, fwhm)).lamp_surface
    # Super-Gaussian k=6 at 1.2 FWHM from the centre is below 1e-12 of the peak.
    cropped = f.crop(540.0 - 36.0, 600.0 + 48.0)
    got = band_terms(
        cropped, _weights(cropped.wavelength_nm, centres, fwhm)
    ).lamp_surface
    assert cropped.wavelength_nm.size < f.wavelength_nm.size / 3
    np.testing.assert_allclose(got, full, rtol=1e-9)


def test_gradient_through_contraction_matches_fd(scen):
    f = scen.factors

    def loss(centre):
        x = 2 * (f.wavelength_nm[None, :] - centre[:, None]) / 40.0
        wts = band_weights(jnp.exp2(-(jnp.abs(x) ** 6)), f.wavelength_nm)
        lb = lamp_scenes(band_terms(f, wts))
        return jnp.sum(jnp.log(lb[..., 0] / lb[..., 1]) ** 2)

    c0 = jnp.array([560.0, 610.5])
    g = jax.grad(loss)(c0)
    eps = 1e-4
    for i in range(2):
        e = jnp.zeros(2).at[i].set(eps)
        fd = (loss(c0 + e) - loss(c0 - e)) / (2 * eps)
        assert abs(g[i] - fd) <= 1e-5 * (abs(g[i]) + abs(fd) + 1.0)


def test_bad_inputs():
    with pytest.raises(ValueError, match="uplight_ratio"):
        build_scenarios(lamps=LAMPS[:1], uplight_ratio=0.7, moons=())
    with pytest.raises(ValueError, match="Unknown lamp id"):
        build_scenarios(lamps=("no_such_lamp",), moons=())
