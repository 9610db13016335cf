"""Band sets as final equinox Modules: parametric (super-Gaussian) and tabulated.

`BandSet` stores unconstrained leaves (`raw_*`) so optimisers need no bounds;
the physical parameters are properties with the bounds built in:

- `fwhm_nm = min_fwhm + (span - min_fwhm) · sigmoid(raw_fwhm)`, span = upper - lower;
- `centre_nm = lower + fwhm/2 + (span - fwhm) · sigmoid(raw_centre)`, so the
  support `centre ± fwhm/2` always lies inside `[lower_nm, upper_nm]`;
- `shape_k = min_k + (max_k - min_k) · sigmoid(raw_shape_k)`.

An optimum on one of these bounds is never "converged": the sigmoid saturates
there; record it as a bound hit.
"""

import csv
import json
import os
from collections.abc import Sequence
from pathlib import Path
from typing import Any, Literal

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike, Float

from ..spectra import GRID_1NM
from ._slit import (
    band_average as _band_average,
    slit_super_gaussian,
    super_gaussian_area_nm,
    super_gaussian_fraction_outside,
)


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


SUMMARY_FIELDS = frozenset(
    {
        "kind",
        "grid_nm",
        "key",
        "title",
        "gsd_m",
        "bit_depth",
        "detection_limit_w_m2_sr_nm",
        "citations",
        "response",
        "note",
    }
)
"""Top-level fields of `bandopt bands --json` that describe a band set
without defining it; `BandSet.from_dict` ignores them."""

SUMMARY_BAND_FIELDS = frozenset({"half_max_edges_nm", "fraction_outside_grid"})
"""Per-band fields of `bandopt bands --json` that `from_dict` ignores."""


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
        text = json.dumps(self.to_dict(), indent=2) + "\n"
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
        text_given = isinstance(source, str) and source.lstrip().startswith("{")
        label = "<json text>" if text_given else str(source)
        try:
            text = source if text_given else Path(source).read_text()
        except UnicodeDecodeError:
            raise ValueError(
                f"{label}: not a band-set JSON file (not UTF-8 text)."
            ) from None
        except OSError as err:
            raise ValueError(f"{label}: cannot read band-set file ({err}).") from err
        try:
            data = json.loads(text)
        except json.JSONDecodeError as err:
            raise ValueError(f"{label}: invalid JSON ({err}).") from err
        return cls.from_dict(data, label=label, **kwargs)

    @classmethod
    def from_dict(cls, data, *, label: str = "<dict>", **kwargs) -> "BandSet":
        """As `from_json`, from an already parsed object."""

        def fail(field, problem):
            raise ValueError(f"{label}: {field}: {problem}")

        def number(field, value, positive=False):
            if isinstance(value, bool) or not isinstance(value, int | float):
                fail(field, f"expected a number, got {value!r}")
            if not np.isfinite(value) or (positive and value <= 0):
                fail(
                    field,
                    f"expected a {'positive ' if positive else ''}finite "
                    f"number, got {value!r}",
                )
            return float(value)

        if not isinstance(data, dict):
            fail("<top level>", "expected an object with 'name' and 'bands'")
        if data.get("kind") == "tabulated":
            fail(
                "kind",
                "a tabulated response (`bandopt bands --json` of a tabulated "
                "sensor) has no centre/FWHM form; give the sensor's name instead",
            )
        unknown = set(data) - {"name", "bands", "range_nm", *SUMMARY_FIELDS}
        if unknown:
            fail(sorted(unknown)[0], "unknown field; expected name, bands, range_nm")
        name = data.get("name", Path(label).stem)
        if not isinstance(name, str):
            fail("name", f"expected a string, got {name!r}")
        if "range_nm" in data:
            rng = data["range_nm"]
            if not (isinstance(rng, list) and len(rng) == 2):
                fail("range_nm", f"expected [lower, upper], got {rng!r}")
            kwargs.setdefault("lower_nm", number("range_nm[0]", rng[0]))
            kwargs.setdefault("upper_nm", number("range_nm[1]", rng[1]))
        bands = data.get("bands")
        if not isinstance(bands, list) or not bands:
            fail("bands", "expected a non-empty list of band objects")
        names, centres, fwhms, ks = [], [], [], []
        for i, band in enumerate(bands):
            where = f"bands[{i}]"
            if not isinstance(band, dict):
                fail(where, f"expected an object, got {band!r}")
            extra = set(band) - {
                "name",
                "centre_nm",
                "fwhm_nm",
                "shape_k",
                "edges_nm",
                *SUMMARY_BAND_FIELDS,
            }
            if extra:
                fail(
                    f"{where}.{sorted(extra)[0]}",
                    "unknown field; expected name, "
                    "centre_nm, fwhm_nm, shape_k or edges_nm",
                )
            bname = band.get("name", f"B{i + 1}")
            if not isinstance(bname, str):
                fail(f"{where}.name", f"expected a string, got {bname!r}")
            if "edges_nm" in band:
                if "centre_nm" in band or "fwhm_nm" in band:
                    fail(where, "give either edges_nm or centre_nm/fwhm_nm, not both")
                e = band["edges_nm"]
                if not (isinstance(e, list) and len(e) == 2):
                    fail(f"{where}.edges_nm", f"expected [lower, upper], got {e!r}")
                lo = number(f"{where}.edges_nm[0]", e[0])
                hi = number(f"{where}.edges_nm[1]", e[1])
                if hi <= lo:
                    fail(f"{where}.edges_nm", f"need lower < upper, got {e!r}")
                centre, fwhm = 0.5 * (lo + hi), hi - lo
            else:
                for f in ("centre_nm", "fwhm_nm"):
                    if f not in band:
                        fail(f"{where}.{f}", "missing (or give edges_nm)")
                centre = number(f"{where}.centre_nm", band["centre_nm"])
                fwhm = number(f"{where}.fwhm_nm", band["fwhm_nm"], positive=True)
            k = number(f"{where}.shape_k", band.get("shape_k", 6.0), positive=True)
            names.append(bname)
            centres.append(centre)
            fwhms.append(fwhm)
            ks.append(k)
        if len(set(names)) != len(names):
            fail("bands[].name", f"band names must be unique, got {names}")
        lo_edge = min(c - f / 2 for c, f in zip(centres, fwhms, strict=True))
        hi_edge = max(c + f / 2 for c, f in zip(centres, fwhms, strict=True))
        if lo_edge < DATA_RANGE_NM[0]:  # the reference sensors' rule (_edges)
            kwargs.setdefault("lower_nm", lo_edge - 1.0)
        if hi_edge > DATA_RANGE_NM[1]:
            kwargs.setdefault("upper_nm", hi_edge + 1.0)
        try:
            return cls.from_physical(
                centres, fwhms, ks, names=names, name=name, **kwargs
            )
        except ValueError as err:
            raise ValueError(f"{label}: bands: {err}") from err


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


Bands = BandSet | TabulatedBands
"""Anything with `names`, `response(wavelength_nm)` and `fraction_outside(...)`."""


def export_response_csv(
    bands: Bands,
    path: str | os.PathLike,
    wavelength_nm: Numbers | None = None,
) -> Path:
    """Write each band's response as a CSV table: `wavelength_nm,<band names...>`.

    Default grid `GRID_1NM` (380-900 nm, 1 nm). Returns the path.
    """
    wl = np.asarray(GRID_1NM if wavelength_nm is None else wavelength_nm, float)
    r = np.asarray(bands.response(jnp.asarray(wl)))
    path = Path(path)
    with path.open("w", newline="") as fh:
        writer = csv.writer(fh)
        writer.writerow(["wavelength_nm", *bands.names])
        for j, w in enumerate(wl):
            writer.writerow([f"{w:g}", *(f"{v:.8g}" for v in r[:, j])])
    return path


__all__ = [
    "DATA_RANGE_NM",
    "MIN_FWHM_NM",
    "SHAPE_K_RANGE",
    "BandSet",
    "Bands",
    "TabulatedBands",
    "export_response_csv",
]
