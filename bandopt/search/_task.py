"""One band search as a self-contained, JSON-described task.

A task names a scenario preset, a target (`ler`, `g`, `cct`, `all`), a band
count, a pan mode, an outer fold (or `"final"`: all lamps) and a seed. It
builds (and caches per process) the scenario context, runs the global search
(nlopt) and a local polish (optimistix), then scores the bands on the outer
test lamps with the estimator refitted on the outer training lamps (ridge
strength chosen on the inner folds). Everything it returns is JSON-ready.
"""

import dataclasses
import functools
import hashlib
import json
import math
import time

import jax.numpy as jnp
import numpy as np

from .. import perturb
from ..datasets import atmosphere
from ..datasets.lamps import library
from ..estimate import (
    LampTable,
    fit_estimator,
    lamp_abs_errors,
    lamp_truth,
    resolve_target,
)
from ..folds import N_INNER_FOLDS, N_OUTER_FOLDS, nested_lamp_splits
from ..forward import band_radiance, dense_spectra
from ..inversion import LampSet, library_lamps, nir_variants
from ..scene import LIGHTING_CLASSES, build_scenarios
from ..sensor.reference import reference_sensor
from ._global import global_search
from ._local import bandset_losses, fit_local, free_bandset
from ._problem import Space, jitted_losses, make_problem, scenario_spectra


KINDS = ("clean", "nir-low", "nir-high", "background-flat", "noise", "shift")
"""Kinds of a scene's lamp spectrum: the library's (`clean`) or one
measurement effect of `ScenePerturbations` (the `scene_kind` of a row)."""


@dataclasses.dataclass(frozen=True)
class ScenePerturbations:
    """Measurement effects on each lamp's spectrum under which a context
    repeats that lamp's scenes, so a band search and its judge cannot lean on
    the library's modelled near-infrared or on clean laboratory spectra.

    Every effect acts on the lamp's per-lumen spectrum before the scene (the
    surface, atmosphere, Moon and lighting class are the clean scene's); the
    result is renormalised to one lumen, the library's convention. Each row
    keeps its lamp's index and so its labels (LER, G, CCT and types of the
    clean visible spectrum): the effects are what a spectrum holds beyond the
    lamp, not a different lamp.

    - `nir_error`: a lamp whose 780-900 nm part is modelled
      (`LampRecord.extended`) is repeated with that part at the low and at
      the high end of its class's measured extension error
      (`inversion.nir_variants`, `datasets.nir.extension_error`; kinds
      `nir-low`, `nir-high`); a lamp measured to 900 nm is repeated unchanged.
    - `background_fraction`: a flat background whose visible power is this
      share of the lamp's (`perturb.add_flat_background`), None for none. [1]
    - `noise_snr`: spectrometer noise at this SNR per nm against the mean
      visible level (`perturb.add_spectrometer_noise`, one seeded draw per
      lamp, the same in every scene of the lamp), None for none. [1]
    - `shift_nm`: a wavelength-calibration error (`perturb.shift_wavelength`),
      None for none. [nm]
    - `copies`: perturbed copies of each clean scene. None: one per kind
      (every kind under every scene). An integer `k` smaller than the number
      of kinds: `k` copies whose kinds are drawn for each lamp (a seeded
      permutation of the kinds, walked cyclically over the lamp's scenes and
      copies, so the kinds of one scene differ and each kind covers a share
      `k / kinds` of the lamp's scenes, within one scene).
    - `seed`: seed of the noise draw and of the kind permutations.
    """

    nir_error: bool = True
    background_fraction: float | None = 0.01
    noise_snr: float | None = 100.0
    shift_nm: float | None = 1.0
    copies: int | None = None
    seed: int = 0

    def __post_init__(self):
        if self.background_fraction is not None and not self.background_fraction > 0:
            raise ValueError(
                f"background_fraction {self.background_fraction!r}: need a share > 0 "
                "of the visible power, or None for no background."
            )
        if self.noise_snr is not None and not self.noise_snr > 0:
            raise ValueError(
                f"noise_snr {self.noise_snr!r}: need an SNR > 0, or None for no noise."
            )
        if self.shift_nm is not None and not (
            np.isfinite(self.shift_nm) and self.shift_nm != 0
        ):
            raise ValueError(
                f"shift_nm {self.shift_nm!r}: need a finite shift != 0 [nm], or "
                "None for no shift."
            )
        if not self.kinds:
            raise ValueError("ScenePerturbations: every effect is off; use no config.")
        if self.copies is not None and not 1 <= self.copies <= len(self.kinds):
            raise ValueError(
                f"copies {self.copies!r}: need 1..{len(self.kinds)} (the number of "
                "kinds), or None for every kind under every scene."
            )

    @property
    def kinds(self) -> tuple[str, ...]:
        """The perturbation kinds switched on, in `KINDS` order."""
        on = {
            "nir-low": self.nir_error,
            "nir-high": self.nir_error,
            "background-flat": self.background_fraction is not None,
            "noise": self.noise_snr is not None,
            "shift": self.shift_nm is not None,
        }
        return tuple(k for k in KINDS[1:] if on[k])

    @property
    def n_copies(self) -> int:
        """Perturbed copies of each clean scene."""
        return len(self.kinds) if self.copies is None else int(self.copies)

    def to_dict(self) -> dict:
        """The settings and the kinds, JSON-ready (a context's provenance)."""
        return {**dataclasses.asdict(self), "kinds": list(self.kinds)}


MEASURED_SPECTRA = ScenePerturbations(copies=2)
"""The perturbations of the `search_perturbed` preset: the modelled NIR at
its measured error bounds (the search must not rest on a model's 780-900 nm
part), a 1 % flat background (stray light and dark level, the middle of the
0.5-2 % a field or satellite spectrum holds; flat, because it lifts the NIR
where lamps are weakest), noise at SNR 100 per nm (an ordinary
spectrometer) and a 1 nm shift (a calibrated spectrometer's wavelength
error; a band edge on a line must not depend on the line's exact place).
Two perturbed copies of each clean scene, not five: the study's run time
grows with the rows, and two copies already give every lamp every kind
(the study's 8 clean scenes per lamp x 2 copies over 5 kinds: each kind
under 3 or 4 of them)."""

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
    """A scenario set ready for searches: spectra `(l, q, w)`, lamp table,
    nested splits, labels, and the photon-noise setting.

    `scene_kind` `(l, q)`: the index into `KINDS` of each scene's lamp
    spectrum (all 0, `clean`, without `ScenePerturbations`). The scenes of a lamp are
    surface x copy x atmosphere x Moon x class in C order (copy 0 the clean
    spectrum; one copy without perturbations), so a scene's surface, Moon and
    class sit where the clean layout puts them."""

    preset: str
    toa: np.ndarray
    wavelength_nm: np.ndarray
    table: LampTable
    lamp_ids: tuple[str, ...]
    splits: tuple
    config: dict
    noise: bool
    noise_radiance: float | None
    scene_kind: np.ndarray | None = None

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


def perturbed_lamp_spectra(
    lamps: LampSet, wavelength_nm, config: ScenePerturbations
) -> dict[str, np.ndarray]:
    """Each kind of `config.kinds` applied to the library lamps `lamps`
    (per-lumen spectra `(l, w)` on the 1 nm grid `wavelength_nm`), by kind,
    each `(l, w)` per lumen (see `ScenePerturbations`). A lamp without a
    modelled NIR part keeps its spectrum in `nir-low` and `nir-high`."""
    grid = np.asarray(wavelength_nm, float)
    clean = np.asarray(lamps.spectra, float)
    out = {}
    if config.nir_error:
        var = nir_variants(lamps, grid)
        row = {lamp_id: k for k, lamp_id in enumerate(var.ids)}
        for tag in ("nir-low", "nir-high"):
            s = clean.copy()
            for i, lamp_id in enumerate(lamps.ids):
                k = row.get(f"{tag}:{lamp_id}")
                if k is not None:
                    s[i] = var.spectra[k]
            out[tag] = s
    rest = {
        "background-flat": lambda: perturb.add_flat_background(
            clean, grid, config.background_fraction
        ),
        "noise": lambda: perturb.add_spectrometer_noise(
            clean, grid, config.noise_snr, seed=config.seed
        ),
        "shift": lambda: perturb.shift_wavelength(clean, grid, config.shift_nm),
    }
    for kind in config.kinds:
        if kind in rest:
            s = rest[kind]()
            out[kind] = s / perturb.luminous_flux_lm(s, grid)[:, None]
    return out


def perturbed_scenes(
    scen, lamps: LampSet, config: ScenePerturbations
) -> tuple[np.ndarray, np.ndarray]:
    """TOA spectra `(l, q, w)` of the scenes of `scen` (a `ScenarioSet` of
    the lamps `lamps`) with each scene repeated under `config`, and the kind
    of each scene `(l, q)` (indices into `KINDS`). Layout of a lamp's `q`
    scenes: surface x copy x atmosphere x Moon x class (C order), copy 0 the
    clean scene and copies 1.. the perturbed ones (`ScenePerturbations`)."""
    if tuple(scen.lamp_ids) != tuple(lamps.ids):
        raise ValueError(
            "perturbed_scenes: the scenario set's lamps and `lamps` differ."
        )
    grid = np.asarray(scen.factors.wavelength_nm, float)
    spectra = {"clean": lamps.spectra, **perturbed_lamp_spectra(lamps, grid, config)}
    kinds = ("clean", *config.kinds)
    dense = np.stack(
        [
            np.asarray(dense_spectra(scen.with_lamps(lamps.ids, spectra[k])))
            for k in kinds
        ]
    )  # (kinds, l, s, a, m, c, w)
    n_k, n_l, n_s, n_a, n_m, n_c, n_w = dense.shape
    n_copy = 1 + config.n_copies
    # kind index (into `kinds`) of every (lamp, surface, copy, atm, moon, class)
    pick = np.zeros((n_l, n_s, n_copy, n_a, n_m, n_c), int)
    if config.copies is None:
        pick[:] = np.arange(n_copy)[None, None, :, None, None, None]
    else:
        per_lamp = n_s * n_a * n_m * n_c
        scene = np.arange(per_lamp).reshape(n_s, n_a, n_m, n_c)
        rng = np.random.default_rng([config.seed, 1])
        for i in range(n_l):
            order = 1 + rng.permutation(n_k - 1)
            start = rng.integers(n_k - 1)
            for c in range(config.n_copies):
                walk = (scene * config.n_copies + c + start) % (n_k - 1)
                pick[i, :, 1 + c] = order[walk]
    idx = np.indices(pick.shape)
    lamp_i, s_i, _, a_i, m_i, c_i = idx
    toa = dense[pick, lamp_i, s_i, a_i, m_i, c_i]  # (l, s, copy, a, m, c, w)
    kind_of = np.asarray([KINDS.index(k) for k in kinds])
    return (
        toa.reshape(n_l, -1, n_w),
        kind_of[pick].reshape(n_l, -1),
    )


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
    if atmospheres == "auto":
        atms = ATMOSPHERES_6S if atmosphere.tables_available() else ("none",)
    elif atmospheres == "6s":
        atmosphere.require_tables()
        atms = ATMOSPHERES_6S
    elif atmospheres == "none":
        atms = ("none",)
    else:
        raise ValueError(
            f"atmospheres must be 'auto', '6s' or 'none', got {atmospheres!r}."
        )
    scen = build_scenarios(scored_only=True, atmospheres=atms, **kw)
    lib = library().select(scored_only=True)
    if tuple(lib.ids) != scen.lamp_ids:
        raise RuntimeError("scenario lamps and library order differ")
    truth, valid = lamp_truth(lib.values, lib.wavelength_nm)
    classes = np.asarray([r.level2 for r in lib.records], dtype=object)
    if perturbations is None:
        toa = scenario_spectra(scen)
        kind = np.zeros(toa.shape[:2], int)
    else:
        lamps = library_lamps(np.asarray(scen.factors.wavelength_nm), scored=True)
        if lamps.ids != scen.lamp_ids:
            raise RuntimeError("scenario lamps and the inversion's lamps differ")
        toa, kind = perturbed_scenes(scen, lamps, perturbations)
    table = LampTable(
        np.repeat(np.arange(len(classes)), toa.shape[1]), classes, truth, valid
    )
    splits = tuple(
        nested_lamp_splits(classes, n_outer=N_OUTER, n_inner=N_INNER, seed=fold_seed)
    )
    config = {
        "preset": preset,
        "scenarios": scen.config,
        "noise": noise,
        "n_lamps": len(classes),
        "scenes_per_lamp": int(toa.shape[1]),
        "perturbations": None if perturbations is None else perturbations.to_dict(),
        "fold_seed": fold_seed,
        "n_outer": N_OUTER,
        "n_inner": N_INNER,
        "atmospheres": [a if isinstance(a, str) else list(a) for a in atms],
    }
    if perturbations is not None:
        counts = np.bincount(kind.ravel(), minlength=len(KINDS))
        config["clean_scenes_per_lamp"] = int(counts[0]) // len(classes)
        config["rows_per_kind"] = {
            k: int(n) for k, n in zip(KINDS, counts, strict=True) if n
        }
        config["scene_layout"] = (
            "surface x copy x atmosphere x Moon x class per lamp, copy 0 clean"
        )
    return Context(
        preset,
        toa,
        np.asarray(scen.factors.wavelength_nm),
        table,
        scen.lamp_ids,
        splits,
        config,
        noisy,
        level,
        kind,
    )


def task_id(task: dict) -> str:
    """Stable file name of a task: readable prefix + hash of its full spec
    (with its preset's scene perturbations, when it has any, so a cached
    task is never reused after they change)."""
    spec = dict(task)
    pert = PRESETS.get(task.get("preset"), {}).get("perturbations")
    if pert is not None:
        spec["perturbations"] = pert.to_dict()
    h = hashlib.sha1(json.dumps(spec, sort_keys=True).encode()).hexdigest()[:10]
    fold = task.get("fold", "final")
    kind = task.get("kind", "search")
    if kind == "reference":
        return f"ref_{task['sensor']}_{h}"
    if kind == "stability":
        if task.get("sensor"):
            return f"st_ref_{task['sensor']}_{h}"
        return f"st_n{task['n_bands']}_a{task['alpha']:g}_{h}"
    return (
        f"{task['target']}_n{task['n_bands']}_{task['pan']}_f{fold}_s{task['seed']}_{h}"
    )


DEFAULT_TASK = {
    "kind": "search",
    "preset": "search",
    "noise": None,
    "fold_seed": 0,
    "target": "all",
    "n_bands": 3,
    "pan": "fixed",
    "fold": "final",
    "seed": 0,
    "algorithm": "mlsl",
    "max_evals": 600,
    "local_max_evals": 40,
    "polish_steps": 40,
    "degree": 1,
    "max_fwhm_nm": 200.0,
    "atmospheres": "auto",
    "warm_start": True,
}

WARM_NEW_CENTRES_NM = (430.0, 530.0, 630.0, 730.0, 830.0)
"""Where a warm start puts the band added to the n - 1 solution (FWHM 40 nm)."""


def make_task(**kwargs) -> dict:
    unknown = set(kwargs) - set(DEFAULT_TASK)
    if unknown:
        raise ValueError(
            f"Unknown task fields {sorted(unknown)}; expected {sorted(DEFAULT_TASK)}."
        )
    task = {**DEFAULT_TASK, **kwargs}
    task["target"] = resolve_target(task["target"])
    if task["atmospheres"] == "auto":
        # Resolve now, so the task's hash (its result file) says which was used.
        task["atmospheres"] = "6s" if atmosphere.tables_available() else "none"
    return task


def _lamps_and_splits(ctx: Context, fold):
    if fold == "final":
        lamps = np.arange(ctx.table.n_lamps)
        splits = [(s.train, s.test) for s in ctx.splits]
        return lamps, splits, None, None
    s = ctx.splits[int(fold)]
    return s.train, list(s.inner), s.train, s.test


def evaluate_bands(ctx: Context, bands, *, folds=None, seed: int = 0) -> dict:
    """Outer-fold test errors of the ridge estimator for a fixed band set.

    For each outer fold (all by default) the estimator is fitted on the outer
    training lamps (ridge strength and feature degree by inner CV) and scored
    on its test lamps. Returns `{"lamp_index", "lamp_errors" (l, 3),
    "fold_of_lamp", "lambdas", "degrees"}`.
    """
    rad = ctx.radiance(bands, seed=seed)
    folds = range(len(ctx.splits)) if folds is None else folds
    idx, errs, fold_of, lams, degs = [], [], [], [], []
    for k in folds:
        s = ctx.splits[k]
        est = fit_estimator(rad, ctx.table, s.train, s.inner)
        pred = np.asarray(est.predict(rad))
        errs.append(lamp_abs_errors(pred, ctx.table, s.test))
        idx.append(s.test)
        fold_of.append(np.full(len(s.test), k))
        lams.append(list(est.lam))
        degs.append(list(est.degree))
    return {
        "lamp_index": np.concatenate(idx).tolist(),
        "lamp_errors": np.concatenate(errs).tolist(),
        "fold_of_lamp": np.concatenate(fold_of).tolist(),
        "lambdas": lams,
        "degrees": degs,
    }


EVALUATION_KEYS = ("lamp_index", "lamp_errors", "fold_of_lamp", "lambdas", "degrees")
"""Keys of `evaluate_bands`: the outer-fold test errors of a task's bands."""


@dataclasses.dataclass(frozen=True)
class TaskResult:
    """The result of `run_task`; `to_dict()` is the JSON of its task file.

    Every task: `task` (its description), `bands` (the band set: the
    `BandSet.to_dict()` form for a search, name/centre/FWHM for a reference
    sensor), `context` (scenario settings), `wall_s` [s] and, on an outer
    fold, the test-lamp evaluation (`lamp_index`, `lamp_errors` [LER lm/W,
    G 1, CCT K per lamp], `fold_of_lamp`, `lambdas`, `degrees`; None on the
    `"final"` fold). A search also has `space`, `loss`, `spread`,
    `global_search` (JSON key `"global"`), `local` and `warm_start` (None
    when not run). `from_dict` reads a task file back.
    """

    task: dict
    bands: dict
    context: dict
    wall_s: float
    space: dict | None = None
    loss: float | None = None
    spread: list | None = None
    global_search: dict | None = None
    local: dict | None = None
    warm_start: dict | None = None
    lamp_index: list | None = None
    lamp_errors: list | None = None
    fold_of_lamp: list | None = None
    lambdas: list | None = None
    degrees: list | None = None

    @property
    def is_reference(self) -> bool:
        """A reference sensor scored on the folds (no search)."""
        return self.task.get("kind") == "reference"

    def evaluation(self) -> dict | None:
        """The test-lamp evaluation as `evaluate_bands` returns it."""
        if self.lamp_index is None:
            return None
        return {k: getattr(self, k) for k in EVALUATION_KEYS}

    def to_dict(self) -> dict:
        """The JSON-ready dict of the task file (keys in the order of the
        files written before this class existed)."""
        ev = self.evaluation() or {}
        if self.is_reference:
            return {
                "task": self.task,
                "bands": self.bands,
                **ev,
                "wall_s": self.wall_s,
                "context": self.context,
            }
        return {
            "task": self.task,
            "space": self.space,
            "bands": self.bands,
            "loss": self.loss,
            "spread": self.spread,
            "global": self.global_search,
            "local": self.local,
            "warm_start": self.warm_start,
            "context": self.context,
            **ev,
            "wall_s": self.wall_s,
        }

    @classmethod
    def from_dict(cls, data: dict) -> "TaskResult":
        """A `TaskResult` from a task file's dict (`to_dict` inverted); a
        missing or unknown key is a `ValueError` naming it."""
        keys = {"task", "bands", "context", "wall_s", *EVALUATION_KEYS}
        if not (isinstance(data.get("task"), dict) and data["task"].get("kind")
                == "reference"):  # fmt: skip
            keys |= {"space", "loss", "spread", "global", "local", "warm_start"}
        unknown = set(data) - keys
        missing = {"task", "bands", "context", "wall_s"} - set(data)
        if unknown or missing:
            raise ValueError(
                f"task result: unknown keys {sorted(unknown)}, missing keys "
                f"{sorted(missing)}."
            )
        kw = {k: v for k, v in data.items() if k != "global"}
        if "global" in data:
            kw["global_search"] = data["global"]
        return cls(**kw)


def run_task(
    task: dict, progress=None, *, results: dict | None = None
) -> TaskResult:
    """Run one task (see module docstring) and return its `TaskResult`
    (`to_dict()` is JSON-ready).

    `results`: results of tasks already run, by `task_id`, as task-file dicts
    (a dict, or anything with `get` and item assignment, e.g.
    `bandopt.search.TaskResults` reading a sweep's finished files). A warm
    start takes the n - 1 task's result from it, running it (and adding its
    `to_dict()`) when missing. Default: a new dict for this call, so nothing
    is shared between calls."""
    results = {} if results is None else results

    t0 = time.perf_counter()
    ctx = get_context(
        task["preset"], task["noise"], task["fold_seed"], task["atmospheres"]
    )
    if task.get("kind") == "reference":
        bands = reference_sensor(task["sensor"])
        ev = evaluate_bands(ctx, bands, seed=task["seed"])
        return TaskResult(
            task=task,
            bands=_describe(bands),
            context=ctx.config,
            wall_s=time.perf_counter() - t0,
            **ev,
        )
    space = Space(task["n_bands"], pan=task["pan"], max_fwhm_nm=task["max_fwhm_nm"])
    lamps, splits, _, _ = _lamps_and_splits(ctx, task["fold"])
    problem = make_problem(
        ctx.toa,
        ctx.wavelength_nm,
        ctx.table,
        lamps,
        splits,
        target=task["target"],
        space=space,
        degree=task["degree"],
        noise=ctx.noise,
        noise_radiance=ctx.noise_radiance,
        seed=task["seed"],
        pad_to=ctx.toa.shape[0] * ctx.toa.shape[1],
    )
    value, vg, _ = jitted_losses(problem, space)
    g = global_search(
        value,
        vg,
        space.dim,
        algorithm=task["algorithm"],
        max_evals=task["max_evals"],
        seed=task["seed"],
        local_max_evals=task["local_max_evals"],
    )
    centre, fwhm = (np.asarray(a) for a in space.physical(jnp.asarray(g.x)))
    local = None
    if task["polish_steps"] > 0:
        loss_b, _ = bandset_losses(space.n_free)
        lo, _ = space.fwhm_range()
        init = free_bandset(
            centre,
            np.clip(fwhm, lo[0] + 1e-3, None),
            space.shape_k,
            min_fwhm_nm=float(lo.min()),
        )
        lr = fit_local(
            loss_b, init, args=problem, solver="bfgs", max_steps=task["polish_steps"]
        )
        local = lr.to_dict()
        if lr.loss < g.loss:
            centre, fwhm = np.asarray(lr.bands.centre_nm), np.asarray(lr.bands.fwhm_nm)
    warm = None
    if task.get("warm_start") and task["n_bands"] > 1 and space.pan != "free":
        # Nested warm start: the n - 1 solution of the same fold plus one new
        # band, polished with BFGS. Keeps the loss from rising with n when the
        # global search stops in a worse basin (deterministic: the n - 1 task
        # is the same computation whether cached or recomputed).
        n = task["n_bands"]
        # Budgets scale with the dimension, so the n - 1 task is the sweep's own.
        prev_task = dict(
            task, n_bands=n - 1, max_evals=round(task["max_evals"] * (n - 1) / n)
        )
        prev = results.get(task_id(prev_task))
        if prev is None:
            prev = run_task(prev_task, results=results).to_dict()
            results[task_id(prev_task)] = prev
        free = [b for b in prev["bands"]["bands"] if b["name"] != "PAN"]
        pc = [b["centre_nm"] for b in free]
        pf = [b["fwhm_nm"] for b in free]
        loss_b, _ = bandset_losses(space.n_free)
        lo, _ = space.fwhm_range()
        best = None
        for c_new in WARM_NEW_CENTRES_NM:
            init = free_bandset(
                [*pc, c_new],
                np.clip([*pf, 40.0], lo[0] + 1e-3, None),
                space.shape_k,
                min_fwhm_nm=float(lo.min()),
            )
            lr = fit_local(
                loss_b,
                init,
                args=problem,
                solver="bfgs",
                max_steps=task["polish_steps"],
            )
            if best is None or lr.loss < best.loss:
                best = lr
        warm = {
            "from_n_bands": task["n_bands"] - 1,
            "loss": best.loss,
            "starts": len(WARM_NEW_CENTRES_NM),
            "result": best.to_dict(),
        }
        current = g.loss if local is None else min(g.loss, local["loss"])
        warm["used"] = bool(best.loss < current)
        if warm["used"]:
            centre = np.asarray(best.bands.centre_nm)
            fwhm = np.asarray(best.bands.fwhm_nm)
    bands = space.band_set(
        centre, fwhm, name=f"bandopt-{task['target']}-n{task['n_bands']}"
    )
    loss = (
        float(value(jnp.asarray(space.unit(centre, fwhm))))
        if local is None
        else min(g.loss, local["loss"])
    )
    if warm is not None and warm["used"]:
        loss = warm["loss"]
    ev = {}
    if task["fold"] != "final":
        ev = evaluate_bands(ctx, bands, folds=[int(task["fold"])], seed=task["seed"])
    return TaskResult(
        task=task,
        space=space.to_dict(),
        bands=bands.to_dict(),
        loss=loss,
        spread=np.asarray(problem.spread).tolist(),
        global_search=g.to_dict(),
        local=local,
        warm_start=warm,
        context=ctx.config,
        wall_s=time.perf_counter() - t0,
        **ev,
    )


def _describe(bands) -> dict:
    c = np.asarray(bands.centre_nm, float)
    f = np.asarray(bands.fwhm_nm, float)
    return {
        "name": bands.name,
        "bands": [
            {"name": n, "centre_nm": float(c[i]), "fwhm_nm": float(f[i])}
            for i, n in enumerate(bands.names)
        ],
    }
