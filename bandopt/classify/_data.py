"""Scenario tables for classification: TOA spectra of every lamp scene with
their labels, and band radiance (with photon noise) for any band set.

The TOA spectra come from the factorised model of `bandopt.scene` (band terms
with identity weights, i.e. one "band" per wavelength sample), so band
radiance for a new band set is one matmul `toa @ weights.T`, the same
quadrature as `bandopt.forward.simulate(..., crop=False)`.

Photon noise follows `bandopt.sensor` (thesis Eqs. 2.16-2.19, Table 2.3):
signal electrons `e = toa @ photon_weights.T`, Gaussian noise of standard
deviation `noise_electrons(e)`, back to radiance with the flat-field
responsivity. The normal draws are *common random numbers*: one seeded draw
per scene and band (`noise_z`), so two band sets of equal size see the same
draws and a search objective is deterministic.
"""

import dataclasses

import jax.numpy as jnp
import numpy as np

from ..scene import ScenarioSet, band_terms, band_weights, lamp_scenes
from ..sensor import SensorParams, noise_electrons, photon_weights


LEVELS = ("level1", "level2")


def resolve_level(level) -> str:
    """`"level1"`/`"level2"` (also accepts 1, 2, "L1", "level-2")."""
    key = str(level).strip().lower().replace("-", "").replace("_", "").replace(" ", "")
    key = {
        "1": "level1",
        "l1": "level1",
        "level1": "level1",
        "2": "level2",
        "l2": "level2",
        "level2": "level2",
    }.get(key)
    if key is None:
        raise ValueError(f"Unknown level {level!r}; expected one of {list(LEVELS)}.")
    return key


@dataclasses.dataclass(frozen=True)
class ScenarioTable:
    """Every lamp scene of a scenario set as a row.

    - `toa`: TOA spectral radiance, `(n, w)`. [W m⁻² sr⁻¹ nm⁻¹]
    - `wavelength_nm`: `(w,)`. [nm]
    - `lamp`: lamp index of each row, `(n,)`; `lamp_ids`, `level1`, `level2`
      per lamp (`bandopt.datasets.lamps` identifiers).
    - `surface`, `atmosphere`, `moon`, `lighting_class`: condition labels, `(n,)`.
    - `config`: the scenario set's configuration.
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

    def noise_z(self, n_bands: int, seed: int) -> np.ndarray:
        """Standard normal draws `(n, n_bands)` (common random numbers)."""
        return np.random.default_rng(seed).standard_normal((self.n_rows, n_bands))

    def band_radiance(
        self,
        bands,
        *,
        noise: bool = False,
        params: SensorParams | None = None,
        seed: int = 0,
    ) -> np.ndarray:
        """Band-averaged radiance of every row, `(n, b)` [W m⁻² sr⁻¹ nm⁻¹];
        with photon noise of `params` (default Table 2.3) when `noise`."""
        resp = jnp.asarray(bands.response(self.wavelength_nm))
        z = self.noise_z(resp.shape[0], seed) if noise else None
        return np.asarray(
            radiance_from_response(
                jnp.asarray(self.toa), jnp.asarray(self.wavelength_nm), resp, z, params
            )
        )


CONDITIONS = ("surface", "atmosphere", "moon", "lighting_class")


def radiance_from_response(toa, wavelength_nm, response, noise_z=None, params=None):
    """Band radiance `(n, b)` of spectra `toa (n, w)` for responses `(b, w)`;
    photon noise from standard normal draws `noise_z (n, b)` if given. Pure
    JAX (differentiable in `response`). [W m⁻² sr⁻¹ nm⁻¹]"""
    hi = "highest"
    if noise_z is None:
        w = band_weights(response, wavelength_nm)
        return jnp.matmul(toa, w.T, precision=hi)
    params = SensorParams() if params is None else params
    pw = photon_weights(response, wavelength_nm, params, None)
    electrons = jnp.matmul(toa, pw.T, precision=hi)
    sigma = noise_electrons(electrons, params)
    resp_e = jnp.sum(pw, axis=-1)[None, :]
    ok = resp_e > 0
    noisy = electrons + sigma * jnp.asarray(noise_z, electrons.dtype)
    return jnp.where(ok, noisy / jnp.where(ok, resp_e, 1.0), 0.0)


def scenario_table(scen: ScenarioSet) -> ScenarioTable:
    """All lamp scenes of `scen` as rows (C order over lamp, surface,
    atmosphere, Moon, class). Lamps must be library ids."""
    from ..datasets.lamps import library

    f = scen.factors
    eye = jnp.eye(f.wavelength_nm.shape[0], dtype=f.lamp.dtype)
    toa = np.asarray(lamp_scenes(band_terms(f, eye)))  # (l, s, a, m, c, w)
    shape = toa.shape[:-1]
    idx = np.indices(shape).reshape(len(shape), -1)
    rec = {r.id: r for r in library().records}
    missing = [i for i in scen.lamp_ids if i not in rec]
    if missing:
        raise ValueError(f"Lamps {missing[:5]} are not in the library (no typology).")
    lvl1 = np.asarray([rec[i].level1 for i in scen.lamp_ids], dtype=object)
    lvl2 = np.asarray([rec[i].level2 for i in scen.lamp_ids], dtype=object)

    def lab(labels, axis):
        return np.asarray(labels, dtype=object)[idx[axis]]

    moons = (
        scen.moon_labels if len(scen.moon_labels) == shape[3] else ("none",) * shape[3]
    )
    return ScenarioTable(
        toa=toa.reshape(-1, toa.shape[-1]),
        wavelength_nm=np.asarray(f.wavelength_nm),
        lamp=idx[0].astype(int),
        lamp_ids=tuple(scen.lamp_ids),
        level1=lvl1,
        level2=lvl2,
        surface=lab(scen.surface_labels, 1),
        atmosphere=lab(scen.atmosphere_labels, 2),
        moon=lab(moons, 3),
        lighting_class=lab(scen.class_labels, 4),
        config=dict(scen.config),
    )
