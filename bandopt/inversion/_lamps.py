"""Lamp sets an inversion trains on: measured library lamps (`LampSet`,
`library_lamps`), your own lamps, modelled incandescent (Planck) spectra, the
IES TM-30-15 lamps, and modelled lamps of rare classes sampled from the
physical lamp models (`bandopt.lampmodels`) calibrated on training lamps only."""

import dataclasses
from collections.abc import Sequence

import numpy as np

from .. import lampmodels
from ..datasets.lamps import LEVEL2, LEVEL2_PARENT, library
from ..photometry import ler


@dataclasses.dataclass(frozen=True)
class LampSet:
    """Measured lamps with their types: the rows an inversion trains on.
    `spectra` (l, w) per lumen on the conditions' grid."""

    ids: tuple[str, ...]
    spectra: np.ndarray
    level1: tuple[str, ...]
    level2: tuple[str, ...]

    def take(self, index) -> "LampSet":
        idx = np.asarray(index, int)
        return LampSet(
            tuple(self.ids[i] for i in idx),
            self.spectra[idx],
            tuple(self.level1[i] for i in idx),
            tuple(self.level2[i] for i in idx),
        )

    def __add__(self, other: "LampSet") -> "LampSet":
        return LampSet(
            self.ids + other.ids,
            np.vstack([self.spectra, other.spectra]),
            self.level1 + other.level1,
            self.level2 + other.level2,
        )


def library_lamps(wavelength_nm, *, scored: bool) -> LampSet:
    """Measured library lamps on a grid: the scored ones (`scored=True`) or the
    measured lamps of classes too small to score (`scored=False`, e.g.
    low-pressure sodium), which only ever train."""
    lib = library(wavelength_nm=np.asarray(wavelength_nm, float)).select()
    keep = [
        i
        for i, r in enumerate(lib.records)
        if (
            lib.is_scored(r)
            if scored
            else (not lib.is_scored(r) and r.excluded is None)
        )
        and (r.level2 is not None or not scored)
    ]
    return _lamp_set(lib, keep)


def _lamp_set(lib, keep) -> LampSet:
    """The library records `keep` (indices) as a `LampSet`; a record without a
    level-2 class (an unscored kind) gets its level 1 in its place."""
    recs = [lib.records[i] for i in keep]
    return LampSet(
        tuple(r.id for r in recs),
        np.asarray(lib.values[keep], float),
        tuple(r.level1 for r in recs),
        tuple(r.level2 if r.level2 is not None else r.level1 for r in recs),
    )


MODELLED_CLASSES = ("lps", "mercury", "led_amber", "metal_halide", "hps")
"""Level-2 classes that get modelled lamps by default: the rare outdoor
classes (2-11 measured lamps each). The white LED classes (`led_warm`,
`led_cool`, 150 measured lamps) also have a model but are left out by
default: they are well sampled already, and fitting their lamps adds ~3 min
per process (see `modelled_lamps`); pass them in `modelled_classes` to use
them. Fluorescent and incandescent lamps have no model."""


MIN_CALIBRATION_LAMPS = 2
"""Least measured training lamps of a class for its model to be sampled: a
calibration on one lamp has no spread (every sample would be that lamp's
fit). A class with fewer training lamps in a fit gets no modelled lamps."""


MODELLED_SEED_STRIDE = 104729
"""Seed offset between classes of one `modelled_lamps` call (a prime, so the
classes' draws never share a seed)."""


def planck_lamps(wavelength_nm) -> LampSet:
    """The library's modelled incandescent spectra (Planck's law,
    `datasets.lamps.MODELLED_INCANDESCENT_K`, per lumen; `Planck1901`), as
    prior lamps of level 1 `incandescent`, level 2 `incandescent_halogen`.

    Why: an incandescent lamp is a thermal radiator, so its family has
    physics no measured class carries: with these in every prior a halogen
    lamp is named `incandescent` even when no measured incandescent lamp
    trains (each class held out in turn, partition 0: level 1 0.0 -> 0.99).
    They are modelled spectra: they train, never score (no scene row belongs
    to them), and every result that uses them says so. Not fitted to any
    lamp, so they carry no scored lamp's information."""
    lib = library(wavelength_nm=np.asarray(wavelength_nm, float))
    keep = [
        i
        for i, r in enumerate(lib.records)
        if r.modelled and r.level1 == "incandescent"
    ]
    return _lamp_set(lib, keep)


def own_lamps(
    names: Sequence[str], values, source_nm, wavelength_nm, level2: Sequence[str]
) -> LampSet:
    """A user's measured lamp spectra as prior lamps: `values` (l, w) on
    `source_nm` (any scale) put on `wavelength_nm` the way the library puts
    its lamps on a grid (linear interpolation, then one lumen on that grid:
    `bandopt.photometry.ler` times the radiant power 380-780 nm), labelled
    with their level-2 classes `level2` (one of `LEVEL2`) and those classes'
    level-1 families. Ids `own:<name>`. They train, never score: the held-out
    scores are of library lamps, so what a lamp of yours in the prior buys
    is the library's in-library bound (`make estimate-library`)."""
    wl = np.asarray(wavelength_nm, float)
    src = np.asarray(source_nm, float)
    v = np.atleast_2d(np.asarray(values, float))
    names, level2 = tuple(names), tuple(level2)
    if not (len(names) == len(level2) == v.shape[0]):
        raise ValueError(
            f"own lamps: {len(names)} names, {len(level2)} classes and "
            f"{v.shape[0]} spectra; need one of each per lamp."
        )
    bad = [c for c in level2 if c not in LEVEL2]
    if bad:
        raise ValueError(
            f"own lamps: class {bad[0]!r} is not a level-2 class; choose from "
            f"{', '.join(LEVEL2)}."
        )
    if v.shape[1] != src.size:
        raise ValueError(
            f"own lamps: spectra have {v.shape[1]} values, the grid {src.size}."
        )
    rows = np.array([np.interp(wl, src, x) for x in v]).reshape(-1, wl.size)
    vis = wl <= 780.0
    lum = np.asarray(ler(rows, wl)) * np.trapezoid(rows[:, vis], wl[vis], axis=1)
    if rows.size and not np.all(np.isfinite(lum) & (lum > 0)):
        k = int(np.flatnonzero(~(np.isfinite(lum) & (lum > 0)))[0])
        raise ValueError(f"own lamps: {names[k]} emits no light in 380-780 nm.")
    return LampSet(
        tuple(f"own:{n}" for n in names),
        rows / lum[:, None] if rows.size else rows,
        tuple(LEVEL2_PARENT[c] for c in level2),
        level2,
    )


def tm30_lamps(wavelength_nm) -> LampSet:
    """The measured lamps of the IES TM-30-15 set (`IES2015`; `library(
    tm30=True)`, source set `ies_tm30`) that the library lacks, per lumen on a
    grid, as prior lamps: commercial and experimental lamps of every
    technology, classified and deduplicated by the library's own rules (a
    copy of a library lamp is removed, the library's kept), 380-780 nm
    measured and NIR-extended beyond like the NIST sets; coloured LEDs are
    left out (`excluded`).

    Why: the held-out error falls with the library's size (`make
    estimate-library`), and these are real measured lamps the scored library
    does not hold. They train, never score: no scene row belongs to them, so
    every committed result stays comparable."""
    lib = library(wavelength_nm=np.asarray(wavelength_nm, float), tm30=True)
    keep = [
        i
        for i, r in enumerate(lib.records)
        if r.source_set == "ies_tm30" and r.excluded is None and r.level2 is not None
    ]
    return _lamp_set(lib, keep)


def with_tm30_lamps(always: LampSet | None, grid, drop_class=None) -> LampSet:
    """`always` (None: no lamps) plus `tm30_lamps`, less those of level-2
    class `drop_class` (a class held out as unseen: measured lamps of it must
    not train)."""
    tm30 = tm30_lamps(grid)
    if drop_class is not None:
        tm30 = tm30.take([i for i, c in enumerate(tm30.level2) if c != drop_class])
    return tm30 if always is None else always + tm30


def with_planck_lamps(always: LampSet | None, grid) -> LampSet:
    """`always` (None: no lamps) plus `planck_lamps`."""
    planck = planck_lamps(grid)
    return planck if always is None else always + planck


def modelled_lamps(
    train_ids: Sequence[str],
    wavelength_nm,
    n_per_class: int,
    *,
    classes: Sequence[str] = MODELLED_CLASSES,
    seed: int = 0,
) -> tuple[LampSet, dict]:
    """Modelled lamps for one fit's prior: `n_per_class` spectra per level-2
    class in `classes` whose model is calibrated ONLY on the measured lamps
    among `train_ids` (`lampmodels.calibrate(c, train_ids)`), labelled with
    the class and its level-1 parent.

    A class with fewer than `MIN_CALIBRATION_LAMPS` measured lamps among
    `train_ids` gets none (listed in `skipped`). Spectra are sampled on the
    library grid (`lampmodels.sample_library`, seed `seed + 104729 j` for the
    j-th class of `classes`; near-infrared beyond the calibration lamps'
    measured range: the library's extension), then put on `wavelength_nm` the
    way the library puts measured lamps on a grid: linear interpolation, then
    one lumen on that grid (`lampmodels.per_lumen`, the library's
    `683 ∫ V S dλ = 1`). [W nm⁻¹ lm⁻¹]

    Returns the lamps (ids `model_<class>_<seed>_<j>`) and a record: lamps
    added per class, the calibration lamps per class, the skipped classes with
    their training-lamp count. Raises `RuntimeError` if a calibration used a
    lamp outside `train_ids` (never expected: a leak).

    **Cost.** `lampmodels.calibrate` fits every calibration lamp once per
    process (Levenberg-Marquardt, 4 starts, cached per lamp), so a
    cross-validation pays it once, whatever its folds. Measured on a 2-core
    machine busy with other runs (so up to ~2x slow): one fit takes 0.1-1 s
    (median 0.6-1 s for the LEDs), but the first fit of each family and
    padded observation count compiles (5-50 s; one metal-halide lamp 120 s).
    The 34 measured lamps of the five `MODELLED_CLASSES`: 350 s in one fresh
    process (LPS 25 s, mercury 13 s, amber LED 27 s, metal halide 214 s,
    HPS 71 s) and 630 s in a second, busier run (metal halide 470 s). All 184
    measured lamps with a model (the scored ones and LPS; with the white LEDs:
    97 warm 70 s, 53 cool 126 s): 823 s. Calibrating and sampling once
    fitted: < 0.1 s per class.
    """
    if n_per_class < 1:
        raise ValueError(f"n_per_class must be >= 1 (got {n_per_class}).")
    grid = np.asarray(wavelength_nm, float)
    lib = library()
    train = set(train_ids)
    ids, spectra, level1, level2 = [], [], [], []
    added, calibrated_on, skipped = {}, {}, {}
    for j, c in enumerate(classes):
        lampmodels.family_of(c)  # ValueError: no model for this class
        members = [
            r.id
            for r in lib.records
            if r.level2 == c and not r.modelled and r.excluded is None and r.id in train
        ]
        if len(members) < MIN_CALIBRATION_LAMPS:
            skipped[c] = len(members)
            continue
        cal = lampmodels.calibrate(c, list(train_ids))
        if not set(cal.lamps) <= train:
            raise RuntimeError(
                f"{c}: model calibrated on lamps outside the fit's training "
                f"lamps: {sorted(set(cal.lamps) - train)}."
            )
        out = lampmodels.sample_library(
            [c], n_per_class, seed + MODELLED_SEED_STRIDE * j, calibrations={c: cal}
        )
        if not all(r.modelled for r in out.records):
            raise RuntimeError("sample_library returned a lamp not marked modelled.")
        v = np.asarray(out.values, float)
        w = np.asarray(out.wavelength_nm, float)
        if w.shape != grid.shape or not np.allclose(w, grid):
            v = np.stack([np.interp(grid, w, row) for row in v])
            v = lampmodels.per_lumen(grid, v)
        if not np.all(np.isfinite(v)):
            raise RuntimeError(f"{c}: modelled spectra are not finite on the grid.")
        ids += [r.id for r in out.records]
        spectra.append(v)
        level1 += [r.level1 for r in out.records]
        level2 += [c] * len(out.records)
        added[c] = len(out.records)
        calibrated_on[c] = list(cal.lamps)
    lamps = LampSet(
        tuple(ids),
        np.vstack(spectra) if spectra else np.zeros((0, grid.size)),
        tuple(level1),
        tuple(level2),
    )
    info = {
        "n_per_class": int(n_per_class),
        "added": added,
        "calibration_lamps": calibrated_on,
        "skipped": skipped,
        "min_calibration_lamps": MIN_CALIBRATION_LAMPS,
        "seed": int(seed),
    }
    return lamps, info
