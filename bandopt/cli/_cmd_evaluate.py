"""`bandopt evaluate`: LER, G and CCT of user lamp spectra, true and estimated
from the band radiances of a band set."""

from ._evaluate_inputs import (
    check_nir,
    load_user_lamp,
    merge_candidates,
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
NIR_POLICY = (
    "A spectrum must cover 380-780 nm. Every measured value is kept; beyond the "
    "measured end (if before 900 nm) it is extended to 900 nm as --nir says "
    "(bandopt.datasets.technology.extend_user_spectrum). auto (default): by the "
    "technology its visible spectrum shows (Hg 405/436/546/578 nm lines, Na 589 "
    "nm core or broadened band, Na 498/819 nm, Eu 611 nm, Tl 535 nm and other "
    "metal halide lines, blue pump and broad phosphor, smooth Planck-like "
    "continuum), with the NIR model of bandopt.datasets.nir; when two or more "
    "technologies score within a factor 2, one extension per candidate: the "
    "estimator runs on each, the estimate is the most likely candidate's, every "
    "90 % interval is the union over candidates and the level-1 probabilities "
    "are the candidates' average. A technology name forces its model, none "
    "puts zeros beyond the measured end, a FILE gives your own NIR (same unit). "
    "notes say, per lamp, the technology used, its evidence and the candidates. "
    "Resampling to the 1 nm library grid is linear."
)


def register(subparsers):
    p = subparsers.add_parser(
        "evaluate",
        help="true and estimated LER, G, CCT of lamp spectra for a band set",
        description=(
            "Estimate LER, G index and CCT of your lamp spectra from the band "
            "radiances of a band set, by default with the physics-based inversion "
            "(a prior of the built-in lamp library, calibrated 90 % intervals, "
            "level-1 lamp-type probabilities and an unexplained flag; "
            "--estimator ridge|kernel for the brightness-free regression baselines "
            "trained on the library, direct for the library-free estimate): for "
            "each lamp spectrum file, the truth (from the full spectrum) and the "
            "estimates from the band radiances of that lamp lighting the default "
            f"scene {SCENE}. " + NIR_POLICY
        ),
    )
    p.add_argument(
        "--bands",
        required=True,
        metavar="NAME|FILE",
        help="reference sensor name (e.g. sdgsat-1) or band-set JSON file",
    )
    add_list_option(
        p,
        "--lamps",
        required=True,
        metavar="FILE",
        help="lamp spectrum files (.csv/.txt/.dat two columns, .prn, .xml/.spdx)",
        split_commas=False,
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
    p.add_argument(
        "--modelled-per-class",
        type=bounded(int, lo=0, why="(a count)"),
        default=0,
        metavar="N",
        help="inversion only: also put N modelled lamps per rare class (lps, "
        "mercury, led_amber, metal_halide, hps; physical lamp models of "
        "bandopt.lampmodels calibrated on the measured training lamps of each "
        "fit only) into the prior; they train, never score. Default 0: measured "
        "lamps only. The first use fits the models to their measured lamps "
        "(several minutes); the JSON says modelled_lamps_used",
    )
    p.add_argument(
        "--mixtures",
        type=bounded(int, lo=0, why="(a count)"),
        default=MIXTURES_DEFAULT,
        metavar="N",
        help="inversion only: also put pairwise blends of two measured library "
        "lamps of one class (flux fractions 1/4, 1/2, 3/4) into the prior, up to "
        f"N pairs per class (default {MIXTURES_DEFAULT}; 0: measured lamps only). "
        "They fill the gaps between the library's lamps; their LER, G and CCT "
        "are computed from the blended spectra, so still physical "
        "(results/estimate_mix)",
    )
    p.add_argument(
        "--cross-mixtures",
        type=bounded(int, lo=0, why="(a count)"),
        default=CROSS_MIXTURES_DEFAULT,
        metavar="N",
        help="inversion only: also put blends of two lamps of different types "
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
        default="any-type",
        help="inversion only: what its 90 %% intervals are calibrated for. "
        "any-type (default): lamp types the library lacks too (conformal factors "
        "from each library class held out in turn; measured: 0.83-0.96 of "
        "held-out classes' true values inside, 0.95-0.97 for new lamps of known "
        "types); known-types: new lamps of the library's types only (factors "
        "from held-out lamps; narrower: 0.92-0.93 for known types, 0.73-0.82 "
        "for held-out classes; results/estimate_moon)",
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
    p.add_argument(
        "--plot", metavar="PNG", help="figure: truth vs estimate with 90 %% intervals"
    )
    p.add_argument("--json", action="store_true", help="print JSON (input order)")
    p.set_defaults(func=run)


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

INTERVALS = {"known-types": "lamps", "any-type": "classes"}
"""`--intervals` choice -> `bandopt.inversion.fit_inversion(calibration=)`."""

INTERVAL_UNITS = {"narrowest": "grid", "half-width": (0.0,)}
"""`--interval-unit` choice -> `bandopt.inversion.fit_inversion(
interval_offsets=)` ("grid": `INTERVAL_OFFSET_GRID`, not imported here: the
parser is built without JAX)."""


def _surface(args, grid):
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
    "intervals": ("--intervals", "any-type", "calibration", "for"),
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


def _config(args):
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


def _fit(args, ctx, bands, mode):
    """The chosen estimator (`bandopt.estimators`) trained on every scored
    library lamp of `ctx` (inner folds: its outer splits), with the user's
    own lamps where it takes them: a fitted estimator with `predict`,
    `report` and `description`."""
    return _config(args).fit(
        ctx, bands, surface_mode=mode, own=getattr(args, "own_lamps", None)
    )


def run(args) -> int:
    import math
    import sys

    import numpy as np

    from ..estimate import METRICS, truth_with_reasons
    from ..estimators import Surface
    from ..forward import band_radiance
    from ..photometry import ler as ler_fn
    from ..scene import class_illuminance_lx
    from ..search import get_context
    from ..spectra import GRID_1NM
    from ._checks import band_set_warnings
    from ._cmd_bands import _load

    if args.modelled_per_class < 0:
        raise ValueError(
            f"--modelled-per-class {args.modelled_per_class}: must be >= 0."
        )
    check_options(args)
    bands, entry = _load(args.bands)
    name = entry.key if entry is not None else bands.name
    config = _config(args)
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
    lamps = [load_user_lamp(p, args.nir) for p in args.lamps]  # before training
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
    grid = np.asarray(GRID_1NM, float)
    refl, surface_label, mode, knowledge = _surface(args, grid)
    ctx = get_context("search", None, 0, "none")
    fitted = _fit(args, ctx, bands, mode)
    desc, rep = fitted.description, fitted.report()
    e_lx = class_illuminance_lx(SCENE["lighting_class"])
    vis = (grid >= 380) & (grid <= 780)

    truths, true_why, notes, at_sensor, owner = [], [], [], [], []
    for k, (candidates, note) in enumerate(lamps):
        values = candidates[0]  # the truth is visible-only: any candidate
        truth, why = truth_with_reasons(values[None], grid)
        # lumens ∝ K_m ∫ V S dλ = LER · ∫ S dλ (380-780 nm)
        lumens = float(ler_fn(values[None, vis], grid[vis])[0]) * float(
            np.trapezoid(values[vis], grid[vis])
        )
        for cand in candidates:  # one row per NIR candidate, most likely first
            per_lx = cand / lumens  # spectral irradiance per lux [W m-2 nm-1 lx-1]
            at_sensor.append(e_lx * refl / math.pi * per_lx)  # no atmosphere
            owner.append(k)
        truths.append(
            {
                m: (float(truth[0, i]) if np.isfinite(truth[0, i]) else None)
                for i, m in enumerate(METRICS)
            }
        )
        true_why.append(why[0])
        if note:
            notes.append(note)
    band_rad = np.asarray(
        band_radiance(np.asarray(at_sensor), bands, wavelength_nm=grid)
    )
    notes += [{**n, "prior_lamp": True} for _, n in prior_loaded if n]
    surface = Surface(mode, knowledge if mode == "class" else None, refl)
    est = fitted.predict(band_rad, surface)
    est_rows = [est.row(i) for i in range(len(est))]
    owner = np.asarray(owner)
    est_rows = [
        merge_candidates([est_rows[i] for i in np.flatnonzero(owner == k)])
        for k in range(len(lamps))
    ]
    rows = []
    for path, t, tw, r in zip(args.lamps, truths, true_why, est_rows, strict=True):
        rows.append(
            {
                "file": str(path),
                "true": t,
                "true_null_reasons": tw,
                "estimate": r["estimate"],
                "interval90": r["interval90"],
                "null_reasons": r["null_reasons"],
                "unexplained": r["unexplained"],
                "known_type_p_value": r.get("known_type_p_value"),
                "level1_probabilities": r["level1_probabilities"],
                "level1_top2": r.get("level1_top2"),
                "predicted_level1": r["predicted_level1"],
                "predicted_level2": r["predicted_level2"],
                **(
                    {"nearest_library_lamp": r["nearest_library_lamp"]}
                    if "nearest_library_lamp" in r
                    else {}
                ),
            }
        )
    scene = {**SCENE, "surface": surface_label}
    out = {
        "bands": name,
        "scene": {
            **scene,
            "illuminance_lx": e_lx,
            "estimator": args.estimator,
            "estimator_description": desc,
            "surface_knowledge": mode,
            "intervals": rep["intervals"],
            "interval_unit": rep["interval_unit"],
            "nir_policy": NIR_POLICY,
        },
        "lamps": rows,
        "notes": notes,
        "warnings": warnings,
        "modelled_lamps_used": args.modelled_per_class,
        **{
            k: rep[k]
            for k in (
                "mixtures_per_class",
                "cross_mixtures_per_class_pair",
                "modelled_in_prior",
                "peak_shifts_nm",
                "tm30_lamps_in_prior",
                "sigma_rel",
            )
        },
        "prior_lamps": [
            {"file": str(p), "level2": c, "id": f"own:{n}"}
            for (c, p), n in zip(
                prior_files, prior_lamp_names([p for _, p in prior_files]), strict=True
            )
        ],
    }
    if args.plot:
        _plot(rows, name, args.estimator, args.plot)
    if args.json:
        from ._output import print_json

        print_json(out)
        return 0
    print(f"bands: {name}; scene: {scene}; estimator: {args.estimator}")
    for r in rows:
        parts = []
        for m in METRICS:
            tv, ev, iv = r["true"][m], r["estimate"][m], (r["interval90"] or {}).get(m)
            est_txt = "null" if ev is None else f"{ev:.4g}"
            if iv:
                est_txt += f" [{iv[0]:.4g}, {iv[1]:.4g}]"
            parts.append(
                f"{m} true {'n/a' if tv is None else f'{tv:.4g}'} est {est_txt}"
            )
        flag = " UNEXPLAINED" if r["unexplained"] else ""
        print(
            f"{r['file']}: "
            + "; ".join(parts)
            + f"; type {r['predicted_level2'] or r['predicted_level1']}{flag}"
        )
    for n in notes:
        ev = "; ".join(n["identification"]["evidence"][:3])
        print(
            f"note: {n['file']} measured to {n['measured_to_nm']:g} nm: "
            f"{n['policy']} ({ev})"
        )
    return 0


def _plot(rows, bands_name, estimator, path):
    """Truth vs estimate with 90 % intervals, one panel per metric."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    units = {"LER": "lm/W", "G": "1", "CCT": "K"}
    fig, axes = plt.subplots(1, 3, figsize=(12, 4.4))
    handles = []
    for ax, m in zip(axes, ("LER", "G", "CCT"), strict=True):
        xs, ys, lo, hi = [], [], [], []
        for r in rows:
            t, e = r["true"][m], r["estimate"][m]
            if t is None or e is None:
                continue
            iv = (r["interval90"] or {}).get(m) or [e, e]
            xs.append(t)
            ys.append(e)
            lo.append(e - iv[0])
            hi.append(iv[1] - e)
        if xs:
            ax.errorbar(
                xs,
                ys,
                yerr=[lo, hi],
                fmt="o",
                capsize=3,
                label="estimate, 90 % interval",
            )
            a, b = min(xs + ys), max(xs + ys)
            ax.plot([a, b], [a, b], "k--", lw=1, label="1:1")
            handles = handles or ax.get_legend_handles_labels()[0]
        else:
            ax.text(
                0.5,
                0.5,
                "no lamp with both values",
                ha="center",
                transform=ax.transAxes,
            )
        ax.set_xlabel(f"true {m} [{units[m]}]")
        ax.set_ylabel(f"estimated {m} [{units[m]}]")
    fig.suptitle(f"bandopt evaluate: {bands_name}, estimator {estimator}")
    if handles:  # one legend below the panels, never over the data
        fig.legend(handles=handles, loc="lower center", ncols=2, fontsize=8)
    fig.tight_layout(rect=(0.0, 0.07, 1.0, 1.0))
    fig.savefig(path, dpi=110)
    plt.close(fig)
