"""Band radiance of anything: a scenario set (factorised contraction on the
grid cropped to the bands' support), a scenario table or dense spectra, for
any band set, noise-free and with photon noise (`BandMeasurement`)."""

import dataclasses

import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike, Float

from ..scene import (
    BandTerms,
    Factors,
    ScenarioSet,
    band_terms,
    band_weights,
    lamp_scenes,
)
from ..sensor import SensorParams, crop_to_support, photon_weights
from ._core import _noisy_radiance, band_values, noise_draws, radiance_from_response
from ._table import ScenarioTable


DEFAULT_TAIL = 1e-6
"""Responses below this fraction of a band's peak are cropped away (changes
band averages by about this much, relative)."""


@dataclasses.dataclass(frozen=True)
class BandMeasurement:
    """What `band_measurement` returns.

    - `radiance`: measured band radiance, `(*batch, b)`; noisy when noise was
      asked, else equal to `clean`. [W m⁻² sr⁻¹ nm⁻¹]
    - `clean`: noise-free band-averaged radiance, `(*batch, b)`. [W m⁻² sr⁻¹ nm⁻¹]
    - `electrons`: noise-free signal electrons `(*batch, b)`, or None. [e-]
    - `responsivity_e`: flat-field responsivity `(b,)`, or None.
      [e- per W m⁻² sr⁻¹ nm⁻¹]
    - `noise_z`: the standard normal draws `(n, b)` used, or None. [1]
    - `terms`: the noise-free `BandTerms` of a scenario set, else None.
    - `grid_nm`: first and last wavelength of the grid used. [nm]
    - `rows`: the `ScenarioTable` measured (`measure`): each row's lamp, lamp
      id, level-1 and level-2 type and scene conditions; None otherwise.
    """

    radiance: Array
    clean: Array
    electrons: Array | None
    responsivity_e: Array | None
    noise_z: Array | None
    terms: BandTerms | None
    grid_nm: tuple[float, float]
    rows: ScenarioTable | None = dataclasses.field(default=None, repr=False)

    def _table(self, what: str) -> ScenarioTable:
        if self.rows is None:
            raise ValueError(f"{what}: this measurement has no rows (use measure).")
        return self.rows

    def labels(self, level) -> np.ndarray:
        """Type of each row at `level` (`"level1"`/`"level2"`), `(n,)`."""
        return self._table("labels").labels(level)

    @property
    def lamp(self) -> np.ndarray:
        """Lamp index of each row, `(n,)` (into `rows.lamp_ids`)."""
        return self._table("lamp").lamp


def _response_on(bands, wavelength_nm) -> Array:
    if hasattr(bands, "response"):
        return jnp.asarray(bands.response(jnp.asarray(wavelength_nm)))
    resp = jnp.asarray(bands)
    if resp.ndim != 2 or resp.shape[-1] != np.shape(wavelength_nm)[-1]:
        raise ValueError(
            "bands must be a band set (with .response(wavelength_nm)) or a "
            f"response array (b, {np.shape(wavelength_nm)[-1]}) on the grid; "
            f"got shape {resp.shape}."
        )
    return resp


def band_weights_on(
    bands, wavelength_nm: Float[ArrayLike, " w"]
) -> Float[Array, "b w"]:
    """Band-averaging weights `(b, w)` of `bands` (a band set or a response
    array on the grid) on `wavelength_nm`: `scene.band_weights` of the band
    responses, the weights of every band radiance in bandopt (this module,
    and the inversion's design matrix). [1/nm-sample, rows sum to 1]"""
    wl = jnp.asarray(wavelength_nm)
    return band_weights(_response_on(bands, wl), wl)


def cropped(scen: ScenarioSet, bands, *, tail: float = DEFAULT_TAIL):
    """(factors, response) on the grid cropped to the bands' support."""
    return _cropped(scen.factors, bands, tail)


def _cropped(f: Factors, bands, tail):
    w = f.wavelength_nm
    resp = _response_on(bands, w)
    sl = crop_to_support(w, resp, tail=tail)
    fc = f.crop(float(w[sl.start]), float(w[sl.stop - 1]))
    if hasattr(bands, "response"):
        return fc, _response_on(bands, fc.wavelength_nm)
    i0 = int(np.searchsorted(np.asarray(w), float(fc.wavelength_nm[0])))
    return fc, resp[:, i0 : i0 + fc.wavelength_nm.shape[0]]


def band_measurement(
    source,
    bands,
    *,
    wavelength_nm: Float[ArrayLike, " w"] | None = None,
    sensor: SensorParams | None = None,
    noise=False,
    key=0,
    crop: bool = True,
    tail: float = DEFAULT_TAIL,
) -> BandMeasurement:
    """Band radiance of `source` for `bands`, noise-free and measured.

    **Arguments:**

    - `source`: a `ScenarioSet` or its `Factors` (factorised contraction,
      result `(l, s, a, m, c, b)`), a `ScenarioTable` (`(n, b)`), or spectra
      `(*batch, w)` with `wavelength_nm`. [W m⁻² sr⁻¹ nm⁻¹]
    - `bands`: a band set (anything with `.response(wavelength_nm)`) or a
      response array `(b, w)` on the source's grid. [1]
    - `sensor`: `SensorParams` of the photon model (default Table 2.3).
    - `noise`: False: noise-free; True: Gaussian photon noise from
      `noise_draws(key, n, b)`; or the standard normal draws `(n, b)` to use.
    - `key`: integer seed or JAX key of the draws.
    - `crop`: for a scenario set, contract only over the bands' support
      (samples below `tail` of each band's peak; changes results by ~`tail`).
    """
    terms = None
    if isinstance(source, ScenarioSet):
        source = source.factors
    if isinstance(source, Factors):
        if crop:
            f, resp = _cropped(source, bands, tail)
        else:
            f, resp = source, _response_on(bands, source.wavelength_nm)
        wl = f.wavelength_nm
        terms = band_terms(f, band_weights(resp, wl))
        clean = lamp_scenes(terms)

        def contract(weights):
            return lamp_scenes(band_terms(f, weights))

    else:
        if isinstance(source, ScenarioTable):
            spectra, wl = jnp.asarray(source.toa), source.wavelength_nm
        else:
            if wavelength_nm is None:
                raise ValueError(
                    "wavelength_nm is required when source is a spectra array."
                )
            spectra, wl = jnp.asarray(source), wavelength_nm
        wl = jnp.asarray(wl)
        if spectra.shape[-1] != wl.shape[0]:
            raise ValueError(
                f"spectra have {spectra.shape[-1]} samples, wavelength_nm "
                f"{wl.shape[0]}."
            )
        resp = _response_on(bands, wl)
        clean = radiance_from_response(spectra, wl, resp)

        def contract(weights):
            return band_values(spectra, weights)

    grid = (float(wl[0]), float(wl[-1]))
    if noise is False or noise is None:
        return BandMeasurement(clean, clean, None, None, None, terms, grid)
    sensor = SensorParams() if sensor is None else sensor
    pw = photon_weights(resp, wl, sensor, None)
    electrons = contract(pw)
    resp_e = jnp.sum(pw, axis=-1)
    b = clean.shape[-1]
    n = int(np.prod(clean.shape[:-1]))
    if noise is True:
        # the default float dtype, then cast: float32 draws are other numbers
        z = noise_draws(key, n, b).astype(electrons.dtype)
    else:
        z = jnp.asarray(noise, electrons.dtype)
        if z.shape != (n, b):
            raise ValueError(f"noise draws must have shape {(n, b)}, got {z.shape}.")
    radiance = _noisy_radiance(electrons, resp_e, z, sensor)
    return BandMeasurement(radiance, clean, electrons, resp_e, z, terms, grid)


def band_radiance(
    source,
    bands,
    *,
    wavelength_nm: Float[ArrayLike, " w"] | None = None,
    sensor: SensorParams | None = None,
    noise=False,
    key=0,
    crop: bool = True,
) -> Array:
    """Measured band radiance of `source` for `bands`:
    `band_measurement(...).radiance` (same arguments). [W m⁻² sr⁻¹ nm⁻¹]"""
    return band_measurement(
        source,
        bands,
        wavelength_nm=wavelength_nm,
        sensor=sensor,
        noise=noise,
        key=key,
        crop=crop,
    ).radiance


def measure(
    table: ScenarioTable,
    bands,
    *,
    sensor: SensorParams | None = None,
    noise=False,
    key=0,
) -> BandMeasurement:
    """Band radiance of every row of `table` for `bands`, with the rows'
    labels attached (`BandMeasurement.rows`): the radiance, noise-free value,
    electrons and noise draws of `band_measurement`, and each row's lamp, type
    and scene. `noise`, `key`, `sensor` as in `band_measurement`; draws are
    `noise_draws(key, n_rows, b)`, so a row gets the same draw whichever caller
    measures it. [W m⁻² sr⁻¹ nm⁻¹]"""
    if not isinstance(table, ScenarioTable):
        raise TypeError(
            f"measure: expected a ScenarioTable, got {type(table).__name__} "
            "(band_measurement takes scenario sets and spectra)."
        )
    m = band_measurement(table, bands, sensor=sensor, noise=noise, key=key)
    return dataclasses.replace(m, rows=table)
