"""The parametric band set: `BandSet`, super-Gaussian bands as a final equinox Module.

`BandSet` stores unconstrained leaves (`raw_*`) so optimisers need no bounds;
the physical parameters are properties with the bounds built in:

- `fwhm_nm = min_fwhm + (span - min_fwhm) · sigmoid(raw_fwhm)`, span = upper - lower;
- `centre_nm = lower + fwhm/2 + (span - fwhm) · sigmoid(raw_centre)`, so the
  support `centre ± fwhm/2` always lies inside `[lower_nm, upper_nm]`;
- `shape_k = min_k + (max_k - min_k) · sigmoid(raw_shape_k)`.

An optimum on one of these bounds is never "converged": the sigmoid saturates
there; record it as a bound hit.

Tabulated responses are `_tabulated.TabulatedBands`; the JSON fields a band
set is read from are checked in `_band_json`; the range and bounds both
share are `_band_common`'s.
"""

import os
from collections.abc import Sequence
from pathlib import Path

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike, Float

from ..strict_json import strict_dumps
from ._band_common import (
    DATA_RANGE_NM,
    MIN_FWHM_NM,
    SHAPE_K_RANGE,
    Numbers,
    _as_1d,
    _band_average_policy,
    _grid_ends,
    _logit,
    _unit,
)
from ._band_json import band_fields, read_json
from ._slit import (
    slit_super_gaussian,
    super_gaussian_area_nm,
    super_gaussian_fraction_outside,
)


class BandSet(eqx.Module):
    """`b` super-Gaussian bands (thesis Eq. 2.15) with bounds built in.

    Build with `from_physical`, `from_edges` or `from_json`; optimise the
    `raw_*` leaves; read physics through `centre_nm`, `fwhm_nm`, `shape_k`.
    Freeze a parameter (e.g. `k = 6`) by filtering its leaf out of the
    optimised pytree (`eqx.partition`).

    **Static fields:** `lower_nm`, `upper_nm` (the data range the supports must
    stay in) [nm], `min_fwhm_nm` [nm], `min_shape_k`, `max_shape_k` [1],
    `name` (of the set), `names` (one per band).
    """

    raw_centre: Float[Array, " b"]
    raw_fwhm: Float[Array, " b"]
    raw_shape_k: Float[Array, " b"]
    lower_nm: float = eqx.field(static=True, default=DATA_RANGE_NM[0])
    upper_nm: float = eqx.field(static=True, default=DATA_RANGE_NM[1])
    min_fwhm_nm: float = eqx.field(static=True, default=MIN_FWHM_NM)
    min_shape_k: float = eqx.field(static=True, default=SHAPE_K_RANGE[0])
    max_shape_k: float = eqx.field(static=True, default=SHAPE_K_RANGE[1])
    name: str = eqx.field(static=True, default="bands")
    names: tuple[str, ...] = eqx.field(static=True, default=())

    def __check_init__(self):
        if not self.lower_nm < self.upper_nm:
            raise ValueError(
                f"Need lower_nm < upper_nm, got {self.lower_nm} and {self.upper_nm}."
            )
        if not 0 < self.min_fwhm_nm < self.upper_nm - self.lower_nm:
            raise ValueError(
                f"min_fwhm_nm={self.min_fwhm_nm} must lie in (0, upper_nm - lower_nm)."
            )
        if not 1.0 <= self.min_shape_k < self.max_shape_k:
            raise ValueError("Need 1 <= min_shape_k < max_shape_k.")
        shapes = {self.raw_centre.shape, self.raw_fwhm.shape, self.raw_shape_k.shape}
        if len(shapes) != 1:
            raise ValueError("`raw_centre`, `raw_fwhm`, `raw_shape_k` differ in shape.")
        if len(self.names) != self.raw_centre.shape[0]:
            raise ValueError(
                f"`names` has {len(self.names)} entries for "
                f"{self.raw_centre.shape[0]} bands."
            )

    # -- construction -------------------------------------------------------
    @classmethod
    def from_physical(
        cls,
        centre_nm: Numbers,
        fwhm_nm: Numbers,
        shape_k: Numbers = 6.0,
        *,
        names: Sequence[str] | None = None,
        name: str = "bands",
        lower_nm: float = DATA_RANGE_NM[0],
        upper_nm: float = DATA_RANGE_NM[1],
        min_fwhm_nm: float = MIN_FWHM_NM,
        min_shape_k: float = SHAPE_K_RANGE[0],
        max_shape_k: float = SHAPE_K_RANGE[1],
    ) -> "BandSet":
        """Bands from centres [nm], FWHMs [nm] and shape exponents [1].

        Raises `ValueError` when a support `centre ± fwhm/2` leaves
        `[lower_nm, upper_nm]`, a FWHM is below `min_fwhm_nm` (default 15 nm,
        3x the 5 nm sampling of the packaged spectra; pass a smaller value
        explicitly to go narrower) or `k` is outside `(min_shape_k, max_shape_k)`.
        A parameter exactly on a bound is moved 1e-9 of its free span inside
        (the sigmoid cannot reach the bound itself).
        """
        centre = _as_1d("centre_nm", centre_nm)
        b = centre.shape[0]
        fwhm = np.broadcast_to(_as_1d("fwhm_nm", fwhm_nm), (b,))
        k = np.broadcast_to(_as_1d("shape_k", shape_k), (b,))
        names = (
            tuple(names) if names is not None else tuple(f"B{i + 1}" for i in range(b))
        )
        if len(names) != b:
            raise ValueError(f"`names` has {len(names)} entries for {b} bands.")
        span = upper_nm - lower_nm
        lo_edge, hi_edge = centre - fwhm / 2, centre + fwhm / 2
        for i in range(b):
            if fwhm[i] < min_fwhm_nm:
                raise ValueError(
                    f"Band {names[i]!r}: fwhm_nm={fwhm[i]:g} is below "
                    f"min_fwhm_nm={min_fwhm_nm:g} (3x the coarsest source "
                    "sampling); pass a smaller min_fwhm_nm explicitly to allow it."
                )
            tol = 1e-9 * span  # rounding of centre ± fwhm/2
            if lo_edge[i] < lower_nm - tol or hi_edge[i] > upper_nm + tol:
                raise ValueError(
                    f"Band {names[i]!r}: support {lo_edge[i]:g}-{hi_edge[i]:g} nm "
                    f"(centre ± FWHM/2) leaves the data range {lower_nm:g}-"
                    f"{upper_nm:g} nm (lower_nm/upper_nm)."
                )
            if not min_shape_k < k[i] < max_shape_k:
                raise ValueError(
                    f"Band {names[i]!r}: shape_k={k[i]:g} must lie in "
                    f"({min_shape_k:g}, {max_shape_k:g})."
                )
        msg = "FWHM must be below upper_nm - lower_nm."
        u_f = _unit(fwhm, min_fwhm_nm, span, msg, closed=True)
        u_c = _unit(
            np.clip(lo_edge, lower_nm, upper_nm - fwhm),
            lower_nm,
            lower_nm + span - fwhm,
            "unreachable",
            closed=True,
        )
        u_k = _unit(k, min_shape_k, max_shape_k, "unreachable", closed=False)
        return cls(
            raw_centre=jnp.asarray(_logit(u_c), dtype=float),
            raw_fwhm=jnp.asarray(_logit(u_f), dtype=float),
            raw_shape_k=jnp.asarray(_logit(u_k), dtype=float),
            lower_nm=float(lower_nm),
            upper_nm=float(upper_nm),
            min_fwhm_nm=float(min_fwhm_nm),
            min_shape_k=float(min_shape_k),
            max_shape_k=float(max_shape_k),
            name=name,
            names=names,
        )

    @classmethod
    def from_edges(
        cls, edges_nm: Numbers, shape_k: Numbers = 6.0, **kwargs
    ) -> "BandSet":
        """Bands from published edges `[(lower, upper), ...]` [nm], read as the
        50 % points: centre = mean of the edges, FWHM = their difference.
        Keyword arguments as in `from_physical`."""
        edges = np.asarray(edges_nm, dtype=float)
        if edges.ndim != 2 or edges.shape[1] != 2:
            raise ValueError(
                "`edges_nm` must be a list of (lower, upper) pairs, got shape "
                f"{edges.shape}."
            )
        if np.any(edges[:, 1] <= edges[:, 0]):
            raise ValueError(
                f"Every band edge pair needs lower < upper: {edges.tolist()}."
            )
        return cls.from_physical(
            edges.mean(axis=1), np.diff(edges, axis=1)[:, 0], shape_k, **kwargs
        )

    @classmethod
    def contiguous(
        cls,
        n: int,
        lower_nm: float = DATA_RANGE_NM[0],
        upper_nm: float = DATA_RANGE_NM[1],
        shape_k: float = 6.0,
        **kwargs,
    ) -> "BandSet":
        """`n` equal-width bands tiling `[lower_nm, upper_nm]`, each meeting
        the next at their 50 % points (an idealised imaging spectrometer; names
        `C1..Cn`, set name `contiguous-n`). Bands narrower than the default
        `min_fwhm_nm` are allowed: asking for `n` is asking for their width.
        Other keyword arguments as in `from_physical`."""
        if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 2:
            raise ValueError(f"n={n!r}: a contiguous band set needs an integer n >= 2.")
        if not upper_nm > lower_nm:
            raise ValueError(
                f"upper_nm={upper_nm:g} must exceed lower_nm={lower_nm:g}."
            )
        width = (upper_nm - lower_nm) / n
        kwargs.setdefault("min_fwhm_nm", min(MIN_FWHM_NM, width))
        kwargs.setdefault("names", [f"C{i + 1}" for i in range(n)])
        kwargs.setdefault("name", f"contiguous-{n}")
        centres = lower_nm + width * (np.arange(n) + 0.5)
        return cls.from_physical(
            centres,
            np.full(n, width),
            shape_k,
            lower_nm=lower_nm,
            upper_nm=upper_nm,
            **kwargs,
        )

    # -- physical parameters -------------------------------------------------
    @property
    def fwhm_nm(self) -> Float[Array, " b"]:
        span = self.upper_nm - self.lower_nm
        return self.min_fwhm_nm + (span - self.min_fwhm_nm) * jax.nn.sigmoid(
            self.raw_fwhm
        )

    @property
    def centre_nm(self) -> Float[Array, " b"]:
        fwhm = self.fwhm_nm
        free = (self.upper_nm - self.lower_nm) - fwhm
        return self.lower_nm + 0.5 * fwhm + free * jax.nn.sigmoid(self.raw_centre)

    @property
    def shape_k(self) -> Float[Array, " b"]:
        span = self.max_shape_k - self.min_shape_k
        return self.min_shape_k + span * jax.nn.sigmoid(self.raw_shape_k)

    @property
    def edges_nm(self) -> Float[Array, "b 2"]:
        """Half-maximum points `centre ± fwhm/2`. [nm]"""
        half = 0.5 * self.fwhm_nm
        return jnp.stack([self.centre_nm - half, self.centre_nm + half], axis=-1)

    def __len__(self) -> int:
        return len(self.names)

    # -- responses -----------------------------------------------------------
    def response(self, wavelength_nm: Float[ArrayLike, " w"]) -> Float[Array, "b w"]:
        """Relative spectral response on `wavelength_nm`, peak 1. [1]"""
        return slit_super_gaussian(
            wavelength_nm, self.centre_nm, self.fwhm_nm, self.shape_k
        )

    def area_nm(self) -> Float[Array, " b"]:
        """Exact response area over all wavelengths. [nm]"""
        return super_gaussian_area_nm(self.fwhm_nm, self.shape_k)

    def fraction_outside(
        self, wavelength_nm: Float[ArrayLike, " w"]
    ) -> Float[Array, " b"]:
        """Fraction of each band's response area outside the grid's ends (exact). [1]"""
        lo, hi = _grid_ends(wavelength_nm)
        return super_gaussian_fraction_outside(
            self.centre_nm, self.fwhm_nm, self.shape_k, lo, hi
        )

    def band_average(
        self,
        spectra: Float[ArrayLike, "*batch w"],
        wavelength_nm: Float[ArrayLike, " w"],
        *,
        outside: str = "raise",
        tolerance: float = 1e-3,
    ) -> Float[Array, "*batch b"]:
        """Band-averaged radiance with an explicit off-grid policy. [unit of spectra]

        `outside="raise"`: a band with more than `tolerance` of its response
        area off the grid raises `ValueError` (concrete values) or fails via
        `eqx.error_if` (traced). `"renormalise"`: average over the on-grid part
        (`band_average`). `"zero"`: radiance off the grid counts as 0 (the
        on-grid average times `1 - fraction_outside`).
        """
        return _band_average_policy(self, spectra, wavelength_nm, outside, tolerance)

    # -- input / output ------------------------------------------------------
    def to_dict(self) -> dict:
        c, f, k = (
            np.asarray(a, float) for a in (self.centre_nm, self.fwhm_nm, self.shape_k)
        )
        return {
            "name": self.name,
            "range_nm": [self.lower_nm, self.upper_nm],
            "bands": [
                {
                    "name": n,
                    "centre_nm": float(c[i]),
                    "fwhm_nm": float(f[i]),
                    "shape_k": float(k[i]),
                }
                for i, n in enumerate(self.names)
            ],
        }

    def to_json(self, path: str | os.PathLike | None = None) -> str:
        """JSON `{"name", "range_nm", "bands": [{"name", "centre_nm", "fwhm_nm",
        "shape_k"}]}`; written to `path` when given. Returns the text."""
        text = strict_dumps(self.to_dict(), indent=2) + "\n"
        if path is not None:
            Path(path).write_text(text)
        return text

    @classmethod
    def from_json(cls, source: str | os.PathLike, **kwargs) -> "BandSet":
        """Read a band set from a JSON file path (or a JSON text starting with `{`).

        Each band needs `centre_nm` and `fwhm_nm`, or `edges_nm: [lower, upper]`
        (50 % points); `shape_k` defaults to 6 (thesis) and `name` to `B<i>`.
        The descriptive fields `bandopt bands --json` adds (`SUMMARY_FIELDS`,
        `SUMMARY_BAND_FIELDS`) are ignored, so its output reads back.
        An optional top-level `range_nm: [lower, upper]` sets the data range
        unless `lower_nm`/`upper_nm` are passed; without either, a band whose
        support leaves `DATA_RANGE_NM` widens the range to its support + 1 nm
        (as the reference sensors do): how much of its response the data
        cover is the commands' check (`bandopt.cli._checks`), not a refusal
        here. Errors name the file and field.
        """
        data, label = read_json(source)
        return cls.from_dict(data, label=label, **kwargs)

    @classmethod
    def from_dict(cls, data, *, label: str = "<dict>", **kwargs) -> "BandSet":
        """As `from_json`, from an already parsed object."""
        fields = band_fields(data, label, kwargs)
        try:
            return cls.from_physical(
                fields.centres_nm,
                fields.fwhms_nm,
                fields.shape_k,
                names=fields.names,
                name=fields.name,
                **fields.kwargs,
            )
        except ValueError as err:
            raise ValueError(f"{label}: bands: {err}") from err
