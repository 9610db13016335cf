"""`bandopt.radiometry`: background floor, distributions, the limit rule,
SNR/NER, quantisers (thesis sections 2.5.2-2.5.3 and 4.2)."""

import math

import jax.numpy as jnp
import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from bandopt.forward import cropped, simulate
from bandopt.radiometry import (
    LimitRule,
    LinearQuantiser,
    SqrtQuantiser,
    TwoGainQuantiser,
    apply_change,
    background_band_radiance,
    electrons_for_snr,
    f_number_for,
    instrument_changes,
    make_quantiser,
    night_sky_radiance,
    radiance_groups,
    radiance_percentiles,
    recommend_limits,
    snr_ner,
)
from bandopt.scene import build_scenarios, moon_scenes, planck_radiance
from bandopt.sensor import BandSet, SensorParams, dequantise, quantise, snr
from bandopt.spectra import GRID_1NM


@pytest.fixture(scope="module")
def scen():
    from bandopt.datasets.lamps import library

    lib = library().select(scored_only=True)
    by_type = {}
    for r in lib.records:  # one lamp of a few distinct types
        by_type.setdefault(r.level2, r.id)
    ids = list(by_type.values())[:4]
    return build_scenarios(
        lamps=ids,
        surfaces=("asphalt", "sidewalk"),
        atmospheres=("none",),
        moons=(None, "full"),
        classes=("P6", "C0"),
        uplight_ratio=0.05,
        fire_temperatures_k=(800.0, 1200.0),
    )


@pytest.fixture(scope="module")
def bands():
    return BandSet.from_edges(
        [(430, 520), (520, 615), (615, 900)], 6.0, names=["blue", "green", "red"]
    )


@pytest.fixture(scope="module")
def groups(scen, bands):
    return radiance_groups(scen, bands)


# ------------------------------------------------------------------------------
# background floor


def test_night_sky_luminance_matches_published_conversion():
    """Luminance of the floor spectrum against the standard conversion of V
    surface brightness, L = 10.8e4 · 10^(-0.4 m_V) cd m⁻² (Garstang 1989; used
    by sky-quality meters). Bandpasses of V and V(λ) differ: 15 % tolerance."""
    from colour.colorimetry import SDS_LEFS_PHOTOPIC

    v = SDS_LEFS_PHOTOPIC["CIE 1924 Photopic Standard Observer"]
    w = np.arange(380.0, 781.0)
    vl = np.interp(w, v.wavelengths, v.values)
    lum = 683.0 * np.trapezoid(np.asarray(night_sky_radiance(w)) * vl, w)
    ref = 10.8e4 * 10 ** (-0.4 * 21.6)
    assert lum == pytest.approx(ref, rel=0.15)


def test_background_order_of_magnitude_and_band_average():
    w = jnp.asarray(GRID_1NM)
    sky = np.asarray(night_sky_radiance(w))
    assert np.all((sky > 1e-9) & (sky < 1e-8))  # literature: a few 1e-9
    assert np.all(np.diff(sky[w > 438]) >= 0)  # rising into the OH bands
    narrow = BandSet.from_physical([545.0], [15.0], [6.0])
    bb = background_band_radiance(narrow.response(w), w)
    assert float(bb[0]) == pytest.approx(
        float(night_sky_radiance(jnp.asarray([545.0]))[0]), rel=0.02
    )
    # linear in scale
    assert float(background_band_radiance(narrow.response(w), w, scale=2.0)[0]) == (
        pytest.approx(2 * float(bb[0]))
    )


def test_background_rejects_bad_scale():
    with pytest.raises(ValueError, match="scale"):
        night_sky_radiance(GRID_1NM, scale=0.0)


# ------------------------------------------------------------------------------
# distributions


def test_groups_recombine_to_forward_model(scen, bands, groups):
    """Reflected lamp light + direct uplight = `bandopt.forward.simulate`."""
    sim = simulate(scen, bands).radiance
    up = groups.uplight[:, None, :, None, :, :]
    np.testing.assert_allclose(groups.lamp + up, sim, rtol=1e-12)


def test_moon_and_fire_groups(scen, bands, groups):
    f, resp = cropped(scen, bands)
    from bandopt.scene import band_terms, band_weights

    terms = band_terms(f, band_weights(resp, f.wavelength_nm))
    ms = np.asarray(moon_scenes(terms))
    np.testing.assert_allclose(
        groups.moon, ms[:, :, 1:, :]
    )  # the moonless state dropped
    assert np.all(ms[:, :, 0, :] == 0)
    # fire: f ε B(T) band-averaged with numpy trapezoid (no atmosphere: T = 1)
    w = np.asarray(f.wavelength_nm)
    b = (
        0.01
        * 0.9
        * np.asarray(planck_radiance(jnp.asarray(w), jnp.asarray([1200.0])))[0]
    )
    r = np.asarray(resp)
    ref = np.trapezoid(b * r, w, axis=-1) / np.trapezoid(r, w, axis=-1)
    np.testing.assert_allclose(groups.fire[1, 0], ref, rtol=1e-9)


def test_percentiles_order_and_extremes(groups):
    p = radiance_percentiles(groups.lamp)
    assert np.all(np.diff(p, axis=0) >= 0)
    flat = groups.flat("lamp")
    np.testing.assert_array_equal(p[0], flat.min(0))
    np.testing.assert_array_equal(p[-1], flat.max(0))
    with pytest.raises(ValueError, match="NaN"):
        radiance_percentiles(np.array([[1.0, np.nan]]))


def test_dim_scenes_by_hand(scen, groups):
    """Dimmest class (P6), moonless, darkest surface per band and lamp."""
    c = list(scen.class_labels).index("P6")
    m = list(scen.moon_labels).index("none")
    ref = groups.lamp[:, :, 0, m, c, :].min(axis=1)
    np.testing.assert_array_equal(groups.dim_scenes(), ref)


# ------------------------------------------------------------------------------
# the limit rule


def _lim(scen, bands, groups, params, rule):
    f, resp = cropped(scen, bands)
    return recommend_limits(groups, resp, f.wavelength_nm, params, rule)


@pytest.mark.parametrize("q", [0.0, 25.0, 50.0])
def test_limits_meet_rule(scen, bands, groups, q):
    params = SensorParams()
    rule = LimitRule(dim_percentile=q, headroom=1.5)
    lim = _lim(scen, bands, groups, params, rule)
    dim = groups.dim_scenes()
    # at most q % of the dim lamp scenes fall below the requirement
    assert np.all(np.mean(dim < lim.scene_requirement[None], axis=0) <= q / 100 + 1e-12)
    assert np.all(lim.detection_limit >= lim.background)
    assert np.all(lim.detection_limit >= lim.scene_requirement)
    assert np.all(
        (lim.detection_limit == lim.background)
        | (lim.detection_limit == lim.scene_requirement)
    )
    # saturation: 1.5 x above every bright scene (lamp + uplight), fires apart
    bright = (groups.lamp + groups.uplight[:, None, :, None, :, :]).reshape(-1, 3)
    np.testing.assert_allclose(lim.saturation, 1.5 * bright.max(0))
    np.testing.assert_allclose(
        lim.fire_fraction_saturated, (groups.flat("fire") > lim.saturation).mean(0)
    )
    # a sensor with `exposure_factor` times the integration time reaches the target
    for j in range(3):
        p2 = SensorParams(
            integration_time_s=params.integration_time_s * lim.exposure_factor[j]
        )
        n = lim.detection_limit[j] * lim.responsivity_e[j] * lim.exposure_factor[j]
        assert float(snr(n, p2)) == pytest.approx(rule.snr_target, rel=1e-9)


def test_sensor_limited_rule_reaches_target(scen, bands, groups):
    params = SensorParams(read_noise_e=5.0, dark_current_e_s=20.0)
    for k in (3.0, 10.0, 30.0):
        lim = _lim(
            scen, bands, groups, params, LimitRule(snr_target=k, sensor_limited=True)
        )
        assert np.all(lim.snr_at_limit >= k * (1 - 1e-9))
        assert np.all(lim.meets_snr_target)
        sensor = lim.limited_by.count("sensor_snr")
        if sensor:
            hit = np.array(lim.limited_by) == "sensor_snr"
            np.testing.assert_allclose(lim.snr_at_limit[hit], k, rtol=1e-9)


def test_each_instrument_change_reaches_the_snr_target_and_no_less_does(
    scen, bands, groups
):
    """`instrument_changes`: each single-knob change, applied to the sensor,
    brings every band's exposure factor to <= 1 at its detection limit, and
    the same change 1 % smaller leaves the limiting band short; an f-number
    beyond f/0.5 is refused, not offered."""
    params = SensorParams()
    rule = LimitRule(snr_target=40.0)
    lim = _lim(scen, bands, groups, params, rule)
    ch = instrument_changes(params, lim.exposure_factor, lim.band_names)
    assert not ch["met"] and ch["exposure_factor"] == pytest.approx(
        lim.exposure_factor.max()
    )
    j = lim.band_names.index(ch["limiting_band"])
    assert ch["gsd_m"] == pytest.approx(
        float(params.integration_time_s) * 6.9e3, rel=0.02
    )  # 600 km orbit, ~6.9 km/s
    for knob, c in ch["changes"].items():
        if c["needed"] is None:
            continue
        p2, extra = apply_change(params, knob, c["needed"])
        f2 = _lim(scen, bands, groups, p2, rule).exposure_factor / extra
        assert np.all(f2 <= 1 + 1e-6), knob
        if knob in ("pixel_pitch_m", "f_number"):  # continuous: 1 % less falls short
            less = c["needed"] * (0.99 if knob == "pixel_pitch_m" else 1.01)
            p3, extra = apply_change(params, knob, less)
            assert _lim(scen, bands, groups, p3, rule).exposure_factor[j] / extra > 1
    assert f_number_for(params, 1e4) is None
    assert f_number_for(params, 1.0) == pytest.approx(float(params.f_number))
    assert instrument_changes(params, [0.5, 0.9], ["a", "b"])["changes"] == {}


def test_limits_move_the_right_way(scen, bands, groups):
    p = SensorParams()
    base = _lim(scen, bands, groups, p, LimitRule())
    higher_q = _lim(scen, bands, groups, p, LimitRule(dim_percentile=50.0))
    assert np.all(higher_q.detection_limit >= base.detection_limit)
    bright_bg = _lim(scen, bands, groups, p, LimitRule(background_scale=1e4))
    assert np.all(bright_bg.detection_limit >= base.detection_limit)
    assert "background" in bright_bg.limited_by
    no_up = _lim(scen, bands, groups, p, LimitRule(include_uplight=False))
    assert np.all(no_up.saturation <= base.saturation)


def test_rule_validation():
    for kw, msg in (
        ({"snr_target": 0.0}, "snr_target"),
        ({"dim_percentile": 101.0}, "dim_"),
        ({"headroom": 0.5}, "headroom"),
        ({"background_scale": -1.0}, "background"),
    ):
        with pytest.raises(ValueError, match=msg):
            LimitRule(**kw)


# ------------------------------------------------------------------------------
# SNR and NER


@settings(max_examples=25, deadline=None)
@given(k=st.floats(0.5, 100.0), read=st.floats(0.0, 50.0), dark=st.floats(0.0, 1e3))
def test_electrons_for_snr_inverts_snr(k, read, dark):
    p = SensorParams(read_noise_e=read, dark_current_e_s=dark)
    n = electrons_for_snr(k, p)
    assert float(snr(n, p)) == pytest.approx(k, rel=1e-9)


def test_ner_equals_radiance_over_snr_at_limit(scen, bands, groups):
    p = SensorParams(read_noise_e=3.0, dark_current_e_s=50.0)
    lim = _lim(scen, bands, groups, p, LimitRule())
    res = snr_ner(lim.detection_limit, lim.responsivity_e, p)
    np.testing.assert_allclose(
        res["ner_w_m2_sr_nm"], lim.detection_limit / res["snr"], rtol=1e-12
    )
    # thesis Eq. 2.19 in the shot-noise limit: NER = sqrt(L / R)
    p0 = SensorParams()
    res0 = snr_ner(lim.detection_limit, lim.responsivity_e, p0)
    np.testing.assert_allclose(
        res0["ner_w_m2_sr_nm"],
        np.sqrt(lim.detection_limit / lim.responsivity_e),
        rtol=1e-12,
    )


# ------------------------------------------------------------------------------
# quantisers

LO = np.array([1e-7, 3e-8])
HI = np.array([1e-3, 5e-4])
RESP = np.array([3e8, 5e7])


def _all(bits, params=None):
    params = SensorParams(read_noise_e=2.0) if params is None else params
    return [
        make_quantiser(s, LO, HI, bits, responsivity_e=RESP, params=params)
        for s in ("linear", "two-gain", "sqrt")
    ]


def _radiances(n=4001):
    x = np.logspace(-9, -2, n)  # spans below L_min and above L_max
    return np.stack([x, x], axis=1)


@pytest.mark.parametrize("bits", [4, 8, 12, 16])
def test_dn_monotone_and_clipped(bits):
    L = _radiances()
    for q in _all(bits):
        dn = np.asarray(q.encode(L))
        assert np.all(np.diff(dn, axis=0) >= 0), type(q).__name__
        assert np.all(dn[(L <= LO[None]).all(1)] == 0)
        assert np.all(dn[(L >= HI[None]).all(1)] == 2**bits - 1)
        assert np.all(dn == np.round(dn))
        assert dn.min() == 0 and dn.max() == 2**bits - 1


@pytest.mark.parametrize("bits", [6, 10, 14])
def test_invertible_within_half_a_step(bits):
    L = _radiances()
    inside = (L > LO[None]) & (L < HI[None])
    for q in _all(bits):
        back = np.asarray(q(L))
        # half a step, the step taken at the larger end (it grows with L)
        step = np.maximum(np.asarray(q.step(L)), np.asarray(q.step(back)))
        err = np.abs(back - L)[inside]
        assert np.all(err <= 0.5 * step[inside] * (1 + 1e-6)), type(q).__name__


def test_linear_equals_sensor_quantise():
    L = _radiances(501)
    q = LinearQuantiser(LO, HI, 12)
    lo, hi = np.broadcast_to(LO, L.shape), np.broadcast_to(HI, L.shape)
    np.testing.assert_array_equal(
        np.asarray(q.encode(L)), np.asarray(quantise(L, lo, hi, 12))
    )
    dn = np.asarray(q.encode(L))
    np.testing.assert_allclose(
        np.asarray(q.decode(dn)), np.asarray(dequantise(dn, lo, hi, 12))
    )


def test_sqrt_companding_is_noise_matched():
    """Step / photon-model noise is the same at every radiance."""
    p = SensorParams(read_noise_e=4.0, dark_current_e_s=100.0)
    q = SqrtQuantiser.for_sensor(LO, HI, RESP, p, 10)
    L = np.logspace(np.log10(LO.max()), np.log10(HI.min()), 50)[:, None] * np.ones(2)
    noise = np.asarray(snr_ner(L, RESP, p)["ner_w_m2_sr_nm"])
    ratio = np.asarray(q.step(L)) / noise
    np.testing.assert_allclose(
        ratio, np.broadcast_to(np.asarray(q.step_over_noise()), ratio.shape), rtol=1e-9
    )
    # the step is the derivative of the inverse: finite difference
    y = np.asarray(q.transfer(L))
    fd = (np.asarray(q.inverse(y + 1e-3)) - np.asarray(q.inverse(y - 1e-3))) / 2e-3
    np.testing.assert_allclose(np.asarray(q.step(L)), fd, rtol=1e-6)


def test_two_gain_finer_below_knee():
    q = TwoGainQuantiser.geometric_knee(LO, HI, 10)
    lin = LinearQuantiser(LO, HI, 10)
    below = np.sqrt(LO * q.knee)[None]
    above = np.sqrt(q.knee * HI)[None]
    assert np.all(np.asarray(q.step(below)) < np.asarray(lin.step(below)))
    assert np.all(np.asarray(q.step(above)) > np.asarray(lin.step(above)))
    np.testing.assert_allclose(np.asarray(q.transfer(q.knee[None])), 2**9 - 1)


@settings(max_examples=8, deadline=None)
@given(
    lo=st.floats(1e-9, 1e-5),
    ratio=st.floats(2.0, 1e5),
    bits=st.integers(2, 16),
    u=st.lists(st.floats(0.0, 1.0), min_size=5, max_size=5),
)
def test_quantisers_property(lo, ratio, bits, u):
    lo_a, hi_a = np.array([lo]), np.array([lo * ratio])
    L = np.sort(lo * ratio ** (np.asarray(u) * 1.2 - 0.1))[:, None]
    for s in ("linear", "two-gain", "sqrt"):
        q = make_quantiser(s, lo_a, hi_a, bits, responsivity_e=np.array([1e8]))
        dn = np.asarray(q.encode(L))
        assert np.all(np.diff(dn[:, 0]) >= 0)
        assert np.all((dn >= 0) & (dn <= 2**bits - 1))
        back = np.asarray(q(L))
        inside = (L > lo_a) & (L < hi_a)
        step = np.maximum(np.asarray(q.step(L)), np.asarray(q.step(back)))
        assert np.all(np.abs(back - L)[inside] <= 0.5 * step[inside] * (1 + 1e-6))


def test_quantiser_errors():
    with pytest.raises(ValueError, match="saturation must exceed"):
        LinearQuantiser(HI, LO, 8)
    with pytest.raises(ValueError, match="bits"):
        LinearQuantiser(LO, HI, 0)
    with pytest.raises(ValueError, match="expected one of"):
        make_quantiser("log", LO, HI, 8)
    with pytest.raises(ValueError, match="responsivity_e"):
        make_quantiser("sqrt", LO, HI, 8)
    with pytest.raises(ValueError, match="knee must exceed"):
        TwoGainQuantiser(LO, LO / 2, HI, 8)
    assert math.isfinite(float(np.asarray(TwoGainQuantiser(LO, LO * 2, HI, 2).dn_max)))
