"""Lamp-type prediction for any band set, trained on the built-in library
(for `bandopt evaluate`).

The training set is `TRAINING_SCENARIOS` (every scored lamp, the default
surfaces, the 6S atmospheres when installed, Moon none/full/first quarter,
four lighting classes) with photon noise of the thesis sensor (Table 2.3);
k is chosen by the outer folds of `nested_lamp_splits` (seed 0) used as
(train, validation) splits; the model is then refitted on every scene.
Models are cached per band set (by its responses on the library grid).
"""

import functools
import hashlib

import numpy as np

from ..datasets import atmosphere
from ..folds import nested_lamp_splits
from ..forward import ScenarioTable, scenario_table
from ..knn import K_GRID, choose_k, features, make_classifier
from ..scene import DEFAULT_ATMOSPHERES, build_scenarios
from ._scores import class_order


TRAINING_SCENARIOS = dict(
    moons=(None, "full", "first_quarter"), classes=("P1", "P6", "M1", "M6")
)
"""Scenario set of the evaluation and of `predict_lamp_types` (surfaces: the
`bandopt.scene` defaults)."""


def available_atmospheres(setting: str = "auto") -> tuple:
    """The scenario atmospheres an atmosphere `setting` ("auto", "6s" or
    "none") gives: the default 6S atmospheres when it resolves to "6s"
    (`datasets.atmosphere.resolve_setting`), else `("none",)`."""
    six_s = atmosphere.resolve_setting(setting) == "6s"
    return DEFAULT_ATMOSPHERES if six_s else ("none",)


@functools.lru_cache(maxsize=2)
def training_table(atmospheres: tuple | None = None) -> ScenarioTable:
    """The scenario table of `TRAINING_SCENARIOS` (cached)."""
    atms = available_atmospheres() if atmospheres is None else atmospheres
    return scenario_table(
        build_scenarios(scored_only=True, atmospheres=atms, **TRAINING_SCENARIOS)
    )


def _band_key(bands, wavelength_nm) -> str:
    r = np.asarray(bands.response(wavelength_nm), float)
    return hashlib.sha1(np.round(r, 9).tobytes()).hexdigest()


_MODELS: dict[str, dict] = {}


def _models(bands, noise: bool = True):
    table = training_table()
    key = _band_key(bands, table.wavelength_nm) + str(noise)
    if key not in _MODELS:
        rad = table.band_radiance(bands, noise=noise, seed=0)
        x = np.asarray(features(rad))
        splits = [(s.train, s.test) for s in nested_lamp_splits(table.level2, seed=0)]
        out = {}
        for level in ("level1", "level2"):
            classes = class_order(level, table.lamp_classes(level))
            cidx = {c: i for i, c in enumerate(classes)}
            y = np.asarray([cidx[c] for c in table.labels(level)])
            k, _ = choose_k(x, y, table.lamp, splits, len(classes), K_GRID)
            out[level] = (make_classifier(k).fit(x, y), classes, k)
        _MODELS[key] = out
    return _MODELS[key]


def predict_lamp_types(band_radiance, bands) -> tuple[list[str], list[str]]:
    """Level-1 and level-2 lamp types of band radiances `(n, b)`
    [W m⁻² sr⁻¹ nm⁻¹] measured with `bands` (any band set with `response`).

    One-vs-all KNN on scale-free log-ratio features, trained on the built-in
    library (see module docstring; the first call per band set builds the
    scenes and fits, later calls reuse the cache). Only scored classes can
    be predicted. Raises `ValueError` if the band count does not match.
    """
    rad = np.asarray(band_radiance, float)
    if rad.ndim == 1:
        rad = rad[None, :]
    nb = len(np.asarray(bands.response(np.array([500.0]))))
    if rad.ndim != 2 or rad.shape[1] != nb:
        raise ValueError(
            f"band_radiance must be (n, {nb}) for this band set, got {rad.shape}."
        )
    x = np.asarray(features(rad))
    models = _models(bands)
    out = []
    for level in ("level1", "level2"):
        clf, classes, _ = models[level]
        out.append([classes[i] for i in clf.predict(x)])
    return out[0], out[1]
