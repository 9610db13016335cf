"""The Sun's spectrum outside the atmosphere and photopic illuminance, for
`bandopt.datasets.moon`: ASTM G173-03 extraterrestrial irradiance
(`ASTMG173`, as shipped by pvlib, `Holmgren2018`) averaged over the cells
of a working grid [W m⁻² nm⁻¹], and the illuminance `K_m ∫ E V dλ` [lx]
with the CIE 1924 `V(λ)` of colour-science (`CIE2018`, `Mansencal2025`).

Apart from the ROLO model (`moon`) because neither depends on the Moon:
they are reference spectra, each loaded once (lazily: pvlib and colour are
slow to import) and integrated exactly on the grid it is asked for.
"""

import functools

import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike, Float

from ..photometry import K_M_LM_PER_W
from ..spectra import GRID_1NM, VISIBLE_NM, trapezoid_weights


def _grid(wavelength_nm: ArrayLike, name: str = "wavelength_nm") -> np.ndarray:
    w = np.atleast_1d(np.asarray(wavelength_nm, dtype=float))
    if w.ndim != 1 or w.size == 0:
        raise ValueError(
            f"`{name}` must be a non-empty 1-D array, got shape {w.shape}."
        )
    if not np.all(np.isfinite(w)):
        raise ValueError(f"`{name}` contains NaN or infinity.")
    if np.any(np.diff(w) <= 0):
        raise ValueError(f"`{name}` must be strictly increasing.")
    return w


@functools.lru_cache(maxsize=1)
def _g173_extraterrestrial() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """ASTM G173-03 extraterrestrial spectrum and its running integral (pvlib)."""
    # start-up time: pvlib takes ~1 s to import
    import pvlib.spectrum

    table = pvlib.spectrum.get_reference_spectra(standard="ASTM G173-03")
    x = table.index.to_numpy(dtype=float)
    y = table["extraterrestrial"].to_numpy(dtype=float)
    cumulative = np.concatenate([[0.0], np.cumsum(0.5 * (y[1:] + y[:-1]) * np.diff(x))])
    return x, y, cumulative


def _g173_integral_to(x_nm: np.ndarray) -> np.ndarray:
    """Exact ∫_{280}^{x} of the piecewise-linear G173 spectrum. [W m⁻²]"""
    x, y, cumulative = _g173_extraterrestrial()
    i = np.clip(np.searchsorted(x, x_nm, side="right") - 1, 0, x.size - 2)
    dx = x_nm - x[i]
    slope = (y[i + 1] - y[i]) / (x[i + 1] - x[i])
    return cumulative[i] + y[i] * dx + 0.5 * slope * dx**2


def solar_irradiance_toa(
    wavelength_nm: ArrayLike = GRID_1NM,
) -> Float[np.ndarray, " w"]:
    """ASTM G173-03 extraterrestrial solar spectrum, grid-cell averages. [W m⁻² nm⁻¹]

    Cell edges lie halfway between grid points (half a step beyond the end
    points); the piecewise-linear G173 table is integrated exactly over each
    cell and divided by its width. One wavelength: linear interpolation.
    The cells must lie within G173's 280-4000 nm, else `ValueError`.
    References: `ASTMG173`, `Holmgren2018`.
    """
    w = _grid(wavelength_nm)
    x, y, _ = _g173_extraterrestrial()
    if w.size == 1:
        edges = w
    else:
        mid = 0.5 * (w[1:] + w[:-1])
        edges = np.concatenate(
            [[w[0] - (mid[0] - w[0])], mid, [w[-1] + (w[-1] - mid[-1])]]
        )
    if edges[0] < x[0] or edges[-1] > x[-1]:
        raise ValueError(
            f"`wavelength_nm` spans {edges[0]:g}-{edges[-1]:g} nm with its cell edges; "
            f"the ASTM G173 solar spectrum covers {x[0]:g}-{x[-1]:g} nm."
        )
    if w.size == 1:
        return np.interp(w, x, y)
    return np.diff(_g173_integral_to(edges)) / np.diff(edges)


@functools.lru_cache(maxsize=1)
def _photopic_table() -> tuple[np.ndarray, np.ndarray]:
    # start-up time: colour takes ~1.5 s to import
    import colour

    lef = colour.SDS_LEFS["CIE 1924 Photopic Standard Observer"]
    return np.asarray(lef.wavelengths, float), np.asarray(lef.values, float)


def illuminance_lx(
    irradiance_w_m2_nm: Float[ArrayLike, "*batch w"],
    wavelength_nm: Float[ArrayLike, " w"] = GRID_1NM,
) -> Float[Array, "*batch"]:
    """Illuminance `K_m ∫ E(λ) V(λ) dλ` over 380-780 nm, `K_m = 683 lm W⁻¹`. [lx]

    `V(λ)` is the CIE 1924 photopic luminous efficiency function from
    colour-science (`CIE2018`, `Mansencal2025`), linearly interpolated onto
    `wavelength_nm`; the trapezoid rule runs over the samples within
    380-780 nm, so the grid must reach both ends (else `ValueError`).
    `irradiance_w_m2_nm` may be a traced JAX array; `wavelength_nm` is static.

    - `irradiance_w_m2_nm`: spectral irradiance, last axis wavelength. [W m⁻² nm⁻¹]
    - `wavelength_nm`: its grid. [nm]
    """
    w = _grid(wavelength_nm)
    lo, hi = VISIBLE_NM
    if w[0] > lo or w[-1] < hi:
        raise ValueError(
            f"`wavelength_nm` spans {w[0]:g}-{w[-1]:g} nm; illuminance needs "
            f"{lo:g}-{hi:g} nm."
        )
    inside = (w >= lo) & (w <= hi)
    weights = np.zeros_like(w)
    weights[inside] = np.asarray(trapezoid_weights(w[inside]))
    v_x, v_y = _photopic_table()
    weights = weights * np.interp(w, v_x, v_y, left=0.0, right=0.0) * K_M_LM_PER_W
    irradiance = jnp.asarray(irradiance_w_m2_nm)
    if irradiance.shape[-1:] != w.shape:
        raise ValueError(
            f"`irradiance_w_m2_nm` has {irradiance.shape[-1:]} wavelength samples but "
            f"`wavelength_nm` has {w.size}."
        )
    return jnp.matmul(
        irradiance, jnp.asarray(weights, irradiance.dtype), precision="highest"
    )
