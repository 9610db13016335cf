"""The inversion's options as one frozen record (`InversionOptions`), and the
named variants `cross_validate` knows (`DEFAULT_ESTIMATOR` and the steps
that lead to it, `LABELLED`: each name's options) beside the learned
baselines."""

import dataclasses

from ._calibrate import INTERVAL_OFFSET_GRID
from ._scoring import FLOOR_GRID, SIGMA_FLOOR
from ._variants import CROSS_MIX_PAIRS, MIX_PAIRS, PEAK_SHIFTS_NM


@dataclasses.dataclass(frozen=True)
class InversionOptions:
    """Options of the inversion (see `fit_inversion`), with the defaults
    `bandopt evaluate` ships.

    - `mixtures`: pairwise same-class blends per class in the prior.
    - `cross_mixtures`: lamp pairs per ordered class pair whose blends of
      two types join the prior, named by the majority lamp
      (`cross_mixture_lamps`, `CROSS_MIX_PAIRS`).
    - `peak_shifts_nm`: wavelength-shifted copies of direct-emission LEDs.
    - `planck`: modelled incandescent spectra (Planck's law) in the prior.
    - `tm30`: the IES TM-30-15 lamps in the prior (train, never score).
    - `sigma_rule`, `floor_grid`: how the band-error model is chosen.
    - `calibration`: interval calibration on held-out lamps ("lamps"), on
      each training class held out in turn ("classes": new types too), or
      the first for pixels the prior explains and the second for pixels
      flagged `unexplained` ("flagged").
    - `interval_offsets`: candidate interval offsets (the narrowest wins).
    - `moon_told`: the Moon's brightness of every scene is known (from the
      acquisition's time and place), so it is not fitted.
    - `modelled_per_class`: modelled lamps of rare classes in the prior.
    - `nir_error`: the modelled NIR of extended lamps carries its measured
      error (`nir_variants`), so no type rests on it alone.
    - `calibrate_probabilities`: type probabilities temperature-scaled on
      held-out lamps of known types (`bandopt.calibration`); held-out types
      are reported beside them and left to the `unexplained` flag."""

    mixtures: int = MIX_PAIRS
    cross_mixtures: int = CROSS_MIX_PAIRS
    peak_shifts_nm: tuple[float, ...] = PEAK_SHIFTS_NM
    planck: bool = True
    tm30: bool = False
    sigma_rule: str = "per-metric"
    floor_grid: tuple[float, ...] = FLOOR_GRID
    calibration: str = "flagged"
    interval_offsets: tuple[float, ...] = INTERVAL_OFFSET_GRID
    moon_told: bool = True
    modelled_per_class: int = 0
    nir_error: bool = True
    calibrate_probabilities: bool = True

    def fit_kwargs(self) -> dict:
        """The keyword arguments of `fit_inversion` these options set (all
        but the data, the prior's always-present lamps and the Moon)."""
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


ESTIMATORS = ("inversion", "ridge", "kernel")
"""Estimators `cross_validate` and `bandopt evaluate` know (`cross_validate`
also `MODELLED_ESTIMATORS`)."""


MODELLED_ESTIMATORS = ("inversion+models", "ridge+models", "kernel+models")
"""`cross_validate` estimators that train on modelled lamps too: the inversion
with them in its prior, the ridge and kernel ridge with their scenes among
the training rows (`augment_with_modelled`)."""


MOON_ESTIMATOR = "inversion-moon"
"""`cross_validate` estimator: the inversion told each pixel's Moon brightness
(`context_moon`; known from the acquisition's time and place) instead of
fitting it."""


MOON_UNSEEN_ESTIMATOR = "inversion-moon-loco"
"""`cross_validate` estimator: `MOON_ESTIMATOR` with its 90 % intervals
calibrated on training classes held out in turn (leave one class out,
`fit_inversion(calibration="classes")`) instead of held-out lamps of known
classes: the same point estimates, intervals meant to hold for lamp types
the prior does not know."""


EVIDENCE_ESTIMATOR = "inversion-evidence"
"""`cross_validate` estimator: the inversion with `σ_rel` chosen by held-out
log evidence (`fit_inversion(sigma_rule="evidence")`) instead of metric error."""


MIX_ESTIMATOR = "inversion-moon-mix"
"""`cross_validate` estimator: `MOON_ESTIMATOR` with pairwise same-class
mixtures of its prior's lamps in every prior (`fit_inversion(mixtures=
MIX_PAIRS)`, `mixture_lamps`)."""


MIX_METRIC_ESTIMATOR = "inversion-moon-mix-metric"
"""`cross_validate` estimator: `MIX_ESTIMATOR` with each metric estimated
with its own band-error model, `σ_rel` and floor (`fit_inversion(
sigma_rule="per-metric", floor_grid=FLOOR_GRID)`)."""


NARROW_ESTIMATOR = "inversion-moon-mix-metric-narrow"
"""`cross_validate` estimator: `MIX_METRIC_ESTIMATOR` with each metric's
interval unit offset chosen for the narrowest calibrated intervals
(`fit_inversion(interval_offsets=INTERVAL_OFFSET_GRID)`): the same
estimates, other intervals. Asked for together with `MIX_METRIC_ESTIMATOR`,
both come from one fit (that one at offset 0, `Inversion.
with_interval_offset`)."""


SHIFT_ESTIMATOR = "inversion-moon-mix-metric-narrow-shift"
"""`NARROW_ESTIMATOR` with wavelength-shifted copies of the prior's
direct-emission LEDs in every prior (`fit_inversion(peak_shifts=
PEAK_SHIFTS_NM)`, `shifted_lamps`)."""


PLANCK_ESTIMATOR = "inversion-moon-mix-metric-narrow-planck"
"""`NARROW_ESTIMATOR` with the library's modelled incandescent spectra
(`planck_lamps`) in every prior, beside the never-scored measured lamps:
modelled spectra train, never score; its records say `modelled_in_prior`."""


DEFAULT_ESTIMATOR = "inversion-moon-mix-metric-narrow-shift-planck"
"""`NARROW_ESTIMATOR` with both `SHIFT_ESTIMATOR`'s shifted LEDs and
`PLANCK_ESTIMATOR`'s modelled incandescent spectra in every prior: what
`bandopt evaluate` does by default."""


TM30_ESTIMATOR = "inversion-moon-mix-metric-narrow-shift-planck-tm30"
"""`DEFAULT_ESTIMATOR` with the measured IES TM-30-15 lamps the library lacks
(`tm30_lamps`) in every prior, beside the never-scored measured lamps: they
train, never score; its records say `tm30_in_prior`."""


PLAIN = InversionOptions(
    mixtures=0,
    cross_mixtures=0,
    peak_shifts_nm=(),
    planck=False,
    tm30=False,
    sigma_rule="error",
    floor_grid=(SIGMA_FLOOR,),
    calibration="lamps",
    interval_offsets=(0.0,),
    moon_told=False,
    modelled_per_class=0,
    nir_error=False,
    calibrate_probabilities=False,
)
"""The inversion with every option off (`fit_inversion`'s own defaults): a
prior of measured lamps, one band-error model chosen by held-out error, the
Moon fitted, intervals calibrated on held-out lamps in units of the
posterior's half-width."""


def _labelled() -> dict:
    moon = dataclasses.replace(PLAIN, moon_told=True)
    mix = dataclasses.replace(moon, mixtures=MIX_PAIRS)
    metric = dataclasses.replace(mix, sigma_rule="per-metric", floor_grid=FLOOR_GRID)
    narrow = dataclasses.replace(metric, interval_offsets=INTERVAL_OFFSET_GRID)
    default = dataclasses.replace(narrow, peak_shifts_nm=PEAK_SHIFTS_NM, planck=True)
    return {
        "inversion": PLAIN,
        "inversion+models": PLAIN,  # modelled_per_class from `cross_validate`
        EVIDENCE_ESTIMATOR: dataclasses.replace(PLAIN, sigma_rule="evidence"),
        MOON_ESTIMATOR: moon,
        MOON_UNSEEN_ESTIMATOR: dataclasses.replace(moon, calibration="classes"),
        MIX_ESTIMATOR: mix,
        MIX_METRIC_ESTIMATOR: metric,
        NARROW_ESTIMATOR: narrow,
        SHIFT_ESTIMATOR: dataclasses.replace(narrow, peak_shifts_nm=PEAK_SHIFTS_NM),
        PLANCK_ESTIMATOR: dataclasses.replace(narrow, planck=True),
        DEFAULT_ESTIMATOR: default,
        TM30_ESTIMATOR: dataclasses.replace(default, tm30=True),
    }


LABELLED: dict[str, InversionOptions] = _labelled()
"""The options of each named inversion variant of `cross_validate`, in one
place: every name is the steps of options it adds to `PLAIN` (`-moon` the
Moon told, `-mix` blends, `-metric` a band-error model per metric,
`-narrow` the narrowest interval unit, `-shift` shifted LEDs, `-planck`
Planck spectra, `-tm30` the TM-30 lamps, `-loco` intervals calibrated on
classes held out in turn, `-evidence` σ chosen by held-out evidence)."""


def options_of(label: str) -> InversionOptions:
    """The options of a named variant: `LABELLED[label]`, or, for a name
    ending in `-loco` whose stem is labelled, the stem's options with the
    intervals calibrated on classes held out in turn (`calibration=
    "classes"`, as an unseen-types run of that variant)."""
    if label in LABELLED:
        return LABELLED[label]
    stem = label.removesuffix("-loco")
    if stem != label and stem in LABELLED:
        return dataclasses.replace(LABELLED[stem], calibration="classes")
    raise ValueError(
        f"inversion variant {label!r}: expected one of {sorted(LABELLED)}, "
        "optionally with -loco."
    )
