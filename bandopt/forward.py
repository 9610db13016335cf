"""The measurement: spectra or a scenario set + a band set -> band radiance
(optionally with photon noise and quantisation), and the scenario table with
every label.

Every part of bandopt (search, classify, radiometry, `simulate`, the
inversion) measures band radiance through this module, so the same inputs and
the same `key` give the same numbers everywhere:

- `band_values`: the one contraction, spectra `(*batch, w)` x band weights
  `(b, w)` -> `(*batch, b)`, for callers that hold the weights
  (`band_weights_on`) or weight the spectra themselves;
- `radiance_from_response`: the pure-JAX core, spectra `(n, w)` x responses
  `(b, w)` -> `(n, b)`, differentiable in the responses (searches jit it);
- `band_measurement` / `band_radiance`: the same for a `ScenarioSet`
  (factorised contraction, grid cropped to the bands' support), a
  `ScenarioTable` or dense spectra, and any band set;
- `noise_draws`: the one rule for photon-noise draws (common random numbers);
- `ScenarioTable` / `scenario_table`: every lamp scene as a labelled row.

**Noise model** (`bandopt.sensor`, thesis Eqs. 2.16-2.19, Table 2.3): signal
electrons from the exact photon integral `e = L @ photon_weightsᵀ`, Gaussian
shot/dark/read noise `e + σ(e) z`, back to radiance with the flat-field
responsivity `Σ_w photon_weights`. A band with zero responsivity on the grid
(no response, or response where the QE is zero) reads 0, not NaN.

**Draws** (`noise_draws`): `z[:, j] = normal(fold_in(key, j), (n,))`, one
standard normal per scene row and band, with `key = jax.random.PRNGKey(seed)`
for an integer seed. Rows are the scenes in C order over (lamp, surface,
atmosphere, Moon, class), so a scene gets the same draw whichever caller
measures it, and band j's draws do not depend on how many bands there are.

The grid of a scenario set is cropped statically to the union of the bands'
supports (response >= `tail` of each band's peak) before contracting.
"""

import dataclasses
from collections.abc import Sequence

import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike, Float

from .datasets.lamps import library
from .names import validate_method
from .scene import (
    BandTerms,
    Factors,
    ScenarioSet,
    band_terms,
    band_weights,
    lamp_scenes,
    mix_label,
)
from .sensor import (
    SensorParams,
    crop_to_support,
    noise_electrons,
    photon_weights,
    quantise,
)


DEFAULT_TAIL = 1e-6
"""Responses below this fraction of a band's peak are cropped away (changes
band averages by about this much, relative)."""

_HI = jax.lax.Precision.HIGHEST


# ------------------------------------------------------------------------------
# noise draws and the pure-JAX core


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


# ------------------------------------------------------------------------------
# the scenario table


LEVELS = ("level1", "level2")
CONDITIONS = ("surface", "atmosphere", "moon", "lighting_class")


_LEVEL_ALIASES = {"1": "level1", "L1": "level1", "2": "level2", "L2": "level2"}


def resolve_level(level) -> str:
    """`"level1"`/`"level2"` (also accepts 1, 2, "L1", "level-2"; case and
    separators ignored)."""
    return validate_method(level, LEVELS, "level", aliases=_LEVEL_ALIASES)


@dataclasses.dataclass(frozen=True)
class ScenarioTable:
    """Every lamp scene of a scenario set as a row (C order over lamp,
    surface, atmosphere, Moon, class: the rows of `noise_draws`).

    - `toa`: TOA spectral radiance, `(n, w)`. [W m⁻² sr⁻¹ nm⁻¹]
    - `wavelength_nm`: `(w,)`. [nm]
    - `lamp`: lamp index of each row, `(n,)`; `lamp_ids`, `level1`, `level2`
      per lamp (`bandopt.datasets.lamps` identifiers).
    - `surface`, `atmosphere`, `moon`, `lighting_class`: condition labels, `(n,)`.
    - `config`: the scenario set's configuration.
    - `scenarios`: the `ScenarioSet` the rows were built from (set by
      `scenario_table`; None for a table built otherwise). Lets a caller
      light the same scenes with other lamps (`ScenarioSet.with_lamps`), e.g.
      modelled training lamps of `bandopt.classify.evaluate_band_set`. Not
      compared by `==`.
    """

    toa: np.ndarray
    wavelength_nm: np.ndarray
    lamp: np.ndarray
    lamp_ids: tuple[str, ...]
    level1: np.ndarray
    level2: np.ndarray
    surface: np.ndarray
    atmosphere: np.ndarray
    moon: np.ndarray
    lighting_class: np.ndarray
    config: dict
    scenarios: ScenarioSet | None = dataclasses.field(
        default=None, repr=False, compare=False
    )

    @property
    def n_rows(self) -> int:
        return int(self.toa.shape[0])

    def lamp_classes(self, level) -> np.ndarray:
        """Class of each lamp at `level`, `(l,)`."""
        return self.level1 if resolve_level(level) == "level1" else self.level2

    def labels(self, level) -> np.ndarray:
        """Class of each row at `level`, `(n,)`."""
        return self.lamp_classes(level)[self.lamp]

    def condition(self, factor: str) -> np.ndarray:
        """Labels of one condition factor (`surface`, `atmosphere`, `moon`,
        `lighting_class`), `(n,)`."""
        if factor not in CONDITIONS:
            raise ValueError(
                f"Unknown factor {factor!r}; expected one of {list(CONDITIONS)}."
            )
        return getattr(self, factor)

    def rows_of_lamps(self, lamps) -> np.ndarray:
        """Boolean row mask of the given lamp indices."""
        return np.isin(self.lamp, np.asarray(lamps, int))

    def noise_z(self, n_bands: int, seed) -> np.ndarray:
        """`noise_draws(seed, n_rows, n_bands)` (common random numbers)."""
        return np.asarray(noise_draws(seed, self.n_rows, n_bands))

    def band_radiance(
        self,
        bands,
        *,
        noise: bool = False,
        params: SensorParams | None = None,
        seed=0,
    ) -> np.ndarray:
        """`band_radiance(self, bands, ...)`: every row, `(n, b)`
        [W m⁻² sr⁻¹ nm⁻¹]; with photon noise of `params` (default Table 2.3)
        drawn from `seed` when `noise`."""
        return np.asarray(
            band_radiance(self, bands, sensor=params, noise=noise, key=seed)
        )


def dense_spectra(scen: ScenarioSet) -> Float[Array, "l s a m c w"]:
    """TOA spectral radiance of every lamp scene, `(l, s, a, m, c, w)`, from
    the factorised model (`band_terms` with identity weights, i.e. sampling
    each wavelength). Memory grows with scenes x wavelengths: for the search
    and classification sets, not for large simulations."""
    f = scen.factors
    eye = jnp.eye(f.wavelength_nm.shape[0], dtype=f.lamp.dtype)
    return lamp_scenes(band_terms(f, eye))


def scenario_table(
    scen: ScenarioSet,
    *,
    level1: Sequence[str] | None = None,
    level2: Sequence[str] | None = None,
) -> ScenarioTable:
    """All lamp scenes of `scen` as rows (C order over lamp, surface,
    atmosphere, Moon, class). Lamps must be library ids, unless their types
    are given per lamp in `level1` and `level2` (lamps outside the library,
    e.g. modelled ones: `ScenarioSet.with_lamps`)."""
    toa = np.asarray(dense_spectra(scen))
    shape = toa.shape[:-1]
    idx = np.indices(shape).reshape(len(shape), -1)
    if (level1 is None) != (level2 is None):
        raise ValueError("scenario_table: give both level1 and level2, or neither.")
    if level1 is not None:
        n = len(scen.lamp_ids)
        if len(level1) != n or len(level2) != n:
            raise ValueError(
                f"scenario_table: {n} lamps but {len(level1)} level-1 and "
                f"{len(level2)} level-2 labels."
            )
        lvl1 = np.asarray(level1, dtype=object)
        lvl2 = np.asarray(level2, dtype=object)
    else:
        rec = {r.id: r for r in library().records}
        missing = [i for i in scen.lamp_ids if i not in rec]
        if missing:
            raise ValueError(
                f"Lamps {missing[:5]} are not in the library (no typology): "
                "give level1 and level2."
            )
        lvl1 = np.asarray([rec[i].level1 for i in scen.lamp_ids], dtype=object)
        lvl2 = np.asarray([rec[i].level2 for i in scen.lamp_ids], dtype=object)

    def lab(labels, axis):
        return np.asarray(labels, dtype=object)[idx[axis]]

    moons = (
        scen.moon_labels if len(scen.moon_labels) == shape[3] else ("none",) * shape[3]
    )
    return ScenarioTable(
        toa=toa.reshape(-1, toa.shape[-1]),
        wavelength_nm=np.asarray(scen.factors.wavelength_nm),
        lamp=idx[0].astype(int),
        lamp_ids=tuple(scen.lamp_ids),
        level1=lvl1,
        level2=lvl2,
        surface=lab(scen.surface_labels, 1),
        atmosphere=lab(scen.atmosphere_labels, 2),
        moon=lab(moons, 3),
        lighting_class=lab(scen.class_labels, 4),
        config=dict(scen.config),
        scenarios=scen,
    )


# ------------------------------------------------------------------------------
# band radiance of anything


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
    """

    radiance: Array
    clean: Array
    electrons: Array | None
    responsivity_e: Array | None
    noise_z: Array | None
    terms: BandTerms | None
    grid_nm: tuple[float, float]


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


# ------------------------------------------------------------------------------
# simulate


@dataclasses.dataclass(frozen=True)
class Simulation:
    """Band radiances of a scenario set.

    - `radiance`: (lamp, surface, atmosphere, moon, class, band)
      [W m⁻² sr⁻¹ nm⁻¹], noisy and/or quantised (then dequantised) if asked.
    - `electrons`: signal electrons (same shape) when `noise=True`, else None.
    - `terms`: the noise-free `BandTerms` (for moon-only and fire scenes).
    - `band_names`, `config`.
    """

    radiance: np.ndarray
    electrons: np.ndarray | None
    terms: BandTerms
    band_names: tuple[str, ...]
    config: dict


def simulate(
    scen: ScenarioSet,
    bands,
    *,
    noise: bool = False,
    params: SensorParams | None = None,
    seed: int = 0,
    bits: int | None = None,
    limits: tuple[np.ndarray, np.ndarray] | None = None,
    crop: bool = True,
) -> Simulation:
    """Band-averaged TOA radiance of every lamp scene of `scen` for `bands`.

    `noise`: photon model of `bandopt.sensor` with `params` (default the
    thesis's Table 2.3) as in `band_measurement`, draws from `seed`
    (`noise_draws`). `bits`: quantise between `limits = (L_min, L_max)` per
    band (default: the noise-free minimum and maximum of this set, stated in
    `config`) and dequantise.
    """
    params = SensorParams() if params is None else params
    m = band_measurement(scen, bands, sensor=params, noise=noise, key=seed, crop=crop)
    radiance = m.radiance
    config = {
        "noise": noise,
        "seed": seed,
        "bits": bits,
        "crop": crop,
        "grid_nm": list(m.grid_nm),
    }
    if noise:
        config["noise_draws"] = "bandopt.forward.noise_draws(seed, scenes, bands)"
        config["sensor"] = {
            fld.name: np.asarray(getattr(params, fld.name)).tolist()
            for fld in dataclasses.fields(params)
        }
    if bits is not None:
        if limits is None:
            clean = m.clean
            lo = jnp.min(clean, axis=tuple(range(clean.ndim - 1)))
            hi = jnp.max(clean, axis=tuple(range(clean.ndim - 1)))
            config["limits_rule"] = (
                "noise-free min and max of this scenario set per band"
            )
        else:
            lo, hi = (jnp.asarray(x) for x in limits)
        lead = (1,) * (radiance.ndim - 1)
        lo, hi = lo.reshape((*lead, -1)), hi.reshape((*lead, -1))
        dn = quantise(radiance, lo, hi, bits)
        radiance = lo + dn * (hi - lo) / (2**bits - 1)
        config["limits"] = [
            np.asarray(lo).ravel().tolist(),
            np.asarray(hi).ravel().tolist(),
        ]
    names = tuple(getattr(bands, "names", ())) or tuple(
        f"B{i + 1}" for i in range(radiance.shape[-1])
    )
    return Simulation(
        np.asarray(radiance),
        None if m.electrons is None else np.asarray(m.electrons),
        m.terms,
        names,
        config,
    )


def lamp_levels(scen: ScenarioSet) -> tuple[list, list]:
    """Level-1 and level-2 label of every lamp of `scen`: a library lamp's
    classes; a mixed lamp (`build_scenarios` entry ``(a, b, f)``, id
    ``"a+b@f"``) gets its components' shared class, or ``"class_a+class_b@f"``
    (`scene.mix_label`) when they differ. Raises `ValueError` naming a lamp
    that is neither (a lamp given by `ScenarioSet.with_lamps`: its classes are
    the caller's)."""
    rec = {r.id: r for r in library().records}
    mixes = {
        mix_label(a, b, float(f)): (a, b, float(f))
        for a, b, f in scen.config.get("lamp_mixtures", ())
    }
    level1, level2 = [], []
    for lamp_id in scen.lamp_ids:
        if lamp_id in rec:
            level1.append(rec[lamp_id].level1)
            level2.append(rec[lamp_id].level2)
        elif lamp_id in mixes and all(x in rec for x in mixes[lamp_id][:2]):
            a, b, f = mixes[lamp_id]
            for out, level in ((level1, "level1"), (level2, "level2")):
                la, lb = getattr(rec[a], level), getattr(rec[b], level)
                out.append(la if la == lb else mix_label(str(la), str(lb), f))
        else:
            raise ValueError(
                f"Lamp {lamp_id!r} is neither a library lamp nor a mix of two: its "
                "classes are unknown (give them to scenario_table)."
            )
    return level1, level2


def to_frame(scen: ScenarioSet, sim: Simulation):
    """A pandas DataFrame: one row per lamp scene, label columns (lamp id,
    level1, level2 as in `lamp_levels`, surface, atmosphere, moon, class,
    illuminance) and one radiance column per band [W m⁻² sr⁻¹ nm⁻¹]."""
    import pandas as pd  # pandas only for this export (start-up time)

    level1, level2 = lamp_levels(scen)
    shape = sim.radiance.shape[:-1]
    idx = np.indices(shape).reshape(len(shape), -1)
    frame = {
        "lamp": np.asarray(scen.lamp_ids, dtype=object)[idx[0]],
        "level1": np.asarray(level1, dtype=object)[idx[0]],
        "level2": np.asarray(level2, dtype=object)[idx[0]],
        "surface": np.asarray(scen.surface_labels, dtype=object)[idx[1]],
        "atmosphere": np.asarray(scen.atmosphere_labels, dtype=object)[idx[2]],
        "moon": np.asarray(scen.moon_labels, dtype=object)[idx[3]],
        "lighting_class": np.asarray(scen.class_labels, dtype=object)[idx[4]],
        "illuminance_lx": np.asarray(scen.factors.illuminance_lx)[idx[4]],
    }
    flat = sim.radiance.reshape(-1, sim.radiance.shape[-1])
    for j, name in enumerate(sim.band_names):
        frame[f"L_{name}"] = flat[:, j]
    return pd.DataFrame(frame)
