"""bandopt.perturb: each measurement effect's defining property."""

import numpy as np
import pytest

from bandopt import perturb


GRID = np.arange(380.0, 901.0)
"""The library's 1 nm grid."""

EXACT = 1e-12
"""Relative tolerance of quantities the construction makes exact (float64
rounding of sums over ~500 samples)."""


def _line(centre_nm: float, fwhm_nm: float = 3.0) -> np.ndarray:
    sigma = fwhm_nm / perturb.FWHM_PER_SIGMA
    return np.exp(-0.5 * ((GRID - centre_nm) / sigma) ** 2)


@pytest.fixture
def spectra() -> np.ndarray:
    """Three lamp-like spectra: a line spectrum (sodium-like), a
    blue-pump-plus-phosphor LED and a smooth warm continuum."""
    led = _line(450.0, 20.0) + 0.6 * _line(580.0, 120.0)
    hps = _line(589.0, 8.0) + 0.2 * _line(819.0, 4.0) + 0.05
    warm = (GRID / 900.0) ** 4
    return np.stack([hps, led, warm])


@pytest.mark.parametrize("fraction", [0.005, 0.01, 0.02])
def test_flat_background_has_its_share_of_visible_power(spectra, fraction):
    out = perturb.add_flat_background(spectra, GRID, fraction)
    added = out - spectra
    assert np.allclose(added, added[:, :1], rtol=EXACT)  # flat in wavelength
    share = perturb.visible_power(added, GRID) / perturb.visible_power(spectra, GRID)
    np.testing.assert_allclose(share, fraction, rtol=EXACT)


@pytest.mark.parametrize("fraction", [0.005, 0.02])
def test_skyglow_has_its_share_and_its_shape(spectra, fraction):
    sky = perturb.skyglow_spectrum(
        spectra,
        ["hps", "led_cool", "incandescent"],
        GRID,
        {"hps": 0.5, "led_cool": 0.5},
    )
    np.testing.assert_allclose(perturb.visible_power(sky[None], GRID), 1.0, rtol=EXACT)
    out = perturb.add_skyglow(spectra, GRID, fraction, sky)
    added = out - spectra
    share = perturb.visible_power(added, GRID) / perturb.visible_power(spectra, GRID)
    np.testing.assert_allclose(share, fraction, rtol=EXACT)
    # the added light is the sky spectrum, scaled
    np.testing.assert_allclose(added / added[:, :1] * sky[0], np.tile(sky, (3, 1)))


def test_skyglow_mix_has_its_luminous_shares(spectra):
    sky = perturb.skyglow_spectrum(
        spectra, ["hps", "led_cool", "x"], GRID, {"hps": 3.0, "led_cool": 1.0}
    )
    # sky = a·hps/Φ_hps + b·led/Φ_led with a : b = 3 : 1
    per_lm = spectra[:2] / perturb.luminous_flux_lm(spectra[:2], GRID)[:, None]
    coef, *_ = np.linalg.lstsq(per_lm.T, sky, rcond=None)
    np.testing.assert_allclose(coef[0] / coef[1], 3.0, rtol=1e-9)


def test_skyglow_names_a_missing_class(spectra):
    with pytest.raises(ValueError, match=r"\['mercury'\]"):
        perturb.skyglow_spectrum(
            spectra, ["hps", "led_cool", "x"], GRID, {"mercury": 1.0}
        )


@pytest.mark.parametrize("snr", [30.0, 100.0])
def test_noise_snr_measured_back(snr):
    flat = np.full((200, GRID.size), 2.0)
    out = perturb.add_spectrometer_noise(flat, GRID, snr, seed=1)
    noise = out - flat
    # 200 x 521 draws: the SD estimate is within ~0.3 % (1/sqrt(2n))
    np.testing.assert_allclose(2.0 / noise.std(), snr, rtol=0.01)
    assert abs(noise.mean()) < 5 * 2.0 / snr / np.sqrt(noise.size)


def test_noise_is_peak_independent_and_seeded(spectra):
    out = perturb.add_spectrometer_noise(
        np.repeat(spectra[:1], 400, 0), GRID, 30.0, seed=2
    )
    noise = out - spectra[0]
    peak, dark = noise[:, 589 - 380], noise[:, 700 - 380]
    # the same σ at the line's peak and far from it (F-test-like bound, 400 draws)
    assert 0.85 < peak.std() / dark.std() < 1.15
    again = perturb.add_spectrometer_noise(spectra, GRID, 30.0, seed=2)
    np.testing.assert_array_equal(
        again, perturb.add_spectrometer_noise(spectra, GRID, 30.0, seed=2)
    )


@pytest.mark.parametrize("fwhm_nm", [2.0, 5.0, 10.0])
def test_resolution_keeps_power_and_widens_a_line(fwhm_nm):
    line = _line(600.0, 1.0)[None] + 0.01 * _line(381.0, 1.0)[None]
    out = perturb.degrade_resolution(line, GRID, fwhm_nm)
    np.testing.assert_allclose(out.sum(), line.sum(), rtol=EXACT)  # the edge too
    # a 1 nm line through the slit: widths add in quadrature
    half = out[0] >= out[0, 220] / 2
    width = half.sum()  # samples above half maximum (1 nm each)
    assert abs(width - np.hypot(fwhm_nm, 1.0)) <= 1.0  # one sample of rounding
    assert out[0].argmax() == 220


@pytest.mark.parametrize("shift_nm", [1.0, 2.0, -1.0])
def test_shift_moves_a_line_by_the_shift(shift_nm):
    line = _line(589.0, 4.0)[None]
    out = perturb.shift_wavelength(line, GRID, shift_nm)
    centroid = lambda s: np.sum(GRID * s) / np.sum(s)  # noqa: E731
    np.testing.assert_allclose(
        centroid(out[0]) - centroid(line[0]), shift_nm, atol=1e-6
    )


def test_shift_by_half_a_sample_interpolates_linearly(spectra):
    out = perturb.shift_wavelength(spectra, GRID, 0.5)
    np.testing.assert_allclose(out[:, 1:], 0.5 * (spectra[:, 1:] + spectra[:, :-1]))


@pytest.mark.parametrize("cut_nm", [780.0, 800.0])
def test_truncation_keeps_data_up_to_the_cut(spectra, cut_nm):
    seen = []

    def extend(w, s):
        seen.append(w[-1])
        return np.full(GRID.size, s[-1])  # hold the last measured value

    out = perturb.truncate_and_extend(spectra, GRID, cut_nm, extend)
    keep = GRID <= cut_nm
    np.testing.assert_array_equal(out[:, keep], spectra[:, keep])
    held = np.broadcast_to(spectra[:, keep][:, -1:], out[:, ~keep].shape)
    np.testing.assert_array_equal(out[:, ~keep], held)
    assert seen == [cut_nm] * 3  # the rule saw only the measured part


def test_truncation_refuses_a_bad_cut_or_rule(spectra):
    with pytest.raises(ValueError, match="cut_nm"):
        perturb.truncate_and_extend(spectra, GRID, 700.0, lambda w, s: GRID)
    with pytest.raises(ValueError, match="extend"):
        perturb.truncate_and_extend(spectra, GRID, 780.0, lambda w, s: w)


@pytest.mark.parametrize("share", [0.1, 0.3])
def test_mixture_share_of_luminous_flux_is_exact(spectra, share):
    others = spectra[[1, 2, 0]] * np.array([[3.0], [0.2], [7.0]])  # any brightness
    out = perturb.mix_lamps(spectra, others, GRID, share)
    flux = perturb.luminous_flux_lm
    np.testing.assert_allclose(flux(out, GRID), flux(spectra, GRID), rtol=EXACT)
    part = share * others * (flux(spectra, GRID) / flux(others, GRID))[:, None]
    np.testing.assert_allclose(flux(part, GRID) / flux(out, GRID), share, rtol=EXACT)
    # the rest is the lamp itself (absolute tolerance: rounding of the subtraction)
    np.testing.assert_allclose(out - part, (1 - share) * spectra, atol=1e-14)


def test_luminous_flux_is_the_library_convention():
    from bandopt.datasets.lamps import library

    lib = library().select(scored_only=True)
    np.testing.assert_allclose(
        perturb.luminous_flux_lm(lib.values[:20], lib.wavelength_nm), 1.0, rtol=1e-9
    )


@pytest.mark.parametrize(
    ("call", "match"),
    [
        (lambda s: perturb.add_flat_background(s, GRID * 2, 0.01), "1 nm"),
        (lambda s: perturb.add_spectrometer_noise(s, GRID, 0.0, seed=0), "snr"),
        (lambda s: perturb.degrade_resolution(s, GRID, -1.0), "fwhm_nm"),
        (lambda s: perturb.mix_lamps(s, s, GRID, 1.5), "share"),
        (lambda s: perturb.add_flat_background(s, GRID, -0.1), "fraction"),
    ],
)
def test_bad_input_names_the_argument(spectra, call, match):
    with pytest.raises(ValueError, match=match):
        call(spectra)
