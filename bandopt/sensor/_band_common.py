"""What parametric and tabulated band sets share: the data range and bounds
a band set lives in, the numbers -> unit-interval map behind `BandSet`'s
unconstrained leaves, and the off-grid policy of a band average.

Kept apart from `_bands` (the super-Gaussian `BandSet`) and `_tabulated`
(`TabulatedBands`) so both build on one definition of the range [nm], the
FWHM floor [nm], the shape-exponent interval [1] and `outside=` handling.
"""

from collections.abc import Sequence
from typing import Any, Literal

import equinox as eqx
import jax.numpy as jnp
import numpy as np
from jaxtyping import ArrayLike

from ._slit import band_average as _band_average


DATA_RANGE_NM: tuple[float, float] = (380.0, 900.0)
"""Default data range (the library grid `GRID_1NM`). [nm]"""

MIN_FWHM_NM: float = 15.0
"""Default FWHM floor: 3x the coarsest source sampling (5 nm NIST/CIE data). [nm]"""

SHAPE_K_RANGE: tuple[float, float] = (1.5, 100.0)
"""Default open interval for the shape exponent k (2 Gaussian ... rectangle). [1]"""

Numbers = ArrayLike | Sequence[Any]
"""Numbers given as arrays, Python lists or scalars (converted with NumPy)."""

_EDGE_NUDGE = 1e-9  # a parameter exactly on a bound is moved this fraction inside


def _logit(u: np.ndarray) -> np.ndarray:
    return np.log(u) - np.log1p(-u)


def _unit(value, lo, hi, what: str, *, closed: bool) -> np.ndarray:
    """Map `value` in (lo, hi) to (0, 1); values on a bound are nudged inside
    when `closed`, anything beyond raises naming `what`."""
    value, lo, hi = (np.asarray(a, float) for a in (value, lo, hi))
    width = hi - lo
    u = np.divide(
        value - lo,
        width,
        out=np.full(np.broadcast(value, width).shape, 0.5),
        where=width > 0,
    )
    bad = (u < 0) | (u > 1) if closed else (u <= 0) | (u >= 1)
    if np.any(bad):
        raise ValueError(what)
    return np.clip(u, _EDGE_NUDGE, 1 - _EDGE_NUDGE)


def _as_1d(name: str, value) -> np.ndarray:
    arr = np.atleast_1d(np.asarray(value, dtype=float))
    if arr.ndim != 1:
        raise ValueError(f"`{name}` must be 1-D, got shape {arr.shape}.")
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"`{name}` must be finite, got {arr.tolist()}.")
    return arr


def _grid_ends(wavelength_nm):
    wavelength_nm = jnp.asarray(wavelength_nm)
    return wavelength_nm[0], wavelength_nm[-1]


def _check_outside(fraction, names, tolerance, result):
    """Raise (concrete) or `eqx.error_if` (traced) when a band loses more than
    `tolerance` of its response area off the grid."""
    try:
        frac = np.asarray(fraction)
    except Exception:  # traced: checked at run time
        return eqx.error_if(
            result,
            jnp.any(fraction > tolerance),
            f"A band's response lies more than {tolerance} outside the data grid.",
        )
    bad = [f"{n} ({f:.3g})" for n, f in zip(names, frac, strict=True) if f > tolerance]
    if bad:
        raise ValueError(
            f"Band response area outside the data grid exceeds tolerance={tolerance}: "
            f"{', '.join(bad)}. Choose outside='renormalise' (average over the "
            "on-grid part) or 'zero' (radiance off the grid counts as 0) knowingly, "
            "or extend the grid."
        )
    return result


OutsidePolicy = Literal["raise", "renormalise", "zero"]


def _band_average_policy(bands, spectra, wavelength_nm, outside, tolerance):
    if outside not in ("raise", "renormalise", "zero"):
        raise ValueError(
            f"Unknown outside={outside!r}; expected one of "
            "['raise', 'renormalise', 'zero']."
        )
    avg = _band_average(spectra, bands.response(wavelength_nm), wavelength_nm)
    if outside == "renormalise":
        return avg
    frac = bands.fraction_outside(wavelength_nm)
    if outside == "zero":
        return avg * (1.0 - frac)
    return _check_outside(frac, bands.names, tolerance, avg)
