"""Spectra on wavelength grids: a `Spectrum` Module, quadrature and resampling.

Resampling is linear interpolation. Outside the measured range a spectrum is
*unknown*, not zero: `resample` asks the caller to choose (`"nan"`, `"zero"`,
`"edge"`), and the lamp library records each spectrum's measured range.
"""

from typing import Literal

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike, Float


GRID_1NM: np.ndarray = np.arange(380.0, 901.0, 1.0)
"""Default working grid of the library: 380-900 nm at 1 nm. [nm]"""

VISIBLE_NM: tuple[float, float] = (380.0, 780.0)
"""Visible range used for photometric integrals. [nm]"""

PLANCK_J_S: float = 6.62607015e-34
"""Planck constant (exact, SI 2019). [J s]"""
SPEED_OF_LIGHT_M_S: float = 299792458.0
"""Speed of light in vacuum (exact). [m s-1]"""
BOLTZMANN_J_K: float = 1.380649e-23
"""Boltzmann constant (exact, SI 2019). [J K-1]"""


def planck_radiance(
    wavelength_nm: Float[ArrayLike, " w"], temperature_k: Float[ArrayLike, "*t"]
) -> Float[ArrayLike, "*t w"]:
    """Blackbody spectral radiance, Planck's law (`Planck1901`):
    `B = 2 h c² / λ⁵ / (exp(h c / (λ k T)) - 1)`, per nm. [W m⁻² sr⁻¹ nm⁻¹]

    The one implementation in bandopt. Broadcasts `temperature_k` (any shape)
    against `wavelength_nm` (last axis). NumPy in, NumPy out; a JAX array in
    either argument gives a JAX array.
    """
    jax_in = any(isinstance(a, jax.Array) for a in (wavelength_nm, temperature_k))
    xp = jnp if jax_in else np
    h, c, k = PLANCK_J_S, SPEED_OF_LIGHT_M_S, BOLTZMANN_J_K
    t = xp.asarray(temperature_k, dtype=float)[..., None]
    lam = xp.asarray(wavelength_nm, dtype=float) * 1e-9  # [m]
    lam = xp.reshape(lam, (1,) * (t.ndim - 1) + lam.shape)
    return 2 * h * c**2 / lam**5 / xp.expm1(h * c / (lam * k * t)) * 1e-9


def trapezoid_weights(wavelength_nm: Float[ArrayLike, " w"]) -> Float[Array, " w"]:
    """Weights `q` with `∫ f dλ ≈ Σ_i q_i f(λ_i)` (trapezoid rule). [nm]"""
    wavelength_nm = jnp.asarray(wavelength_nm)
    dl = jnp.diff(wavelength_nm)
    zero = jnp.zeros((1,), dl.dtype)
    return 0.5 * (jnp.concatenate([zero, dl]) + jnp.concatenate([dl, zero]))


def resample(
    wavelength_nm: ArrayLike,
    values: ArrayLike,
    new_wavelength_nm: ArrayLike,
    *,
    outside: Literal["nan", "zero", "edge"] = "nan",
) -> np.ndarray:
    """Linear interpolation of `values[..., w]` onto `new_wavelength_nm`.

    `outside` says what a sample outside `[wavelength_nm[0], wavelength_nm[-1]]`
    becomes: `"nan"` (unknown, the default), `"zero"` or `"edge"` (the end value).
    """
    x = np.asarray(wavelength_nm, float)
    y = np.asarray(values, float)
    xn = np.asarray(new_wavelength_nm, float)
    if outside not in ("nan", "zero", "edge"):
        raise ValueError(
            f"Unknown outside={outside!r}; expected one of ['edge', 'nan', 'zero']."
        )
    if x.ndim != 1 or y.shape[-1] != x.size:
        raise ValueError(
            f"`values` has {y.shape[-1]} wavelength samples but `wavelength_nm` has "
            f"{x.size}."
        )
    if np.any(np.diff(x) <= 0):
        raise ValueError("`wavelength_nm` must be strictly increasing.")
    fill = {"nan": np.nan, "zero": 0.0}.get(outside)
    flat = y.reshape(-1, x.size)
    out = np.empty((flat.shape[0], xn.size))
    for i, row in enumerate(flat):
        if fill is None:
            out[i] = np.interp(xn, x, row)
        else:
            out[i] = np.interp(xn, x, row, left=fill, right=fill)
    return out.reshape((*y.shape[:-1], xn.size))


def _strictly_increasing(wavelength_nm: ArrayLike) -> Float[Array, " w"]:
    wavelength_nm = jnp.asarray(wavelength_nm, dtype=float)
    return eqx.error_if(
        wavelength_nm,
        jnp.any(jnp.diff(wavelength_nm) <= 0),
        "`Spectrum(wavelength_nm=...)` must be strictly increasing.",
    )


class Spectrum(eqx.Module):
    """A spectral quantity sampled on a wavelength grid.

    **Attributes:**

    - `wavelength_nm`: sample wavelengths. [nm]
    - `values`: samples; the last axis is wavelength. [`unit`]
    - `unit`: physical unit of `values`, e.g. `"W m-2 sr-1 nm-1"` or `"1"`.
    - `source`: BibTeX key in `bandopt/datasets/references.bib`.
    """

    wavelength_nm: Float[Array, " w"] = eqx.field(converter=_strictly_increasing)
    values: Float[Array, "*batch w"] = eqx.field(converter=jnp.asarray)
    unit: str = eqx.field(static=True)
    source: str = eqx.field(static=True)

    def __check_init__(self):
        if self.values.shape[-1] != self.wavelength_nm.shape[0]:
            raise ValueError(
                f"`values` has {self.values.shape[-1]} wavelength samples but "
                f"`wavelength_nm` has {self.wavelength_nm.shape[0]}."
            )
