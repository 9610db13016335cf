"""`bandopt evaluate`'s default estimator as a configuration object.

`InversionConfig` holds the options of the physics-based inversion that
`bandopt evaluate` ships (`bandopt.inversion.fit_inversion`), with the
defaults users get; `fit_on_context` fits it on a `search.Context`'s scenes
for any band set and any lamp-grouped training split, so a study scores
exactly the estimator users run (one place for its options instead of a
copy per caller).
"""

import dataclasses
from collections.abc import Sequence

import numpy as np

from . import inversion as inv_mod
from .forward import band_weights_on


@dataclasses.dataclass(frozen=True)
class InversionConfig:
    """Options of the shipped inversion (see `inversion.fit_inversion`).

    - `mixtures`: pairwise same-class blends per class in the prior.
    - `cross_mixtures`: lamp pairs per ordered class pair whose blends of
      two types join the prior, named by the majority lamp
      (`inversion.cross_mixture_lamps`, `inversion.CROSS_MIX_PAIRS`).
    - `peak_shifts_nm`: wavelength-shifted copies of direct-emission LEDs.
    - `planck`: modelled incandescent spectra (Planck's law) in the prior.
    - `tm30`: the IES TM-30-15 lamps in the prior (train, never score).
    - `sigma_rule`, `floor_grid`: how the band-error model is chosen.
    - `calibration`: interval calibration on held-out lamps ("lamps") or on
      each training class held out in turn ("classes": new types too).
    - `interval_offsets`: candidate interval offsets (the narrowest wins).
    - `moon_told`: the Moon's brightness of every scene is known (from the
      acquisition's time and place), so it is not fitted.
    - `modelled_per_class`: modelled lamps of rare classes in the prior.
    - `nir_error`: the modelled NIR of extended lamps carries its measured
      error (`inversion.nir_variants`), so no type rests on it alone.
    - `calibrate_probabilities`: type probabilities temperature-scaled on
      held-out lamps of known types (`bandopt.calibration`); held-out types
      are reported beside them and left to the `unexplained` flag."""

    mixtures: int = inv_mod.MIX_PAIRS
    cross_mixtures: int = inv_mod.CROSS_MIX_PAIRS
    peak_shifts_nm: tuple[float, ...] = inv_mod.PEAK_SHIFTS_NM
    planck: bool = True
    tm30: bool = False
    sigma_rule: str = "per-metric"
    floor_grid: tuple[float, ...] = inv_mod.FLOOR_GRID
    calibration: str = "classes"
    interval_offsets: tuple[float, ...] = inv_mod.INTERVAL_OFFSET_GRID
    moon_told: bool = True
    modelled_per_class: int = 0
    nir_error: bool = True
    calibrate_probabilities: bool = True

    def fit_kwargs(self) -> dict:
        """The keyword arguments of `inversion.fit_inversion` this config sets
        (all but the data and the prior's always-present lamps)."""
        return {
            "mixtures": self.mixtures,
            "cross_mixtures": self.cross_mixtures,
            "peak_shifts": tuple(self.peak_shifts_nm),
            "sigma_rule": self.sigma_rule,
            "floor_grid": tuple(self.floor_grid),
            "calibration": self.calibration,
            "interval_offsets": tuple(self.interval_offsets),
            "modelled_per_class": self.modelled_per_class,
            "nir_error": self.nir_error,
            "calibrate_probabilities": self.calibrate_probabilities,
        }


def fit_on_context(
    ctx,
    bands,
    config: InversionConfig = InversionConfig(),
    *,
    surface_mode: str = "unknown",
    train_lamps: Sequence[int] | None = None,
    inner: Sequence[tuple[np.ndarray, np.ndarray]] | None = None,
    always=None,
):
    """Fit `config`'s inversion on a `search.Context` for `bands`.

    `train_lamps` (indices of the context's scored lamps; default all) with
    `inner` lamp-grouped (train, validation) splits of them (default: the
    context's outer splits, as `bandopt evaluate` uses when it trains on every
    library lamp). `always`: extra lamps always in the prior (e.g. a user's
    own), added to the library's unscored lamps. Surface knowledge
    `surface_mode` as in `inversion.SURFACE_MODES` ('measured': Sentinel-2
    draws of each row's surface)."""
    lamps, lib_always, cond, row_types = inv_mod.context_setup(ctx)
    grid = ctx.wavelength_nm
    if train_lamps is None:
        train_lamps = np.arange(ctx.table.n_lamps)
        if inner is None:
            inner = [(s.train, s.test) for s in ctx.splits]
    elif inner is None:
        raise ValueError("inner: give the lamp-grouped splits of train_lamps.")
    basis = inv_mod.surface_basis(grid)
    row_surface = {
        "unknown": None,
        "class": row_types,
        "measured": inv_mod.measured_surfaces(row_types, basis),
    }[surface_mode]
    prior_always = lib_always
    if config.planck:
        prior_always = inv_mod.with_planck_lamps(prior_always, grid)
    if config.tm30:
        prior_always = inv_mod.with_tm30_lamps(prior_always, grid)
    if always is not None:
        prior_always = always if prior_always is None else prior_always + always
    return inv_mod.fit_inversion(
        ctx.radiance(bands),
        ctx.table.lamp_of,
        lamps,
        np.asarray(train_lamps, int),
        list(inner),
        np.asarray(band_weights_on(bands, np.asarray(grid, float))),
        cond,
        basis=basis,
        surface_mode=surface_mode,
        row_surface=row_surface,
        always=prior_always,
        row_moon=inv_mod.context_moon(ctx) if config.moon_told else None,
        **config.fit_kwargs(),
    )
