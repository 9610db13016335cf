"""Photon noise model (thesis Eqs. 2.16-2.19, Table 2.3) and quantisation."""

import math

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from bandopt.sensor import (
    BandSet,
    SensorParams,
    add_photon_noise,
    dequantise,
    ground_track_speed_m_s,
    noise_electrons,
    noise_equivalent_radiance,
    quantise,
    quantise_ste,
    radiance_from_electrons,
    radiance_step,
    responsivity,
    signal_electrons,
    snr,
)


# Thesis Table 2.3, with the published values of its own inputs (CODATA h, c)
L_TABLE = 2.5e-6  # W m-2 sr-1 nm-1 (= 250 nW cm-2 sr-1 um-1)
H, C = 6.62607015e-34, 299792458.0
WL = jnp.arange(380.0, 900.01, 0.25)  # fine grid: the k=50 edges need it


def _table_2_3_electrons(area_nm):
    """Eq. 2.18 by hand: L Δλ A π τ η t λ / ((4 N² + 1) h c), Δλ = band area."""
    a_det = (7e-6) ** 2 * 0.95
    t_eff = 2.2e-4 * 256
    return (
        L_TABLE
        * area_nm
        * a_det
        * math.pi
        * 0.8
        * 0.85
        * t_eff
        * 560e-9
        / ((4 * 2.5**2 + 1) * H * C)
    )


def test_table_2_3_reproduction():
    params = SensorParams()
    # the thesis's listed intermediate values
    np.testing.assert_allclose(params.detector_area_m2, 4.66e-11, rtol=2e-3)
    np.testing.assert_allclose(params.effective_integration_time_s, 5.63e-2, rtol=1e-3)
    np.testing.assert_allclose(params.projected_solid_angle_sr, 1.21e-1, rtol=2e-3)
    # a nearly rectangular 100 nm band at 560 nm (k = 50), flat spectrum
    band = BandSet.from_physical([560.0], [100.0], [50.0])
    n = signal_electrons(jnp.full(WL.shape, L_TABLE), band.response(WL), WL, params)
    area = float(band.area_nm()[0])  # 99.6 nm: k = 50 is not quite a rectangle
    np.testing.assert_allclose(n, _table_2_3_electrons(area), rtol=1e-6)
    rect = float(n[0]) * 100.0 / area
    assert abs(rect - 152.0) < 0.5  # "about 152"
    shot = float(noise_electrons(jnp.asarray(rect), params))
    assert abs(shot - 12.3) < 0.05
    # the printed 160 e- / 12.6 e- leave out the fill factor
    assert abs(rect / 0.95 - 160.0) < 0.5
    assert abs(math.sqrt(rect / 0.95) - 12.6) < 0.05


def test_ner_and_snr_match_equation_2_19_for_shot_noise():
    params = SensorParams()
    band = BandSet.from_physical([560.0], [100.0], [50.0])
    r = band.response(WL)
    n = signal_electrons(jnp.full((1, WL.shape[0]), L_TABLE), r, WL, params)
    resp = responsivity(r, WL, params)
    area = float(band.area_nm()[0])
    k_geo = (7e-6) ** 2 * 0.95 * math.pi * 0.8 * 0.85 * 2.2e-4 * 256 / (26 * H * C)
    ner_2_19 = math.sqrt(L_TABLE / (area * 560e-9 * k_geo))
    np.testing.assert_allclose(
        noise_equivalent_radiance(n, resp, params), [[ner_2_19]], rtol=1e-6
    )
    np.testing.assert_allclose(snr(n, params), jnp.sqrt(n), rtol=1e-12)
    # a flat spectrum: electrons / responsivity is the radiance itself
    np.testing.assert_allclose(
        radiance_from_electrons(n, resp), [[L_TABLE]], rtol=1e-12
    )


def test_signal_is_the_spectral_integral_not_centre_times_fwhm():
    """A spectrum rising across a wide band weights red photons by λ/hc."""
    params = SensorParams()
    band = BandSet.from_physical([640.0], [400.0], [6.0])
    r = band.response(WL)
    ramp = 1e-6 * (np.asarray(WL) / 640.0)
    q = np.asarray(r[0]) * np.gradient(np.asarray(WL))  # independent weights
    expected = (
        params.etendue_time_m2_sr_s
        * 0.85
        / (H * C)
        * np.sum(ramp * q * np.asarray(WL) * 1e-9)
    )
    got = signal_electrons(jnp.asarray(ramp), r, WL, params)[0]
    np.testing.assert_allclose(got, expected, rtol=1e-4)  # trapezoid vs gradient ends
    qe = jnp.where(WL < 640.0, 0.9, 0.3)
    lower = signal_electrons(jnp.asarray(ramp), r, WL, params, quantum_efficiency=qe)
    assert float(lower[0]) < float(got)


def test_noise_terms_add_in_quadrature():
    params = SensorParams(read_noise_e=5.0, dark_current_e_s=10.0)
    s = jnp.asarray([0.0, 100.0, 1e4])
    dark = 10.0 * 2.2e-4 * 256
    expected = np.sqrt(np.asarray(s) + dark + 25.0 + 3.0**2 / 12)
    np.testing.assert_allclose(
        noise_electrons(s, params, electrons_per_dn=3.0), expected
    )
    zero = SensorParams()
    g = jax.grad(lambda x: noise_electrons(x, zero) + snr(x, zero))(0.0)
    assert np.isfinite(float(g))


def test_integration_time_from_gsd():
    p = SensorParams.for_gsd(50.0, ground_speed_m_s=7000.0, tdi_stages=64)
    np.testing.assert_allclose(p.integration_time_s, 50.0 / 7000.0)
    assert p.tdi_stages == 64
    # circular orbit at 600 km: orbital 7.56 km/s scaled to the ground track
    v = float(ground_track_speed_m_s(600e3))
    assert 6.85e3 < v < 6.95e3
    with pytest.raises(ValueError, match="gsd_m"):
        SensorParams.for_gsd(-1.0)


@pytest.mark.parametrize("method", ["gaussian", "poisson"])
def test_photon_noise_statistics_and_reproducibility(method):
    params = SensorParams(read_noise_e=2.0)
    s = jnp.full((40000,), 150.0)
    a = add_photon_noise(jax.random.key(7), s, params, method=method)
    b = add_photon_noise(jax.random.key(7), s, params, method=method)
    c = add_photon_noise(jax.random.key(8), s, params, method=method)
    np.testing.assert_array_equal(a, b)
    assert not np.array_equal(np.asarray(a), np.asarray(c))
    var = 150.0 + 4.0
    se_mean = math.sqrt(var / s.size)
    assert abs(float(a.mean()) - 150.0) < 5 * se_mean
    assert abs(float(a.var()) / var - 1) < 5 * math.sqrt(2 / s.size)
    with pytest.raises(ValueError, match="expected one of"):
        add_photon_noise(jax.random.key(0), s, params, method="uniform")


def test_quantisation_monotone_clipped_and_inverse():
    lo, hi, bits = 2.5e-7, 2.5e-3, 10
    rad = jnp.sort(
        jnp.concatenate(
            [
                jnp.asarray([0.0, lo, hi, 1.0]),
                10
                ** jax.random.uniform(jax.random.key(1), (2000,), minval=-8, maxval=-2),
            ]
        )
    )
    dn = quantise(rad, lo, hi, bits)
    assert bool(jnp.all(jnp.diff(dn) >= 0))
    assert float(dn.min()) == 0.0 and float(dn.max()) == 1023.0
    assert float(quantise(jnp.asarray(lo / 2), lo, hi, bits)) == 0.0
    assert float(quantise(jnp.asarray(hi * 2), lo, hi, bits)) == 1023.0
    inside = (rad >= lo) & (rad <= hi)
    back = dequantise(dn, lo, hi, bits)
    step = float(radiance_step(lo, hi, bits))
    assert bool(
        jnp.all(jnp.where(inside, jnp.abs(back - rad) <= 0.5 * step + 1e-18, True))
    )
    # integer values, independent formula
    ref = np.clip(np.round((np.asarray(rad) - lo) * 1023 / (hi - lo)), 0, 1023)
    np.testing.assert_array_equal(dn, ref)
    with pytest.raises(ValueError, match="bit_depth"):
        quantise(rad, lo, hi, 0)
    with pytest.raises(ValueError, match="saturation"):
        quantise(rad, hi, lo, 8)


def test_straight_through_gradient():
    lo, hi, bits = 0.0, 1.0, 8
    x = jnp.asarray([-0.5, 0.3, 0.61, 2.0])
    np.testing.assert_array_equal(
        quantise_ste(x, lo, hi, bits), quantise(x, lo, hi, bits)
    )
    g = jax.vmap(jax.grad(lambda v: quantise_ste(v, lo, hi, bits)))(x)
    np.testing.assert_allclose(g, [0.0, 255.0, 255.0, 0.0])
