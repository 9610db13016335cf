"""One place for each constant and for Planck's law (issue 16)."""

import jax.numpy as jnp
import numpy as np
import pytest

import bandopt.datasets.lamps as lamps
import bandopt.datasets.moon as moon
import bandopt.datasets.nir as nir
import bandopt.estimate as estimate
import bandopt.photometry as photometry
import bandopt.scene as scene
import bandopt.sensor as sensor
import bandopt.spectra as spectra
from bandopt.folds import N_INNER_FOLDS, N_OUTER_FOLDS, nested_lamp_splits


def test_planck_is_one_function_and_matches_colour():
    """Every caller uses `spectra.planck_radiance`; it matches colour-science's
    `planck_law` (same constants) in NumPy and in JAX, and broadcasts."""
    import colour

    assert scene.planck_radiance is spectra.planck_radiance
    w = np.arange(380.0, 901.0, 10.0)
    t = np.array([700.0, 2856.0, 6500.0])
    ours = spectra.planck_radiance(w, t)
    assert isinstance(ours, np.ndarray) and ours.shape == (3, w.size)
    h, c = spectra.PLANCK_J_S, spectra.SPEED_OF_LIGHT_M_S
    c1 = 2 * np.pi * h * c**2  # colour's defaults round c1 and c2: pass exact ones
    c2 = h * c / spectra.BOLTZMANN_J_K
    for i, ti in enumerate(t):
        # colour: c1 / (π λ⁵ ...) per m; ours per nm
        ref = colour.colorimetry.planck_law(w * 1e-9, ti, c1=c1, c2=c2) * 1e-9
        np.testing.assert_allclose(ours[i], ref, rtol=1e-12)
    via_jax = spectra.planck_radiance(jnp.asarray(w), jnp.asarray(t))
    np.testing.assert_allclose(np.asarray(via_jax), ours, rtol=1e-12)
    np.testing.assert_allclose(lamps.planck_spectrum(w, 2856.0), ours[1], rtol=0)
    # nir's tail extension fits the same law (its shape, any scale)
    r = nir._planck(w, 2856.0) / ours[1]
    np.testing.assert_allclose(r, r[0], rtol=1e-12)


def test_constants_have_one_home():
    assert moon.K_M_LM_PER_W is photometry.K_M_LM_PER_W
    assert lamps.K_M_LM_PER_W is photometry.K_M_LM_PER_W
    assert estimate.CCT_RANGE_K == (photometry.CCT_MIN_K, photometry.CCT_MAX_K)
    assert sensor.PLANCK_J_S is spectra.PLANCK_J_S
    assert sensor.SPEED_OF_LIGHT_M_S is spectra.SPEED_OF_LIGHT_M_S


@pytest.mark.parametrize("n", [12, 30])
def test_default_fold_counts(n):
    classes = np.array(["a", "b", "c"] * (n // 3), object)
    splits = nested_lamp_splits(classes, seed=0)
    assert len(splits) == N_OUTER_FOLDS
    assert all(len(s.inner) == N_INNER_FOLDS for s in splits)


def test_lamp_models_use_the_one_planck_and_k_m():
    """`lampmodels`' continuum is `spectra.planck_radiance` (unit area) and its
    per-lumen scaling uses `photometry.K_M_LM_PER_W`."""
    import colour

    import bandopt.lampmodels as lampmodels

    w = np.arange(380.0, 901.0)
    for t in (700.0, 2856.0, 6500.0):
        shape = np.asarray(lampmodels._planck(jnp.asarray(w), jnp.asarray(t)))
        ref = spectra.planck_radiance(w, t)
        np.testing.assert_allclose(shape, ref / np.trapezoid(ref, w), rtol=1e-12)
    s = lampmodels.per_lumen(w, spectra.planck_radiance(w, 2856.0))
    v = colour.SDS_LEFS["CIE 1924 Photopic Standard Observer"][w[:401]]
    lum = photometry.K_M_LM_PER_W * np.trapezoid(s[:401] * v, w[:401])
    assert lum == pytest.approx(1.0, rel=1e-12)
