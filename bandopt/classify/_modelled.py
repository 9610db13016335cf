"""Modelled training lamps for the KNN classifier: the table's
scenes lit by modelled lamps, as extra training rows.

`modelled_rows` samples lamps of the rare classes from the physical lamp
models (`bandopt.inversion.modelled_lamps`: each model calibrated ONLY on
the measured lamps it is given, the training lamps of one fold), lights the
table's own scenes with them (`ScenarioSet.with_lamps`, the same surfaces,
atmospheres, Moon states and lighting classes) and measures them through the
same forward model as the measured rows (`ScenarioTable.band_radiance`).
They only ever train: no modelled lamp is a test lamp, and a modelled lamp id
is never a table lamp id (checked).

**Noise draws.** The measured rows of a table take `noise_draws(seed, n, b)`
(`bandopt.forward`). Modelled rows take their own draws,
`noise_draws(modelled_noise_key(seed, stream), m, b)` with
`modelled_noise_key(seed, stream) = fold_in(fold_in(PRNGKey(seed),
MODELLED_NOISE_TAG), stream)`: a stream per set of modelled lamps (one per
inner and outer training set), never the draws of a measured row of any
integer seed (a measured row's band j uses `fold_in(PRNGKey(seed), j)`).
"""

import dataclasses
from collections.abc import Sequence

import jax
import numpy as np

from .. import inversion as inv_mod
from ..forward import ScenarioTable, band_weights_on, scenario_table


MODELLED_NOISE_TAG = 0x6D6F6465
"""`fold_in` tag of the modelled rows' noise stream (ASCII "mode", a uint32
far above any band index, so never the key of a measured row's band)."""


def modelled_noise_key(seed: int, stream: int):
    """JAX key of the photon-noise draws of the modelled rows of set `stream`
    for noise seed `seed` (module docstring)."""
    base = jax.random.fold_in(jax.random.PRNGKey(int(seed)), MODELLED_NOISE_TAG)
    return jax.random.fold_in(base, int(stream))


@dataclasses.dataclass(frozen=True)
class ModelledRows:
    """Training rows of modelled lamps under a table's scenes.

    - `radiance`: band radiance `(m, b)`, noisy when asked. [W m⁻² sr⁻¹ nm⁻¹]
    - `table`: the `ScenarioTable` of the modelled lamps (labels per lamp,
      conditions per row), or None when no class got lamps.
    - `info`: the record of `bandopt.inversion.modelled_lamps` (lamps added
      per class, calibration lamps per class, skipped classes).
    """

    radiance: np.ndarray
    table: ScenarioTable | None
    info: dict

    @property
    def n_rows(self) -> int:
        return int(self.radiance.shape[0])

    def labels(self, level) -> np.ndarray:
        """Class of each row at `level`, `(m,)` (empty without lamps)."""
        if self.table is None:
            return np.zeros(0, dtype=object)
        return self.table.labels(level)


TABLE_CACHE_SIZE = 9
"""Modelled-lamp tables kept per process (`_modelled_table`): one lamp
partition's 3 outer x (2 inner + 1) training sets, so scoring several band
sets on the same partition builds each set's scenes once (~30 MB each for 20
lamps on the 336 scenes of the evaluation table)."""

_TABLES: dict = {}


def _modelled_table(scen, train_ids, n_per_class, classes, seed):
    """(lamps, info, their ScenarioTable or None) of `modelled_lamps(train_ids,
    ...)` under the scenes of `scen`; the last `TABLE_CACHE_SIZE` kept (the
    key holds the scenario set itself, compared by identity)."""
    key = (id(scen), train_ids, n_per_class, classes, seed)
    hit = _TABLES.get(key)
    if hit is not None and hit[0] is scen:
        return hit[1]
    grid = np.asarray(scen.factors.wavelength_nm)
    lamps, info = inv_mod.modelled_lamps(
        list(train_ids), grid, n_per_class, classes=list(classes), seed=seed
    )
    mtable = None
    if lamps.ids:
        mtable = scenario_table(
            scen.with_lamps(lamps.ids, lamps.spectra),
            level1=list(lamps.level1),
            level2=list(lamps.level2),
        )
    while len(_TABLES) >= TABLE_CACHE_SIZE:
        _TABLES.pop(next(iter(_TABLES)))
    _TABLES[key] = (scen, (lamps, info, mtable))
    return lamps, info, mtable


def modelled_rows(
    table: ScenarioTable,
    train_lamps,
    bands,
    n_per_class: int,
    *,
    classes: Sequence[str] = inv_mod.MODELLED_CLASSES,
    seed: int = 0,
    stream: int = 0,
    noise: bool = True,
    params=None,
) -> ModelledRows:
    """`n_per_class` modelled lamps per class of `classes`, calibrated only on
    the measured lamps among `train_lamps` (indices into `table.lamp_ids`),
    lighting every scene of `table`, measured with `bands`.

    Lamp spectra from `bandopt.inversion.modelled_lamps(train ids, grid,
    n_per_class, classes=classes, seed=seed)`; a class with fewer than
    `MIN_CALIBRATION_LAMPS` measured training lamps gets none (`info
    ["skipped"]`). Photon noise of `params` (default Table 2.3) when `noise`,
    drawn from `modelled_noise_key(seed, stream)`.

    Raises `ValueError` when the table has no scenario set behind it (not
    built by `scenario_table`) or its lamps are not that set's, and
    `RuntimeError` if a model was calibrated on a lamp outside
    `train_lamps` or a modelled lamp would carry a class or id the table
    cannot score (leaks, never expected).
    """
    scen = table.scenario_set()
    train_ids = [table.lamp_ids[i] for i in np.asarray(train_lamps, int)]
    lamps, info, mtable = _modelled_table(
        scen, tuple(train_ids), int(n_per_class), tuple(classes), int(seed)
    )
    leaked = {
        c: sorted(set(cal) - set(train_ids))
        for c, cal in info["calibration_lamps"].items()
        if not set(cal) <= set(train_ids)
    }
    if leaked:
        raise RuntimeError(f"models calibrated outside the training lamps: {leaked}")
    n_bands = int(band_weights_on(bands, table.wavelength_nm).shape[0])
    if not lamps.ids:
        return ModelledRows(np.zeros((0, n_bands)), None, info)
    if set(lamps.ids) & set(table.lamp_ids):
        raise RuntimeError("a modelled lamp id is also a measured lamp's id.")
    unknown = sorted(set(lamps.level2) - set(table.level2))
    if unknown:
        raise RuntimeError(f"modelled lamps of classes {unknown} the table lacks.")
    rad = mtable.band_radiance(
        bands, noise=noise, params=params, seed=modelled_noise_key(seed, stream)
    )
    return ModelledRows(np.asarray(rad, float), mtable, info)
