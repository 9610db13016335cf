"""Physical lamp models: spectra, NIST line positions, the instrument operator,
fitting (recovery of a known model spectrum), calibration and sampling (modelled
lamps never scored). The leave-one-lamp-out validation on the whole measured
library (`lampmodels.write_validation`, `make lamp-models`) is too slow for the
test suite; its summary is tested on rows made up here."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from bandopt import lampmodels as lm
from bandopt.photometry import metrics


W = np.arange(380.0, 901.0)
VIS = (W >= 380.0) & (W <= 780.0)


def _z(family, **values):
    base = {p.name: p.init for p in family.params}
    base.update(values)
    return lm.to_z(family, np.array([base[n] for n in family.names]))


@pytest.mark.parametrize("name", sorted(lm.FAMILIES))
def test_spectrum_is_finite_positive_unit_visible_power(name):
    family = lm.FAMILIES[name]
    s = np.asarray(lm.spectrum(family, family.z_init(), W))
    assert np.all(np.isfinite(s)) and np.all(s >= 0)
    vis = np.trapezoid(s[VIS], W[VIS])
    assert vis == pytest.approx(1.0, rel=1e-12)
    # gradients through the bound map and every profile are finite
    g = jax.grad(lambda z: jnp.sum(lm.spectrum(family, z, W) ** 2))(
        jnp.asarray(family.z_init())
    )
    assert np.all(np.isfinite(np.asarray(g)))


def test_bound_map_round_trip_and_bounds():
    f = lm.HPS
    v = np.array([p.init for p in f.params])
    np.testing.assert_allclose(np.asarray(lm.to_values(f, lm.to_z(f, v))), v)
    big = np.asarray(lm.to_values(f, np.full(v.size, 50.0)))
    assert np.all(big <= f.hi) and np.all(
        lm.to_values(f, -np.full(v.size, 50.0)) >= f.lo
    )
    with pytest.raises(ValueError, match="inside their bounds"):
        lm.to_z(f, f.hi)


def test_lines_at_nist_wavelengths():
    fine = np.arange(380.0, 900.0, 0.05)
    hg = np.asarray(lm.spectrum(lm.MERCURY, _z(lm.MERCURY, fwhm_lines_nm=1.0), fine))
    assert fine[np.argmax(hg)] == pytest.approx(546.074, abs=0.05)
    lps = np.asarray(lm.spectrum(lm.LPS, _z(lm.LPS, fwhm_nm=0.4), fine))
    assert 588.9 <= fine[np.argmax(lps)] <= 589.7
    # the weak 819 nm doublet is where NIST puts it
    nir = fine > 800
    top = lps[nir].max()

    def at(x):
        return lps[np.argmin(np.abs(fine - x))]

    assert at(818.326) > 0.9 * top and at(819.482) > 0.9 * top
    assert at(818.9) < 0.5 * top and at(810.0) < 0.01 * top
    # HPS: self-reversed D line, a dip at 589 nm between two maxima
    hps = np.asarray(lm.spectrum(lm.HPS, _z(lm.HPS, d_tau_abs=6.0), fine))
    d = (fine > 570) & (fine < 610)
    x, y = fine[d], hps[d]
    centre = y[np.argmin(np.abs(x - 589.3))]
    assert centre < 0.8 * y[x < 589.3].max() and centre < 0.8 * y[x > 589.3].max()


def test_pc_led_spans_warm_to_cool():
    """The docstring's claim: the PC-LED family spans 1800-6500 K (near the
    Planckian locus, |Duv| < 0.02) within its bounds."""
    f = lm.PC_LED
    warm = _z(f, ln_pump=-3.5, ph1_nm=580.0, ph2_offset_nm=50.0, ln_ph2=1.5)
    cool = _z(f, ln_pump=-0.3, ph1_nm=535.0, ph2_offset_nm=60.0, ln_ph2=-1.5)
    s = np.stack([np.asarray(lm.spectrum(f, z, W[VIS])) for z in (warm, cool)])
    m = metrics(s, W[VIS])
    assert float(m["CCT"][0]) < 1800 and float(m["CCT"][1]) > 6500
    assert np.all(np.abs(np.asarray(m["Duv"])) < 0.02)


def test_sampling_matrix_keeps_line_power_at_the_knots():
    w = np.arange(380.0, 781.0)
    p = lm.sampling_matrix(w, 5, 780.0)
    line = np.zeros_like(w)
    line[w == 546.0] = 1.0  # 1 W nm-1 over 1 nm: power 1
    knots = (w - 380) % 5 == 0
    seen = (p @ line)[knots]
    assert np.sum(seen) * 5 == pytest.approx(1.0, rel=1e-12)
    assert np.count_nonzero(seen) == 2  # the two knots within 5 nm
    np.testing.assert_array_equal(lm.sampling_matrix(w, 1, 780.0), np.eye(w.size))


def test_native_step_detection():
    w = np.arange(380.0, 781.0)
    rng = np.random.default_rng(1)
    knots = np.arange(380.0, 781.0, 5.0)
    coarse = np.interp(w, knots, rng.uniform(0.1, 1.0, knots.size))
    assert lm.native_step_nm(w, coarse, 780.0) == 5
    assert lm.native_step_nm(w, rng.uniform(0.1, 1.0, w.size), 780.0) == 1


def test_fit_recovers_a_model_spectrum():
    f = lm.PC_LED
    z_true = _z(f, pump_nm=452.0, ph1_nm=555.0, ln_pump=-1.0, ln_ph2=-0.8)
    s = np.asarray(lm.spectrum(f, z_true, W))
    res = lm.fit("pc_led", W, 3.7 * s, step_nm=1)
    assert res.nrms < 0.02 and res.family == "pc_led"
    m = metrics(np.stack([s[VIS], res.model[VIS]]), W[VIS])
    ler = np.asarray(m["LER"])
    assert ler[1] == pytest.approx(ler[0], rel=0.01)
    assert float(m["CCT"][1]) == pytest.approx(float(m["CCT"][0]), abs=30.0)
    with pytest.raises(ValueError, match="finite from 380 nm to at least 650 nm"):
        lm.fit("pc_led", W, np.where(W < 600, np.nan, s))


def _fake_fit(z, nir):
    return lm.Fit("hps", z, {}, z, z, z, 0.0, nir, 5, True)


def test_calibration_keeps_nir_block_separate():
    f = lm.HPS
    rng = np.random.default_rng(0)
    k = len(f.params)
    fits = {f"l{i}": _fake_fit(rng.normal(0, 1, k), nir=i < 2) for i in range(5)}
    ends = {f"l{i}": 900.0 if i < 2 else 780.0 for i in range(5)}
    cal = lm.calibrate_fits("hps", fits, ends)
    nm = f.nir_mask
    assert cal.nir_lamps == ("l0", "l1") and cal.model_end_nm == 900.0
    zs = np.array([fits[i].z for i in sorted(fits)])
    np.testing.assert_allclose(cal.mean[~nm], zs[:, ~nm].mean(0))
    np.testing.assert_allclose(cal.mean[nm], zs[:2, nm].mean(0))
    assert np.all(cal.cov[np.ix_(nm, ~nm)] == 0)
    samples = lm.sample_z(cal, 4000, seed=3)
    np.testing.assert_allclose(samples.mean(0), cal.mean, atol=0.15)
    assert np.isfinite(float(lm.log_prior(cal, cal.mean)))
    with pytest.raises(ValueError, match="no measured lamp"):
        lm.calibrate_fits("hps", {}, {})
    with pytest.raises(ValueError, match="No lamp model for class 'fire'"):
        lm.family_of("fire")


def test_sampled_lamps_are_modelled_and_never_scored():
    f = lm.PC_LED
    rng = np.random.default_rng(2)
    z0 = _z(f, ph1_nm=595.0, ln_pump=-8.0)  # a PC-amber-like model lamp
    fits = {
        f"l{i}": lm.Fit(
            "pc_led",
            z0 + rng.normal(0, 0.1, z0.size),
            {},
            z0,
            z0,
            z0,
            0.0,
            True,
            1,
            True,
        )
        for i in range(3)
    }
    cal = lm.calibrate_fits("led_amber", fits, dict.fromkeys(fits, 900.0))
    out = lm.sample_library(["led_amber"], 3, seed=0, calibrations={"led_amber": cal})
    assert len(out) == 3
    assert all(r.modelled and not out.is_scored(r) for r in out.records)
    assert all(r.source == "bandopt lamp model led_amber" for r in out.records)
    # the library's unit: one lumen per spectrum (683 lm/W x ∫ V S = 1)
    from colour import SDS_LEFS

    w = out.wavelength_nm
    vis = (w >= 380.0) & (w <= 780.0)
    v = SDS_LEFS["CIE 1924 Photopic Standard Observer"][w[vis]]
    lum = 683.0 * np.trapezoid(out.values[:, vis] * v, w[vis], axis=1)
    np.testing.assert_allclose(lum, 1.0, rtol=1e-9)
    with pytest.raises(ValueError, match="is a calibration of 'led_amber'"):
        lm.sample_library(["led_warm"], 1, seed=0, calibrations={"led_warm": cal})


def test_calibration_uses_only_the_training_lamps():
    """No test lamp leaks into a fold's prior: `calibrate` fits only the
    measured lamps of the class that are listed."""
    from bandopt.datasets.lamps import library

    lib = library()
    amber = [
        r.id
        for r in lib.records
        if r.level2 == "led_amber" and not r.modelled and r.excluded is None
    ]
    cal = lm.calibrate("led_amber", [amber[0], "nist_traditional_hps"])
    assert cal.lamps == (amber[0],)


@pytest.mark.parametrize("extend", [True, False])
def test_samples_of_lamps_measured_to_780_nm_stop_there(extend):
    """Calibration lamps that all stop at 780 nm (the NIST mercury lamps): the
    samples beyond 780 nm are the library's NIR extension or NaN, as for a
    measured lamp of that range (this path wrote into a read-only array)."""
    f = lm.MERCURY
    rng = np.random.default_rng(5)
    z0 = f.z_init()
    fits = {
        f"l{i}": lm.Fit(
            "mercury",
            z0 + rng.normal(0, 0.1, z0.size),
            {},
            z0,
            z0,
            z0,
            0.0,
            False,
            5,
            True,
        )
        for i in range(3)
    }
    cal = lm.calibrate_fits("mercury", fits, dict.fromkeys(fits, 780.0))
    out = lm.sample_library(
        ["mercury"], 2, seed=1, calibrations={"mercury": cal}, extend_nir=extend
    )
    w = out.wavelength_nm
    beyond = w > 780.0
    assert np.all(np.isfinite(out.values[:, ~beyond]))
    assert np.all(np.isfinite(out.values[:, beyond])) == extend
    assert np.all(np.isnan(out.values[:, beyond])) == (not extend)
    assert all(r.extended == extend for r in out.records)
    assert all(r.measured_range_nm == (380.0, 780.0) for r in out.records)


def test_validation_summary_reads_the_rows():
    """Medians over the rows that have a value, NaN left out; coverage is the
    share of held-out lamps strictly inside the samples' 5-95 %."""
    rows = [
        {"fit_nrms": 0.1, "fit_converged": True, "ler_fit_rel_err": -0.02,
         "cct_fit_err_k": 30.0, "loo": "ok", "loo_ler_median_rel_err": 0.1,
         "loo_ler_percentile": 0.5, "loo_cct_median_err_k": float("nan"),
         "loo_cct_percentile": float("nan"), "loo_nearest_sample_nrms": 1.0,
         "loo_nearest_measured_nrms": 2.0},
        {"fit_nrms": 0.3, "fit_converged": False, "ler_fit_rel_err": 0.04,
         "cct_fit_err_k": -50.0, "loo": "ok", "loo_ler_median_rel_err": -0.3,
         "loo_ler_percentile": 0.99, "loo_cct_median_err_k": -100.0,
         "loo_cct_percentile": 0.2, "loo_nearest_sample_nrms": 3.0,
         "loo_nearest_measured_nrms": 4.0},
    ]  # fmt: skip
    s = lm.summarise_validation(rows)
    assert s["measured_lamps"] == 2 and s["fit_converged"] == 1
    assert s["fit_nrms_median"] == pytest.approx(0.2)
    assert s["fit_ler_abs_rel_err_median"] == pytest.approx(0.03)
    assert s["loo_lamps"] == 2
    assert s["loo_ler_abs_rel_err_median"] == pytest.approx(0.2)
    assert s["loo_ler_90pc_interval_coverage"] == 0.5
    assert s["loo_cct_abs_err_k_median"] == 100.0  # the NaN row left out
    assert s["loo_cct_90pc_interval_coverage"] == 1.0
    one = lm.summarise_validation([{**rows[0], "loo": "not possible"}])
    assert one["loo_lamps"] == 0 and one["loo"].startswith("not possible")
