"""Tabulated band responses: `TabulatedBands`, measured or standard curves
interpolated linearly (0 outside the table), read-only.

Apart from `_parametric` because a table has no parameters to optimise:
its centres and FWHMs are derived from the table with NumPy, outside `jit`.
"""

from collections.abc import Sequence

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike, Float

from ._band_common import Numbers, _band_average_policy, _grid_ends
from ._parametric import BandSet  # the type of `from_bands`' `bands`


class TabulatedBands(eqx.Module):
    """Bands given as tabulated relative responses (measured, or standard curves).

    `response(wavelength_nm)` interpolates linearly and is **0 outside the
    table** (say in `source_note` what the table leaves out, e.g. the VIIRS DNB
    file stops at 899.5 nm). Centres (response-weighted centroids) and FWHMs
    (outermost half-maximum crossings) are derived from the table with NumPy:
    read them outside `jit`. Not optimisable.
    """

    table_wavelength_nm: Float[Array, " t"]
    table_response: Float[Array, "b t"]
    name: str = eqx.field(static=True, default="bands")
    names: tuple[str, ...] = eqx.field(static=True, default=())
    source_note: str = eqx.field(static=True, default="")

    def __check_init__(self):
        if self.table_response.ndim != 2 or (
            self.table_response.shape[1] != self.table_wavelength_nm.shape[0]
        ):
            raise ValueError(
                f"`table_response` must be (b, {self.table_wavelength_nm.shape[0]}), "
                f"got {self.table_response.shape}."
            )
        if len(self.names) != self.table_response.shape[0]:
            raise ValueError("`names` needs one entry per tabulated band.")

    @classmethod
    def from_table(
        cls,
        wavelength_nm: Numbers,
        response: Numbers,
        *,
        names: Sequence[str],
        name: str = "bands",
        source_note: str = "",
    ) -> "TabulatedBands":
        """From a table `response[b, t]` on increasing `wavelength_nm[t]` [nm]."""
        wl = np.asarray(wavelength_nm, float)
        r = np.atleast_2d(np.asarray(response, float))
        if wl.ndim != 1 or np.any(np.diff(wl) <= 0):
            raise ValueError("`wavelength_nm` must be 1-D and strictly increasing.")
        if not np.all(np.isfinite(r)) or np.any(r < 0):
            raise ValueError("`response` must be finite and non-negative.")
        return cls(
            jnp.asarray(wl),
            jnp.asarray(r),
            name=name,
            names=tuple(names),
            source_note=source_note,
        )

    @classmethod
    def from_bands(
        cls, bands: "BandSet | TabulatedBands", wavelength_nm: Numbers, **kwargs
    ) -> "TabulatedBands":
        """Tabulate any band set on `wavelength_nm` (e.g. to join it with others)."""
        r = np.asarray(bands.response(jnp.asarray(wavelength_nm, dtype=float)))
        kwargs.setdefault("names", bands.names)
        kwargs.setdefault("name", bands.name)
        return cls.from_table(wavelength_nm, r, **kwargs)

    @classmethod
    def concatenate(
        cls,
        parts: Sequence["BandSet | TabulatedBands"],
        wavelength_nm: Numbers,
        *,
        name: str,
        source_note: str = "",
    ) -> "TabulatedBands":
        """Join band sets into one table on `wavelength_nm` [nm]."""
        tables = [cls.from_bands(p, wavelength_nm) for p in parts]
        names = tuple(n for t in tables for n in t.names)
        r = np.concatenate([np.asarray(t.table_response) for t in tables])
        return cls.from_table(
            wavelength_nm, r, names=names, name=name, source_note=source_note
        )

    def __len__(self) -> int:
        return len(self.names)

    def response(self, wavelength_nm: Float[ArrayLike, " w"]) -> Float[Array, "b w"]:
        """Linear interpolation of the table, 0 outside it. [1]"""
        wl = jnp.asarray(wavelength_nm)
        wl = wl.astype(jnp.result_type(float, wl.dtype))
        interp = jax.vmap(
            lambda r: jnp.interp(wl, self.table_wavelength_nm, r, left=0.0, right=0.0)
        )
        return interp(self.table_response)

    def area_nm(self) -> Float[Array, " b"]:
        """Trapezoid area of each tabulated response. [nm]"""
        tw, tr = self.table_wavelength_nm, self.table_response
        return jnp.sum(0.5 * (tr[:, 1:] + tr[:, :-1]) * jnp.diff(tw)[None, :], axis=-1)

    def fraction_outside(
        self, wavelength_nm: Float[ArrayLike, " w"]
    ) -> Float[Array, " b"]:
        """Fraction of each table's area outside the grid's ends. [1]

        From the cumulative trapezoid area, interpolated at the grid ends.
        Response beyond the table itself is unknown and not counted.
        """
        lo, hi = _grid_ends(wavelength_nm)
        tw, tr = self.table_wavelength_nm, self.table_response
        steps = 0.5 * (tr[:, 1:] + tr[:, :-1]) * jnp.diff(tw)[None, :]
        cum = jnp.concatenate([jnp.zeros_like(tr[:, :1]), jnp.cumsum(steps, axis=1)], 1)
        total = cum[:, -1]
        at = jax.vmap(lambda c: jnp.interp(jnp.stack([lo, hi]), tw, c))(cum)
        inside = at[:, 1] - at[:, 0]
        ok = total > 0
        return jnp.where(ok, 1.0 - inside / jnp.where(ok, total, 1.0), 0.0)

    def band_average(
        self,
        spectra: Float[ArrayLike, "*batch w"],
        wavelength_nm: Float[ArrayLike, " w"],
        *,
        outside: str = "raise",
        tolerance: float = 1e-3,
    ) -> Float[Array, "*batch b"]:
        """As `BandSet.band_average`. [unit of spectra]"""
        return _band_average_policy(self, spectra, wavelength_nm, outside, tolerance)

    @property
    def centre_nm(self) -> np.ndarray:
        """Response-weighted centroid of each table. [nm]"""
        tw, tr = np.asarray(self.table_wavelength_nm), np.asarray(self.table_response)
        return np.trapezoid(tr * tw, tw, axis=-1) / np.trapezoid(tr, tw, axis=-1)

    @property
    def edges_nm(self) -> np.ndarray:
        """Outermost half-maximum crossings (linear interpolation), (b, 2). [nm]"""
        tw, tr = np.asarray(self.table_wavelength_nm), np.asarray(self.table_response)
        out = np.empty((tr.shape[0], 2))
        for i, r in enumerate(tr):
            half = 0.5 * r.max()
            idx = np.flatnonzero(r >= half)
            j0, j1 = idx[0], idx[-1]
            lo = (
                tw[j0]
                if j0 == 0
                else np.interp(half, [r[j0 - 1], r[j0]], tw[j0 - 1 : j0 + 1])
            )
            hi = (
                tw[j1]
                if j1 == tw.size - 1
                else np.interp(half, [r[j1 + 1], r[j1]], [tw[j1 + 1], tw[j1]])
            )
            out[i] = lo, hi
        return out

    @property
    def fwhm_nm(self) -> np.ndarray:
        """Distance between the outermost half-maximum crossings. [nm]"""
        e = self.edges_nm
        return e[:, 1] - e[:, 0]
