"""Slit functions and band radiance: closed forms, invariants, gradients, float32."""

import itertools
import warnings

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import pytest
import scipy.integrate
import scipy.special
from hypothesis import given, settings, strategies as st

from bandopt.sensor import (
    BandSet,
    SensorParams,
    band_average,
    band_integrate,
    crop_to_support,
    signal_electrons,
    slit_super_gaussian,
    super_gaussian_area_nm,
    super_gaussian_fraction_outside,
)
from bandopt.spectra import GRID_1NM, resample


WL = jnp.asarray(GRID_1NM)


def _colour_lamp(key):
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", message='"Matplotlib" related API')
        import colour
    sd = colour.SDS_LIGHT_SOURCES[key]
    # NIST data end at 780 nm; zero beyond is a test input, not a claim.
    return resample(sd.wavelengths, sd.values, GRID_1NM, outside="zero")


@pytest.fixture(scope="module")
def lamps():
    return jnp.asarray(np.stack([_colour_lamp("LPS"), _colour_lamp("HPS")]))


@settings(deadline=None, max_examples=25)
@given(
    centre=st.floats(400, 880),
    fwhm=st.floats(1, 600),
    k=st.floats(1.5, 100),
)
def test_half_maximum_at_half_fwhm_for_every_k(centre, fwhm, k):
    wl = jnp.asarray([centre - fwhm / 2, centre, centre + fwhm / 2])
    r = slit_super_gaussian(
        wl, jnp.asarray([centre]), jnp.asarray([fwhm]), jnp.asarray([k])
    )
    # the grid points themselves carry rounding ~eps*centre, amplified by k/fwhm
    atol = 1e-15 + 4 * np.finfo(float).eps * k * centre / fwhm
    np.testing.assert_allclose(r[0], [0.5, 1.0, 0.5], rtol=0, atol=atol)


@pytest.mark.parametrize("k", [2.0, 3.0, 6.0, 20.0, 50.0])
def test_area_and_outside_fraction_match_quadrature(k):
    fwhm, centre = 80.0, 870.0
    f = lambda x: 2.0 ** -(abs(2 * (x - centre) / fwhm) ** k)  # noqa: E731
    total = scipy.integrate.quad(f, centre - 10 * fwhm, centre + 10 * fwhm, limit=400)[
        0
    ]
    area = super_gaussian_area_nm(jnp.asarray([fwhm]), jnp.asarray([k]))[0]
    np.testing.assert_allclose(area, total, rtol=1e-9)
    if k == 2.0:  # Gaussian closed form: sigma sqrt(2 pi)
        sigma = fwhm / (2 * np.sqrt(2 * np.log(2)))
        np.testing.assert_allclose(area, sigma * np.sqrt(2 * np.pi), rtol=1e-12)
    above = scipy.integrate.quad(f, 900.0, centre + 10 * fwhm, limit=400)[0]
    below = scipy.integrate.quad(f, centre - 10 * fwhm, 380.0, limit=400)[0]
    frac = super_gaussian_fraction_outside(
        jnp.asarray([centre]), jnp.asarray([fwhm]), jnp.asarray([k]), 380.0, 900.0
    )[0]
    np.testing.assert_allclose(frac, (above + below) / total, rtol=1e-7, atol=1e-13)


def test_band_average_and_integral_against_numpy(lamps):
    bands = BandSet.from_physical([450.0, 589.0, 820.0], [40.0, 20.0, 60.0], [2, 6, 30])
    r = bands.response(WL)
    s = np.asarray(lamps)
    w = np.asarray(WL)
    ref_int = np.trapezoid(s[:, None, :] * np.asarray(r)[None], w, axis=-1)
    ref_avg = ref_int / np.trapezoid(np.asarray(r), w, axis=-1)[None, :]
    np.testing.assert_allclose(band_integrate(lamps, r, WL), ref_int, rtol=1e-12)
    np.testing.assert_allclose(band_average(lamps, r, WL), ref_avg, rtol=1e-12)


def test_flat_spectrum_passes_unchanged():
    bands = BandSet.from_physical(
        [420.0, 560.0, 700.0], [20.0, 150.0, 60.0], [2, 6, 50]
    )
    flat = jnp.full((3, WL.shape[0]), 3.7e-6)
    np.testing.assert_allclose(
        band_average(flat, bands.response(WL), WL), 3.7e-6, 1e-12
    )
    # the policy wrapper agrees when nothing is off the grid
    np.testing.assert_allclose(bands.band_average(flat, WL), 3.7e-6, rtol=1e-12)


def test_band_off_the_grid_is_never_silently_renormalised():
    bands = BandSet.from_physical([880.0], [40.0], [2.0])  # Gaussian tail past 900
    flat = jnp.ones(WL.shape)
    frac = float(bands.fraction_outside(WL)[0])
    assert frac > 0.05
    with pytest.raises(ValueError, match=r"B1 \(0\.\d+\)"):
        bands.band_average(flat, WL)
    np.testing.assert_allclose(bands.band_average(flat, WL, outside="renormalise"), 1)
    zero = bands.band_average(flat, WL, outside="zero")
    np.testing.assert_allclose(zero, 1 - frac, rtol=1e-12)
    with pytest.raises(ValueError, match="expected one of"):
        bands.band_average(flat, WL, outside="clip")
    jitted = eqx.filter_jit(lambda b, s: b.band_average(s, WL))
    with pytest.raises(Exception, match="outside the data grid"):
        jitted(bands, flat)


def test_crop_to_support_skips_work_without_changing_results(lamps):
    bands = BandSet.from_physical([450.0, 600.0], [30.0, 50.0], [6.0, 20.0])
    r = bands.response(WL)
    s = crop_to_support(WL, r, tail=1e-6)
    assert 0 < s.start and s.stop < WL.shape[0]
    assert float(jnp.max(r[:, : s.start])) < 1e-6
    assert float(jnp.max(r[:, s.stop :])) < 1e-6
    full = band_average(lamps, r, WL)
    cropped = band_average(lamps[:, s], r[:, s], WL[s])
    np.testing.assert_allclose(cropped, full, rtol=1e-6)
    with pytest.raises(ValueError, match="concrete"):
        jax.jit(lambda r: crop_to_support(WL, r))(r)


# --- gradients: the box of the issue, vectorised ----------------------------
FWHMS = (1.0, 3.0, 15.0, 100.0, 600.0)
KS = (2.0, 6.0, 20.0, 50.0)
CENTRES = (560.0, 560.37, 380.0, 900.0, 450.0)  # on a grid point, off it, edges, blue
CASES = np.array(list(itertools.product(CENTRES, FWHMS, KS)))  # (100, 3)
REF_BAND = (589.0, 30.0, 6.0)  # denominator of the band ratio


def _outputs(theta, lamps, params):
    """Band radiance (LPS, HPS), HPS/LPS-ratio-like band ratio and electrons."""
    c, f, k = theta[0], theta[1], theta[2]
    centre = jnp.stack([c, jnp.full_like(c, REF_BAND[0])])
    fwhm = jnp.stack([f, jnp.full_like(f, REF_BAND[1])])
    shape = jnp.stack([k, jnp.full_like(k, REF_BAND[2])])
    r = slit_super_gaussian(WL.astype(theta.dtype), centre, fwhm, shape)
    wl = WL.astype(theta.dtype)
    avg = band_average(lamps, r, wl)  # (2 lamps, 2 bands)
    ratio = avg[:, 0] / avg[:, 1]  # reference band sees both lamps
    electrons = signal_electrons(lamps * 1e-6, r, wl, params)[:, 0]
    return jnp.concatenate([avg[:, 0], ratio, 1e-3 * electrons])


def _fd(fun, theta, h):
    """Fourth-order central differences, one parameter at a time."""
    cols = []
    for j in range(3):
        e = jnp.zeros(3).at[j].set(h[j])
        cols.append(
            (
                -fun(theta + 2 * e)
                + 8 * fun(theta + e)
                - 8 * fun(theta - e)
                + fun(theta - 2 * e)
            )
            / (12 * h[j])
        )
    return jnp.stack(cols, axis=-1)


def test_gradients_finite_and_match_finite_differences(lamps):
    params = SensorParams()
    fun = lambda t: _outputs(t, lamps, params)  # noqa: E731
    theta = jnp.asarray(CASES)
    jac = jax.jit(jax.vmap(jax.jacfwd(fun)))(theta)  # (cases, outputs, 3)
    out = jax.jit(jax.vmap(fun))(theta)  # (cases, outputs)
    assert bool(jnp.all(jnp.isfinite(jac)) & jnp.all(jnp.isfinite(out)))
    # steps: centre and FWHM move 1e-3 of the edge width FWHM/k, k moves 1e-3 k
    edge = theta[:, 1] / theta[:, 2]
    h = jnp.stack([1e-3 * edge, 1e-3 * edge, 1e-3 * theta[:, 2]], -1)
    fd = jax.jit(jax.vmap(lambda t, hh: _fd(fun, t, hh)))(theta, h)
    # scale: each output's largest magnitude in the box per unit of each
    # parameter's own size (FWHM for centre and FWHM, k for k)
    size = jnp.stack([theta[:, 1], theta[:, 1], theta[:, 2]], -1)[:, None, :]
    scale = jnp.max(jnp.abs(out), axis=0)[None, :, None] / size
    bad = jnp.abs(jac - fd) > 1e-5 * (jnp.abs(jac) + scale)
    assert not bool(jnp.any(bad)), CASES[np.unique(np.nonzero(np.asarray(bad))[0])]


def test_blue_band_on_low_pressure_sodium_is_zero_with_zero_gradient(lamps):
    fun = lambda t: _outputs(t, lamps, SensorParams())[0]  # noqa: E731
    theta = jnp.asarray([450.0, 30.0, 6.0])
    value, grad = jax.jit(jax.value_and_grad(fun))(theta)
    assert float(value) == 0.0
    np.testing.assert_array_equal(grad, 0.0)


def test_float32_has_no_nan_anywhere_in_the_box(lamps):
    lamps32 = lamps.astype(jnp.float32)
    params32 = jax.tree.map(lambda x: x.astype(jnp.float32), SensorParams())
    fun = lambda t: _outputs(t, lamps32, params32)  # noqa: E731
    theta = jnp.asarray(CASES, dtype=jnp.float32)
    out, jac = jax.jit(jax.vmap(lambda t: (fun(t), jax.jacfwd(fun)(t))))(theta)
    assert out.dtype == jnp.float32 and jac.dtype == jnp.float32
    assert bool(jnp.all(jnp.isfinite(out)) & jnp.all(jnp.isfinite(jac)))
    frac = super_gaussian_fraction_outside(
        theta[:, 0], theta[:, 1], theta[:, 2], 380, 900
    )
    g = jax.grad(
        lambda t: super_gaussian_fraction_outside(
            t[:, 0], t[:, 1], t[:, 2], 380.0, 900.0
        ).sum()
    )(theta)
    assert bool(jnp.all(jnp.isfinite(frac)) & jnp.all(jnp.isfinite(g)))


@pytest.mark.parametrize("dtype", [jnp.float32, jnp.float64])
def test_small_radiances_keep_relative_precision(dtype, lamps):
    bands = BandSet.from_physical([450.0, 589.0], [40.0, 20.0])
    wl = WL.astype(dtype)
    r = bands.response(WL).astype(dtype)
    base = band_average(lamps[1].astype(dtype), r, wl)
    params = jax.tree.map(lambda x: x.astype(dtype), SensorParams())
    e_base = signal_electrons(lamps[1].astype(dtype), r, wl, params)
    rtol = 1e-5 if dtype == jnp.float32 else 1e-12
    for scale in (1e-12, 1e-6, 1.0, 1e2):
        scaled = (lamps[1] * scale).astype(dtype)
        np.testing.assert_allclose(band_average(scaled, r, wl), base * scale, rtol=rtol)
        np.testing.assert_allclose(
            signal_electrons(scaled, r, wl, params), e_base * scale, rtol=rtol
        )


def test_jit_vmap_grad_agree_with_eager(lamps):
    bands = BandSet.from_physical([470.0, 589.0, 700.0], [40.0, 25.0, 80.0], [4, 6, 12])

    def loss(b, spectra):
        avg = b.band_average(spectra, WL, outside="renormalise")
        return jnp.sum(jnp.log1p(avg[:, 0] / avg[:, 1]))

    eager = loss(bands, lamps)
    jitted = eqx.filter_jit(loss)(bands, lamps)
    per_lamp = jax.jit(jax.vmap(lambda s: loss(bands, s[None])))(lamps)
    np.testing.assert_allclose(jitted, eager, rtol=1e-13)
    np.testing.assert_allclose(per_lamp.sum(), eager, rtol=1e-13)
    g_eager = eqx.filter_grad(loss)(bands, lamps)
    g_jit = eqx.filter_jit(eqx.filter_grad(loss))(bands, lamps)
    for a, b in zip(jax.tree.leaves(g_eager), jax.tree.leaves(g_jit), strict=True):
        np.testing.assert_allclose(a, b, rtol=1e-12, atol=1e-300)
        assert bool(jnp.all(jnp.isfinite(a)))
