"""The options of a fitted estimator, shared by `bandopt fit` and `bandopt
evaluate`: the band set, the estimator and its configuration, the user's
prior lamps and the surface knowledge; how they are checked, turned into a
configuration (`bandopt.estimators`) and into a fitted estimator (from a
model file, the cache or a fit)."""

from ._evaluate_inputs import (
    check_nir,
    load_user_lamp,
    parse_prior_lamps,
    prior_class_warning,
    prior_lamp_names,
    read_reflectance,
)
from ._options import add_list_option, bounded


SCENE = {
    "surface": "asphalt",
    "atmosphere": "none",
    "moon": None,
    "lighting_class": "P4",
    "view_zenith_deg": 0.0,
}
"""The scene `bandopt evaluate` lights with each lamp (its surface is the
surface an estimator does not know)."""


MIXTURES_DEFAULT = 50
"""Default of `--mixtures`: `bandopt.inversion.MIX_PAIRS` (not imported here:
the parser is built without JAX)."""

CROSS_MIXTURES_DEFAULT = 3
"""Default of `--cross-mixtures`: `bandopt.inversion.CROSS_MIX_PAIRS` (not
imported here: the parser is built without JAX)."""

PEAK_SHIFTS = {"on": "grid", "off": ()}
"""`--peak-shifts` choice -> `bandopt.inversion.fit_inversion(peak_shifts=)`
("grid": `PEAK_SHIFTS_NM`, not imported here: the parser is built without
JAX)."""

PEAK_SHIFTS_DEFAULT = "on"
"""Default of `--peak-shifts` (see `results/estimate_shift/`)."""

PLANCK_DEFAULT = "on"
"""Default of `--planck` (see `results/estimate_planck/`)."""

TM30_DEFAULT = "off"
"""Default of `--tm30` (see `results/estimate_tm30/`)."""

SIGMA_RULES = {"per-metric": "per-metric", "joint": "error"}
"""`--sigma` choice -> `bandopt.inversion.fit_inversion(sigma_rule=)`."""

INTERVALS = {"by-flag": "flagged", "known-types": "lamps", "any-type": "classes"}
"""`--intervals` choice -> `bandopt.inversion.fit_inversion(calibration=)`."""

INTERVAL_UNITS = {"narrowest": "grid", "half-width": (0.0,)}
"""`--interval-unit` choice -> `bandopt.inversion.fit_inversion(
interval_offsets=)` ("grid": `INTERVAL_OFFSET_GRID`, not imported here: the
parser is built without JAX)."""


def surface_of(args, grid):
    """(scene reflectance on grid, label, surface mode, knowledge for the inversion)."""
    from pathlib import Path

    from ..datasets import surfaces

    if args.surface is None:
        _, refl = surfaces.mean_reflectance([SCENE["surface"]], grid)
        return refl[0], SCENE["surface"], "unknown", None
    if Path(args.surface).is_file():
        return read_reflectance(args.surface, grid), str(args.surface), "measured", None
    try:
        name = surfaces.resolve_surface(args.surface)
    except (KeyError, ValueError) as exc:
        raise ValueError(
            f"--surface {args.surface!r}: neither a file nor a surface type ({exc})"
        ) from None
    _, refl = surfaces.mean_reflectance([name], grid)
    return refl[0], name, "class", name


OPTIONS = {
    # dest: (flag, default, configuration field, why the option is refused)
    "modelled_per_class": ("--modelled-per-class", 0, "modelled_per_class",
                           "modelled lamps go into the prior of"),
    "mixtures": ("--mixtures", MIXTURES_DEFAULT, "mixtures",
                 "blends go into the prior of"),
    "cross_mixtures": ("--cross-mixtures", CROSS_MIXTURES_DEFAULT, "cross_mixtures",
                       "blends go into the prior of"),
    "sigma": ("--sigma", "per-metric", "sigma_rule", "for"),
    "interval_unit": ("--interval-unit", "narrowest", "interval_offsets", "for"),
    "planck": ("--planck", PLANCK_DEFAULT, "planck",
               "the Planck spectra go into the prior of"),
    "tm30": ("--tm30", TM30_DEFAULT, "tm30", "the TM-30 lamps go into the prior of"),
    "peak_shifts": ("--peak-shifts", PEAK_SHIFTS_DEFAULT, "peak_shifts_nm",
                    "shifted LEDs go into the prior of"),
    "intervals": ("--intervals", "by-flag", "calibration", "for"),
}  # fmt: skip
"""The estimator options of `bandopt evaluate`: each sets one field of an
estimator's configuration (`bandopt.estimators`); given (not at its
default) for an estimator without that field, it is refused."""


def check_options(args) -> None:
    """Refuses, before anything is read or trained, an option the chosen
    estimator's configuration lacks, naming the estimators that have it."""
    from ..estimators import ESTIMATORS, options_of, owners_of

    est = args.estimator
    for dest, (flag, default, field, why) in OPTIONS.items():
        value = getattr(args, dest)
        if value != default and field not in options_of(est):
            raise ValueError(
                f"{flag} {value}: {why} --estimator "
                f"{', '.join(owners_of(field))} only (got --estimator {est})."
            )
    if args.prior_lamps and not ESTIMATORS[est].own_lamps:
        owners = [n for n, c in ESTIMATORS.items() if c.own_lamps]
        raise ValueError(
            f"--prior-lamps: your lamps go into the prior of --estimator "
            f"{', '.join(owners)} only (got --estimator {est})."
        )


def config_of(args):
    """The chosen estimator's configuration from the options."""
    from .. import inversion as inv_mod
    from ..estimators import InversionConfig, configure

    if args.estimator != "inversion":
        return configure(args.estimator)
    return InversionConfig(
        mixtures=args.mixtures,
        cross_mixtures=args.cross_mixtures,
        peak_shifts_nm=(
            inv_mod.PEAK_SHIFTS_NM
            if PEAK_SHIFTS[args.peak_shifts] == "grid"
            else PEAK_SHIFTS[args.peak_shifts]
        ),
        planck=args.planck == "on",
        tm30=args.tm30 == "on",
        sigma_rule=SIGMA_RULES[args.sigma],
        floor_grid=(
            inv_mod.FLOOR_GRID if args.sigma == "per-metric" else (inv_mod.SIGMA_FLOOR,)
        ),
        calibration=INTERVALS[args.intervals],
        interval_offsets=(
            inv_mod.INTERVAL_OFFSET_GRID
            if INTERVAL_UNITS[args.interval_unit] == "grid"
            else INTERVAL_UNITS[args.interval_unit]
        ),
        modelled_per_class=args.modelled_per_class,
    )


def fit_on(args, ctx, bands, mode):
    """The chosen estimator (`bandopt.estimators`) trained on every scored
    library lamp of `ctx` (inner folds: its outer splits), with the user's
    own lamps where it takes them: a fitted estimator with `predict`,
    `report` and `description`."""
    return config_of(args).fit(
        ctx, bands, surface_mode=mode, own=getattr(args, "own_lamps", None)
    )


def prepare(args):
    """(band set, its label, configuration, warnings) of the options, every
    static mistake refused before any file is read or anything trains."""
    import sys

    from ._checks import band_set_warnings
    from ._cmd_bands import _load

    if args.modelled_per_class < 0:
        raise ValueError(
            f"--modelled-per-class {args.modelled_per_class}: must be >= 0."
        )
    check_options(args)
    bands, entry = _load(args.bands)
    name = entry.key if entry is not None else bands.name
    config = config_of(args)
    try:
        config.check(bands)  # before any lamp is read or anything trains
    except ValueError as exc:
        raise ValueError(f"--bands {args.bands}: {exc}") from None
    if config.needs_surface and args.surface is None:
        raise ValueError(
            f"--estimator {args.estimator} needs --surface NAME|FILE: it divides "
            "the surface out of the band values, and with the library's mean "
            "reflectance instead its errors are large (results/estimate_bands)."
        )
    warnings = band_set_warnings(bands, args.bands, log=sys.stderr)
    check_nir(args.nir)
    return bands, name, config, warnings


def read_prior_lamps(args, warnings: list):
    """The user's `--prior-lamps` as [(class, path)] and their loaded
    spectra; sets `args.own_lamps` ((names, values on GRID_1NM, classes) or
    None) and adds a warning for a lamp unlike its class."""
    import sys

    import numpy as np

    from ..spectra import GRID_1NM

    prior_files = parse_prior_lamps(args.prior_lamps)
    prior_loaded = [load_user_lamp(p, args.nir) for _, p in prior_files]
    for (cls, p), (spectra, _) in zip(prior_files, prior_loaded, strict=True):
        w = prior_class_warning(cls, p, spectra[0], np.asarray(GRID_1NM, float))
        if w is not None:
            warnings.append(w)
            print(f"warning: {w}", file=sys.stderr)
    args.own_lamps = (
        (
            prior_lamp_names([p for _, p in prior_files]),
            np.array([v[0] for v, _ in prior_loaded]),  # the most likely NIR
            [c for c, _ in prior_files],
        )
        if prior_files
        else None
    )
    return prior_files, prior_loaded


def obtain_fitted(args, bands, config, mode, fit=None):
    """(fitted estimator, its fingerprint) for the options: read from
    `--model` when given (refused when its fingerprint differs), else
    loaded from the cache or fitted (by `fit(ctx)`, default `fit_on`) and
    cached (`bandopt.estimators.fit_cached`); a note on stderr says which."""
    import sys
    from pathlib import Path

    from ..estimators import fingerprint, fit_cached, load_fitted

    own = getattr(args, "own_lamps", None)
    model = getattr(args, "model", None)
    if model:
        if not Path(model).is_file():
            raise ValueError(f"--model {model}: no such file.")
        fp = fingerprint(config, bands, surface_mode=mode, own=own)
        return load_fitted(model, fp), fp
    fitted, outcome = fit_cached(
        config,
        bands,
        surface_mode=mode,
        own=own,
        fit=fit or (lambda ctx: fit_on(args, ctx, bands, mode)),
    )
    text = {
        "loaded": f"estimator loaded from the cache ({outcome.path})",
        "fitted": f"estimator fitted and cached ({outcome.path})",
        "refitted": f"the cached estimator {outcome.reason}: refitted and "
        f"replaced ({outcome.path})",
        "uncached": f"estimator fitted, not cached ({outcome.reason})",
    }[outcome.action]
    print(f"note: {text}", file=sys.stderr)
    return fitted, outcome.fingerprint


def _count_option(p, flag: str, default: int, text: str) -> None:
    """A count option (an int >= 0, metavar N) of the fit."""
    p.add_argument(
        flag, type=bounded(int, lo=0, why="(a count)"), default=default,
        metavar="N", help=text,
    )  # fmt: skip


def add_estimator_options(p):
    """The options a fit depends on, shared by `bandopt fit` and `bandopt
    evaluate`: the band set, the estimator and its options, the user's prior
    lamps (read with `--nir`) and what is known of the surface."""
    p.add_argument(
        "--bands",
        required=True,
        metavar="NAME|FILE",
        help="reference sensor name (e.g. sdgsat-1) or band-set JSON file",
    )
    p.add_argument(
        "--nir",
        default="auto",
        metavar="TECHNOLOGY|none|auto|FILE",
        help="near-infrared beyond a spectrum's measured end (when it ends "
        "before 900 nm): auto (default: the technology of its spectral "
        "features; every candidate when they are ambiguous), a technology ("
        "hps, lps, metal_halide, mercury, fluorescent, incandescent, led), none "
        "(zeros) or a two-column FILE with your own NIR, in the unit of the "
        "spectra, covering their measured end to 900 nm",
    )
    p.add_argument(
        "--estimator",
        choices=("inversion", "ridge", "kernel", "direct"),
        default="inversion",
        help="inversion (default): physics-based inversion with a prior over the "
        "measured library lamps, 90 %% intervals and an 'unexplained' flag; ridge / "
        "kernel: regression baselines on centred log band ratios, bounded to the "
        "training range, with split-conformal 90 %% intervals and an 'unexplained' "
        "flag for band ratios unlike every library lamp's; direct: no lamp "
        "library, the band values read as a spectrum once the surface is divided "
        "out, for contiguous bands tiling 380-780 nm and a known --surface "
        "(results/estimate_bands), with 90 %% intervals calibrated on the library "
        "lamps",
    )
    _count_option(
        p,
        "--modelled-per-class",
        0,
        "inversion only: also put N modelled lamps per rare class (lps, "
        "mercury, led_amber, metal_halide, hps; physical lamp models of "
        "bandopt.lampmodels calibrated on the measured training lamps of each "
        "fit only) into the prior; they train, never score. Default 0: measured "
        "lamps only. The first use fits the models to their measured lamps "
        "(several minutes); the JSON says modelled_lamps_used",
    )
    _count_option(
        p,
        "--mixtures",
        MIXTURES_DEFAULT,
        "inversion only: also put pairwise blends of two measured library "
        "lamps of one class (flux fractions 1/4, 1/2, 3/4) into the prior, up to "
        f"N pairs per class (default {MIXTURES_DEFAULT}; 0: measured lamps only). "
        "They fill the gaps between the library's lamps; their LER, G and CCT "
        "are computed from the blended spectra, so still physical "
        "(results/estimate_mix)",
    )
    _count_option(
        p,
        "--cross-mixtures",
        CROSS_MIXTURES_DEFAULT,
        "inversion only: also put blends of two lamps of different types "
        "(the second giving 10, 25 or 40 %% of the light, named by the first) "
        "into the prior, N lamp pairs per pair of types (default "
        f"{CROSS_MIXTURES_DEFAULT}; 0: none), as a pixel holding two lamp types "
        "sees them",
    )
    p.add_argument(
        "--peak-shifts",
        choices=tuple(PEAK_SHIFTS),
        default=PEAK_SHIFTS_DEFAULT,
        help="inversion only: also put copies of the library's direct-emission "
        "LEDs (one visible band at most 40 nm wide: the direct amber LEDs) "
        "shifted by +-2.5 to +-10 nm into the prior, so a new LED whose band "
        "lies between or beyond the library's is represented; their LER, G and "
        f"CCT are computed from the shifted spectra (default {PEAK_SHIFTS_DEFAULT}; "
        "results/estimate_shift)",
    )
    p.add_argument(
        "--planck",
        choices=("on", "off"),
        default=PLANCK_DEFAULT,
        help="inversion only: also put the library's modelled incandescent "
        "spectra (Planck's law, 2400-3200 K) into the prior, so an incandescent "
        "lamp is named incandescent whatever the measured lamps; modelled "
        "spectra train, never score, and the JSON lists them in "
        f"modelled_in_prior (default {PLANCK_DEFAULT}; results/estimate_planck)",
    )
    p.add_argument(
        "--tm30",
        choices=("on", "off"),
        default=TM30_DEFAULT,
        help="inversion only: also put the measured lamps of the IES TM-30-15 "
        "source library that the library lacks (210: commercial and experimental "
        "LED, fluorescent, HID and filament lamps; IES2015, vendored from LuxPy) "
        "into the prior; measured lamps that train, never score, and the JSON "
        f"counts them in tm30_lamps_in_prior (default {TM30_DEFAULT}; "
        "results/estimate_tm30)",
    )
    add_list_option(
        p,
        "--prior-lamps",
        default=[],
        default_help="none",
        metavar="CLASS=FILE",
        split_commas=False,
        help="inversion only: also put your own measured lamp spectra into the "
        "prior, each with its level-2 class (e.g. led_warm=my_led.csv "
        "hps=street_hps.csv; files as for --lamps). A lamp the library lacks "
        "costs most of the estimate's error (results/estimate_library); "
        "measured spectra of the lamps in your scene remove that. They train, "
        "never score; the JSON lists them in prior_lamps",
    )
    p.add_argument(
        "--sigma",
        choices=tuple(SIGMA_RULES),
        default="per-metric",
        help="inversion only: the band-error model the posterior assumes, "
        "sigma_rel |y| + floor. per-metric (default): each of LER, G and CCT "
        "under its own sigma_rel and floor, chosen on lamp-grouped folds by "
        "that metric's error (LER is best with bands weighted nearly "
        "uniformly, G and CCT nearly by relative error); one scoring per "
        "distinct model, so 2-3x the time. joint: one sigma_rel (floor 0.001) "
        "for all three. Lamp types and the unexplained flag use the "
        "joint choice either way (results/estimate_mix)",
    )
    p.add_argument(
        "--intervals",
        choices=tuple(INTERVALS),
        default="by-flag",
        help="inversion only: what its 90 %% intervals are calibrated for. "
        "by-flag (default): a pixel the library explains gets intervals "
        "calibrated on held-out lamps of the library's types, a pixel flagged "
        "unexplained those calibrated on library classes held out in turn; "
        "any-type: every pixel the latter (wide: 0.97-0.98 of new lamps of "
        "known types inside); known-types: every pixel the former "
        "(results/robustness gives the coverage and widths of the default)",
    )
    p.add_argument(
        "--interval-unit",
        choices=tuple(INTERVAL_UNITS),
        default="narrowest",
        help="inversion only: the unit the conformal factor widens the "
        "posterior's 5-95 %% range by. narrowest (default): the posterior's "
        "half-width plus an offset, per metric the one of 0-10 x the metric's "
        "spread over the library lamps whose calibrated intervals are narrowest "
        "on the held-out lamps (same coverage there); half-width: the "
        "posterior's half-width alone (a broad posterior gets a very "
        "wide interval). Same estimates either way (results/estimate_intervals)",
    )
    p.add_argument(
        "--surface",
        metavar="NAME|FILE",
        default=None,
        help="surface under the lamp, known to the estimator: a surface type "
        "(e.g. grass; `bandopt surfaces`) or a two-column reflectance file "
        "(wavelength [nm], reflectance [0-1], covering 380-900 nm). Default: the "
        "scene's asphalt, unknown to the estimator",
    )
