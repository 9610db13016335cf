"""The scenario table: every lamp scene of a scenario set as a labelled row
(lamp, level-1 and level-2 type, surface, atmosphere, Moon, lighting class),
and its dense TOA spectra."""

import dataclasses
from collections.abc import Sequence

import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Float

from ..datasets.lamps import library
from ..names import validate_method
from ..scene import ScenarioSet, band_terms, lamp_scenes
from ..sensor import SensorParams
from ._core import noise_draws


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
    - `kind`: what was done to each row's lamp spectrum, an index into
      `kinds`, `(n,)`; None when every row holds the clean spectrum. A table
      with `copies` > 1 (`scenario_table`) repeats each scene under measurement
      effects of the lamp spectrum (`bandopt.search.ScenePerturbations`);
      rows are then C order over lamp, surface, copy, atmosphere, Moon, class.
    - `kinds`: the names `kind` indexes (`"clean"` first).
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
    kind: np.ndarray | None = None
    kinds: tuple[str, ...] = ("clean",)

    def scenario_set(self) -> ScenarioSet:
        """The `ScenarioSet` behind the rows (their atmospheres, Moon states,
        neighbourhood and scenes, to light with other lamps). Raises
        `ValueError` for a table not built by `scenario_table`, or whose
        lamps are not its set's."""
        scen = self.scenarios
        if scen is None:
            raise ValueError(
                "table: no scenario set behind it (not built by "
                "bandopt.forward.scenario_table); its scenes are unknown."
            )
        if tuple(scen.lamp_ids) != tuple(self.lamp_ids):
            raise ValueError(
                "table: its lamps differ from those of its scenario set "
                "(table.scenarios); rebuild it with scenario_table."
            )
        return scen

    @property
    def n_lamps(self) -> int:
        return len(self.lamp_ids)

    @property
    def scenes_per_lamp(self) -> int:
        """Rows of each lamp (every lamp has the same scenes)."""
        return self.n_rows // max(self.n_lamps, 1)

    def per_lamp(self, values: np.ndarray) -> np.ndarray:
        """Row values `(n, ...)` grouped by lamp, `(l, q, ...)` (rows are
        lamp-major)."""
        values = np.asarray(values)
        return values.reshape(self.n_lamps, self.scenes_per_lamp, *values.shape[1:])

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
        from ._measure import measure  # the measurement is built on the table

        return np.asarray(
            measure(self, bands, sensor=params, noise=noise, key=seed).radiance
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
    spectra: np.ndarray | None = None,
    kind: np.ndarray | None = None,
    kinds: tuple[str, ...] = ("clean",),
) -> ScenarioTable:
    """All lamp scenes of `scen` as rows (C order over lamp, surface,
    atmosphere, Moon, class). Lamps must be library ids, unless their types
    are given per lamp in `level1` and `level2` (lamps outside the library,
    e.g. modelled ones: `ScenarioSet.with_lamps`).

    `spectra`: the rows' TOA spectra when they are not `scen`'s dense spectra:
    `(l, s, k, a, m, c, w)`, each scene repeated `k` times (copy 0 clean; a
    row's `kind`, `(l, s, k, a, m, c)` indices into `kinds`, says what was
    done to its lamp spectrum). Rows are then C order over lamp, surface,
    copy, atmosphere, Moon, class. [W m⁻² sr⁻¹ nm⁻¹]"""
    if spectra is None:
        toa = np.asarray(dense_spectra(scen))[:, :, None]
    else:
        toa = np.asarray(spectra)
        if kind is None or np.shape(kind) != toa.shape[:-1]:
            raise ValueError(
                f"scenario_table: spectra of scenes {toa.shape[:-1]} need a kind "
                f"of that shape, got {None if kind is None else np.shape(kind)}."
            )
    shape = toa.shape[:-1]  # (l, s, k, a, m, c)
    idx = np.indices(shape).reshape(len(shape), -1)[[0, 1, 3, 4, 5]]
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
        scen.moon_labels if len(scen.moon_labels) == shape[4] else ("none",) * shape[4]
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
        kind=None if spectra is None else np.asarray(kind, int).reshape(-1),
        kinds=tuple(kinds),
    )
