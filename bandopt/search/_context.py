"""The scenario context of a band search: the presets (`PRESETS`), the
`Context` they build (spectra, lamp table, nested splits, noise setting)
and `get_context`, which builds one per process and caches it.

Apart from `_task` (one search) because every study reads a context (the
stability study, the robustness study, the inversion's fit on a search's
scenes), not only a task. Radiance levels are in [W m-2 sr-1 nm-1].
"""

import dataclasses
import functools
import math

import numpy as np

from ..datasets import atmosphere
from ..datasets.lamps import library
from ..estimate import LampTable, lamp_truth
from ..folds import N_INNER_FOLDS, N_OUTER_FOLDS, Folds, lamp_folds
from ..forward import ScenarioTable, band_radiance, scenario_table
from ..inversion import library_lamps
from ..scene import LIGHTING_CLASSES, build_scenarios
from ._perturbed import KINDS, MEASURED_SPECTRA, perturbed_scenes


PRESETS = {
    # scenario presets: surfaces x atmospheres x moons x classes (scored lamps),
    # optionally `perturbations` (a `ScenePerturbations`)
    "search": dict(
        surfaces=("asphalt", "concrete_roof_tile", "grass", "soil"),
        moons=(None, "full"),
        classes=("P1", "P6"),
    ),
    "search_perturbed": dict(
        surfaces=("asphalt", "concrete_roof_tile", "grass", "soil"),
        moons=(None, "full"),
        classes=("P1", "P6"),
        perturbations=MEASURED_SPECTRA,
    ),
    "quick": dict(surfaces=("asphalt", "grass"), moons=(None,), classes=("P4",)),
    "tiny": dict(surfaces=("asphalt",), moons=(None,), classes=("P4",)),
}
"""Scenario presets. Atmospheres: two 6S atmospheres when the tables are
installed (`ATMOSPHERES_6S`), otherwise none (recorded in every result).
`search_perturbed`: the `search` scenes, each repeated under measurement
effects of the lamp spectrum (`MEASURED_SPECTRA`)."""

ATMOSPHERES_6S = (
    ("midlatitude_summer", "urban", 23.0),
    ("tropical", "continental", 10.0),
)

N_OUTER, N_INNER = N_OUTER_FOLDS, N_INNER_FOLDS


@dataclasses.dataclass(frozen=True)
class Context:
    """A scenario table ready for searches and estimators: every scene as a
    labelled row (`scenes`, a `bandopt.forward.ScenarioTable`), the nested
    lamp splits (`folds`), each lamp's true metrics, and the photon-noise
    setting.

    - `preset`: the scenario preset (`PRESETS`); `config` records it.
    - `scenes`: rows lamp-major; a preset with `perturbations` repeats each
      scene under them (`ScenarioTable.kind` indexes `KINDS`; layout surface x
      copy x atmosphere x Moon x class per lamp, copy 0 the clean spectrum).
    - `folds`: `bandopt.folds.Folds` over the lamps, stratified by level-2 type.
    - `truth`, `valid`: LER, G, CCT of each lamp and whether defined, `(l, 3)`.
    - `noise`: photon noise on; `noise_radiance`: the level every scene is
      scaled to before noise, or None. [W m⁻² sr⁻¹ nm⁻¹]

    The searches' views: `toa` `(l, q, w)`, `table` (`LampTable`), `splits`
    (the folds), `scene_kind` `(l, q)`, `lamp_ids`, `wavelength_nm`."""

    preset: str
    scenes: ScenarioTable
    folds: Folds
    truth: np.ndarray
    valid: np.ndarray
    config: dict
    noise: bool
    noise_radiance: float | None

    @property
    def toa(self) -> np.ndarray:
        """TOA spectra of each lamp's scenes, `(l, q, w)`. [W m⁻² sr⁻¹ nm⁻¹]"""
        return self.scenes.per_lamp(self.scenes.toa)

    @property
    def wavelength_nm(self) -> np.ndarray:
        return self.scenes.wavelength_nm

    @property
    def lamp_ids(self) -> tuple[str, ...]:
        return self.scenes.lamp_ids

    @property
    def splits(self) -> Folds:
        return self.folds

    @property
    def scene_kind(self) -> np.ndarray:
        """Index into `KINDS` of each scene's lamp spectrum, `(l, q)`."""
        kind = self.scenes.kind
        if kind is None:
            return np.zeros((self.scenes.n_lamps, self.scenes.scenes_per_lamp), int)
        return self.scenes.per_lamp(kind)

    @functools.cached_property
    def table(self) -> LampTable:
        """Per-row lamp index, level-2 type per lamp and true metrics, for
        lamp-grouped fits."""
        return LampTable(self.scenes.lamp, self.scenes.level2, self.truth, self.valid)

    def radiance(self, bands, *, seed: int = 0) -> np.ndarray:
        """Band-averaged radiance `(N, b)` of every scene for any band set
        (`BandSet` or `TabulatedBands`; response on the 380-900 nm grid,
        averaged over its on-grid part), noisy when the context has noise.

        Evaluation draws come from `seed + EVALUATION_SEED_OFFSET`, so a band
        set found with the search draws of `seed` is scored on fresh noise."""
        return self.radiance_of(self.toa, bands, seed=seed)

    def radiance_of(self, toa, bands, *, seed: int = 0) -> np.ndarray:
        """`radiance` for other spectra under this context's scenes, e.g.
        modelled lamps' `(m, q, w)` (same scaling to the noise level, same
        noise rule, draws from `seed + EVALUATION_SEED_OFFSET`: give a seed
        of its own to keep them apart from the measured rows' draws)."""
        toa = np.asarray(toa).reshape(-1, np.shape(toa)[-1])
        if self.noise_radiance is not None:
            toa = _scale_to(toa, self.wavelength_nm, self.noise_radiance)
        return np.asarray(
            band_radiance(
                toa,
                bands,
                wavelength_nm=self.wavelength_nm,
                noise=self.noise,
                key=seed + EVALUATION_SEED_OFFSET,
            )
        )


EVALUATION_SEED_OFFSET = 7919
"""`Context.radiance(seed=s)` draws its noise from seed `s + 7919`: held-out
scoring never reuses the draws the search of seed `s` was fitted on."""


def _scale_to(toa, wl, level):
    band = (wl >= 400) & (wl <= 900)
    return toa * (level / toa[:, band].mean(axis=1))[:, None]


def parse_noise(level: str | None) -> tuple[dict, bool, float | None]:
    """`--noise LEVEL` -> (preset overrides, noise on, radiance level)."""
    if level is None or str(level).lower() in ("", "none"):
        return {}, False, None

    key = str(level).strip().upper()
    if key in LIGHTING_CLASSES:
        return {"classes": (key,), "moons": (None,)}, True, None
    try:
        value = float(level)
    except ValueError:
        raise ValueError(
            f"--noise {level!r}: expected an EN 13201 class "
            f"{list(LIGHTING_CLASSES)} or a radiance [W m-2 sr-1 nm-1]."
        ) from None
    if not (value > 0 and math.isfinite(value)):
        raise ValueError(
            f"--noise {level!r}: a radiance level must be finite and > 0 "
            "[W m-2 sr-1 nm-1]."
        )
    return {"moons": (None,), "classes": ("P4",)}, True, value


@functools.lru_cache(maxsize=8)
def get_context(
    preset: str = "search",
    noise: str | None = None,
    fold_seed: int = 0,
    atmospheres: str = "auto",
) -> Context:
    """Build (once per process) the scenario context of a preset; a preset
    with `perturbations` (`ScenePerturbations`) repeats each lamp's scenes
    under them (`perturbed_scenes`; `Context.scene_kind` says which is
    which, `config["perturbations"]` records the settings)."""
    if preset not in PRESETS:
        raise ValueError(
            f"Unknown scenario preset {preset!r}; expected one of {list(PRESETS)}."
        )
    kw = dict(PRESETS[preset])
    perturbations = kw.pop("perturbations", None)
    over, noisy, level = parse_noise(noise)
    kw.update(over)
    six_s = atmosphere.resolve_setting(atmospheres) == "6s"
    atms = ATMOSPHERES_6S if six_s else ("none",)
    scen = build_scenarios(scored_only=True, atmospheres=atms, **kw)
    lib = library().select(scored_only=True)
    if tuple(lib.ids) != scen.lamp_ids:
        raise RuntimeError("scenario lamps and library order differ")
    truth, valid = lamp_truth(lib.values, lib.wavelength_nm)
    classes = np.asarray([r.level2 for r in lib.records], dtype=object)
    if perturbations is None:
        scenes = scenario_table(scen)
    else:
        lamps = library_lamps(np.asarray(scen.factors.wavelength_nm), scored=True)
        if lamps.ids != scen.lamp_ids:
            raise RuntimeError("scenario lamps and the inversion's lamps differ")
        toa, kind = perturbed_scenes(scen, lamps, perturbations)
        # (l, q) -> (l, s, copy, a, m, c): perturbed_scenes's layout
        n_s, n_a, n_c = (
            len(scen.surface_labels),
            len(scen.atmosphere_labels),
            len(scen.class_labels),
        )
        n_k = 1 + perturbations.n_copies
        shape = (len(classes), n_s, n_k, n_a, -1, n_c)
        scenes = scenario_table(
            scen,
            spectra=toa.reshape(*shape, toa.shape[-1]),
            kind=kind.reshape(shape),
            kinds=KINDS,
        )
    if not np.array_equal(scenes.level2, classes):
        raise RuntimeError("scenario table and library types differ")
    folds = lamp_folds(classes, n_outer=N_OUTER, n_inner=N_INNER, seed=fold_seed)
    config = {
        "preset": preset,
        "scenarios": scen.config,
        "noise": noise,
        "n_lamps": len(classes),
        "scenes_per_lamp": scenes.scenes_per_lamp,
        "perturbations": None if perturbations is None else perturbations.to_dict(),
        "fold_seed": fold_seed,
        "n_outer": N_OUTER,
        "n_inner": N_INNER,
        "atmospheres": [a if isinstance(a, str) else list(a) for a in atms],
    }
    if perturbations is not None:
        counts = np.bincount(scenes.kind, minlength=len(KINDS))
        config["clean_scenes_per_lamp"] = int(counts[0]) // len(classes)
        config["rows_per_kind"] = {
            k: int(n) for k, n in zip(KINDS, counts, strict=True) if n
        }
        config["scene_layout"] = (
            "surface x copy x atmosphere x Moon x class per lamp, copy 0 clean"
        )
    return Context(preset, scenes, folds, truth, valid, config, noisy, level)
