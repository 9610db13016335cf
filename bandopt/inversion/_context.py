"""The inversion on a `search.Context`: its lamps, conditions, per-row surfaces
and Moon brightness (cached per context object), band weights,
`fit_for_context`, and the learned baselines' training data with modelled
lamps added (`augment_with_modelled`)."""

import dataclasses
from collections.abc import Sequence

import numpy as np

from ..estimate import LampTable, lamp_truth
from ..forward import band_weights_on as forward_band_weights, dense_spectra
from ._conditions import Conditions
from ._fit import fit_inversion
from ._lamps import MODELLED_CLASSES, library_lamps, modelled_lamps
from ._scoring import SIGMA_REL_GRID
from ._surfaces import SurfaceBasis, surface_basis


MODEL_NOISE_SEED_OFFSET = 15485863
"""Noise seed offset of modelled lamps' rows (a prime): with photon noise,
their draws never share a seed with the measured rows' draws."""


@dataclasses.dataclass(frozen=True)
class Augmented:
    """Training data of a learned estimator with modelled lamps added
    (`augment_with_modelled`): `radiance` (N + M, b) and `table` (measured
    rows and lamps first, unchanged, then the modelled ones), `train` the
    outer training lamps plus the modelled lamps calibrated on them, `inner`
    the inner (train, validation) splits, each train plus the modelled lamps
    calibrated on that inner training set (validation: measured lamps only),
    and `info` what was added (`modelled_per_class`,
    `modelled_classes_added`: level-2 class -> lamps of the outer set)."""

    radiance: np.ndarray
    table: LampTable
    train: np.ndarray
    inner: list
    info: dict


def augment_with_modelled(
    ctx,
    bands,
    radiance,
    train,
    inner,
    n_per_class: int,
    *,
    classes: Sequence[str] = MODELLED_CLASSES,
    seed: int = 0,
) -> Augmented:
    """Add modelled lamps to a learned estimator's training data.

    For the outer training lamps `train` and for each inner split's training
    lamps, `n_per_class` modelled lamps per class of `classes`
    (`modelled_lamps`: calibrated on those measured lamps plus the
    never-scored `always` lamps, nothing else), lit by every scene of the
    context (`ScenarioSet.with_lamps`, same atmospheres, surfaces, Moon and
    classes) and measured with the same band set and noise rule
    (`Context.radiance_of`, own noise seeds). Each model set trains only the
    fit it was calibrated for; no modelled lamp is ever a validation or test
    lamp. `radiance` is `ctx.radiance(bands)` (the measured rows)."""
    lamps, always, _, _ = context_setup(ctx)
    scen = context_scenarios(ctx)
    grid = ctx.wavelength_nm
    base = ctx.table
    q = ctx.toa.shape[1]
    n0 = base.n_lamps
    rads, lamp_of = [np.asarray(radiance, float)], [np.asarray(base.lamp_of)]
    cls, truth, valid = [base.classes], [base.truth], [base.valid]
    added_info = {}

    def add(train_idx, j: int) -> np.ndarray:
        ids = [lamps.ids[i] for i in np.asarray(train_idx, int)] + list(always.ids)
        mset, info = modelled_lamps(ids, grid, n_per_class, classes=classes, seed=seed)
        if j == 0:
            added_info.update(info)
        m = len(mset.ids)
        if m == 0:
            return np.zeros(0, int)
        toa = np.asarray(dense_spectra(scen.with_lamps(mset.ids, mset.spectra)))
        toa = toa.reshape(m, -1, toa.shape[-1])
        if toa.shape[1] != q:
            raise RuntimeError(
                f"modelled lamps' scenes: {toa.shape[1]} per lamp, context {q}."
            )
        start = n0 + sum(len(c) for c in cls[1:])
        rads.append(
            ctx.radiance_of(toa, bands, seed=seed + MODEL_NOISE_SEED_OFFSET * (j + 1))
        )
        lamp_of.append(start + np.repeat(np.arange(m), q))
        cls.append(np.asarray(mset.level2, dtype=object))
        t, v = lamp_truth(mset.spectra, grid)
        truth.append(np.asarray(t))
        valid.append(np.asarray(v))
        return start + np.arange(m)

    train = np.asarray(train, int)
    new_train = np.concatenate([train, add(train, 0)])
    new_inner = [
        (np.concatenate([np.asarray(tr, int), add(tr, j + 1)]), np.asarray(va, int))
        for j, (tr, va) in enumerate(inner)
    ]
    table = LampTable(
        np.concatenate(lamp_of),
        np.concatenate(cls),
        np.vstack(truth),
        np.vstack(valid),
    )
    return Augmented(
        np.vstack(rads),
        table,
        new_train,
        new_inner,
        {
            "modelled_per_class": int(n_per_class),
            "modelled_classes_added": dict(added_info.get("added", {})),
        },
    )


def fit_for_context(
    ctx,
    bands,
    radiance,
    train,
    inner,
    *,
    surface_mode="unknown",
    sigma_grid: Sequence[float] = SIGMA_REL_GRID,
    modelled_per_class: int = 0,
    modelled_classes: Sequence[str] = MODELLED_CLASSES,
    modelled_seed: int = 0,
):
    """`fit_inversion` on a `search.Context`'s scenes for one band set (surface
    knowledge 'unknown' or 'class' — the per-row types come from the context;
    `sigma_grid` one value: `σ_rel` fixed; `modelled_*`: modelled lamps in the
    prior, default none, see `fit_inversion`)."""
    lamps, always, cond, row_types = context_setup(ctx)
    grid = ctx.wavelength_nm
    w = band_weights_on(bands, grid)
    return fit_inversion(
        radiance,
        ctx.table.lamp_of,
        lamps,
        np.asarray(train),
        list(inner),
        w,
        cond,
        basis=_basis(grid),
        surface_mode=surface_mode,
        row_surface=row_types if surface_mode == "class" else None,
        always=always,
        sigma_grid=sigma_grid,
        modelled_per_class=modelled_per_class,
        modelled_classes=modelled_classes,
        modelled_seed=modelled_seed,
    )


_BASIS_CACHE: dict = {}


def _basis(grid) -> "SurfaceBasis":
    key = (float(grid[0]), float(grid[-1]), len(grid))
    if key not in _BASIS_CACHE:
        _BASIS_CACHE[key] = surface_basis(grid)
    return _BASIS_CACHE[key]


_SETUP_CACHE: dict = {}


def context_setup(ctx):
    """Lamps, always-in-prior lamps, conditions and per-row surface types of a
    `search.Context` (its scenes are surface x atmosphere x Moon x class);
    cached per context object."""
    return _cached_setup(ctx)[:4]


def context_moon(ctx) -> np.ndarray:
    """The Moon's brightness in each row of a `search.Context`, relative to the
    inversion's Moon state (`Conditions.from_scenarios`: the brightest), (N,):
    0 moonless, 1 that state, else the ratio of the states' moonlit-ground
    irradiance (same shape assumed; exact for none/full). What an analyst
    knows from the acquisition's time and place."""
    scen = context_scenarios(ctx)
    q = ctx.toa.shape[1]
    amp = moon_amplitudes(scen)
    n_c = len(scen.class_labels)
    per_scene = amp[(np.arange(q) // n_c) % amp.size]
    return np.tile(per_scene, ctx.table.n_lamps)


def moon_amplitudes(scen) -> np.ndarray:
    """The Moon's brightness in each Moon state of a `scene.ScenarioSet`
    (`scen.moon_labels` order), relative to its brightest state (the one
    `Conditions.from_scenarios` holds): moonlit-ground irradiance summed over
    atmospheres and wavelengths, over that of the brightest state; 0 for a
    moonless state, all 0 when no state has a Moon. (m,) [1]"""
    f = scen.factors
    if f.moon_ground is None:
        return np.zeros(max(len(scen.moon_labels), 1))
    tot = np.asarray(f.moon_ground).sum(axis=(0, 2))  # (a, m, w) -> (m,)
    return tot / tot.max() if tot.max() > 0 else np.zeros_like(tot)


def context_scenarios(ctx):
    """The `scene.ScenarioSet` of a `search.Context`'s scenes, lit by its first
    lamp (`ScenarioSet.with_lamps` lights them with others); cached."""
    return _cached_setup(ctx)[4]


def _cached_setup(ctx):
    key = id(ctx)
    hit = _SETUP_CACHE.get(key)
    if hit is not None and hit[0] is ctx:
        return hit[1]
    out = _context_setup(ctx)
    _SETUP_CACHE[key] = (ctx, out)
    return out


def _context_setup(ctx):
    grid = ctx.wavelength_nm
    lamps = library_lamps(grid, scored=True)
    if lamps.ids != tuple(ctx.lamp_ids):
        raise RuntimeError("context lamps and library scored lamps differ")
    always = library_lamps(grid, scored=False)
    scen = ctx.scenes.scenario_set().subset_lamps([0])
    row_types = [str(x) for x in ctx.scenes.surface]
    return lamps, always, Conditions.from_scenarios(scen), row_types, scen


def band_weights_on(bands, wavelength_nm) -> np.ndarray:
    """Band-averaging weights `(b, w)` of a band set on a grid: those of the
    forward model (`forward.band_weights_on`), as a NumPy array."""
    return np.asarray(forward_band_weights(bands, np.asarray(wavelength_nm, float)))
