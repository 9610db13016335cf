"""The one contraction and the one noise rule of every band value in bandopt:
`band_values`, `radiance_from_response` (pure JAX, differentiable in the
responses) and `noise_draws` (common random numbers). The package docstring
states the noise model and the draws."""

import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike, Float

from ..scene import band_weights
from ..sensor import SensorParams, noise_electrons, photon_weights


_HI = jax.lax.Precision.HIGHEST


def prng_key(key) -> Array:
    """`key` as a JAX PRNG key: an integer seed -> `jax.random.PRNGKey(seed)`;
    a key array is returned unchanged."""
    if isinstance(key, (int, np.integer)):
        return jax.random.PRNGKey(int(key))
    return key


def noise_draws(key, n_rows: int, n_bands: int, dtype=None) -> Float[Array, "n b"]:
    """Standard normal draws `(n_rows, n_bands)` for photon noise (module
    docstring): column j is `normal(fold_in(key, j), (n_rows,))`. `key`: an
    integer seed or a JAX key. [1]"""
    k = prng_key(key)
    dtype = jnp.result_type(float) if dtype is None else dtype
    cols = jax.vmap(
        lambda j: jax.random.normal(jax.random.fold_in(k, j), (n_rows,), dtype)
    )
    return cols(jnp.arange(n_bands)).T


def band_values(
    spectra: Float[ArrayLike, "*batch w"], weights: Float[ArrayLike, "b w"]
) -> Float[Array, "*batch b"]:
    """Band values `(*batch, b)` of spectra `(*batch, w)` for weights `(b, w)`
    on the same grid: `spectra @ weightsᵀ`, one dense matmul at full
    precision. With band-averaging weights (`band_weights_on`) it gives band
    radiance in the unit of the spectra; with photon weights, electrons.
    Band values of dense spectra anywhere in bandopt are this contraction
    (a scenario set's factorised one, `scene.band_terms`, uses the same
    weights), so one rule decides the numbers. Pure JAX, differentiable in
    both arguments."""
    return jnp.matmul(jnp.asarray(spectra), jnp.asarray(weights).T, precision=_HI)


def radiance_from_response(
    spectra: Float[ArrayLike, "*batch w"],
    wavelength_nm: Float[ArrayLike, " w"],
    response: Float[ArrayLike, "b w"],
    noise_z: Float[ArrayLike, "n b"] | None = None,
    sensor: SensorParams | None = None,
) -> Float[Array, "*batch b"]:
    """Band-averaged radiance `(*batch, b)` of spectra `(*batch, w)` for
    relative responses `(b, w)` on the same grid: one dense matmul. With
    standard normal draws `noise_z (n, b)` (n: the batch's size), photon
    noise of `sensor` (default Table 2.3) as in the module docstring; a band
    with zero responsivity reads 0. Pure JAX, differentiable in `response`.
    [W m⁻² sr⁻¹ nm⁻¹]"""
    spectra = jnp.asarray(spectra)
    if noise_z is None:
        return band_values(spectra, band_weights(response, wavelength_nm))
    sensor = SensorParams() if sensor is None else sensor
    pw = photon_weights(response, wavelength_nm, sensor, None)
    electrons = band_values(spectra, pw)
    return _noisy_radiance(electrons, jnp.sum(pw, axis=-1), noise_z, sensor)


def _noisy_radiance(electrons, resp_e, z, sensor):
    """`(e + σ(e) z) / responsivity`, 0 where the responsivity is 0
    (double-where: finite gradients there too)."""
    lead = (1,) * (electrons.ndim - 1)
    resp_e = jnp.reshape(resp_e, (*lead, -1))
    ok = resp_e > 0
    noisy = electrons + noise_electrons(electrons, sensor) * jnp.asarray(
        z, electrons.dtype
    ).reshape(electrons.shape)
    return jnp.where(ok, noisy / jnp.where(ok, resp_e, 1.0), 0.0)
