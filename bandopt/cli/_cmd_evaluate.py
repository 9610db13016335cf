"""`bandopt evaluate`: LER, G and CCT of user lamp spectra, true and estimated
from the band radiances of a band set."""

from ._estimator_options import (
    CROSS_MIXTURES_DEFAULT as CROSS_MIXTURES_DEFAULT,
    MIXTURES_DEFAULT as MIXTURES_DEFAULT,
    OPTIONS as OPTIONS,
    PEAK_SHIFTS_DEFAULT as PEAK_SHIFTS_DEFAULT,
    PLANCK_DEFAULT as PLANCK_DEFAULT,
    SCENE as SCENE,
    TM30_DEFAULT as TM30_DEFAULT,
    add_estimator_options,
    config_of,
    fit_on,
    obtain_fitted,
    prepare,
    read_prior_lamps,
    surface_of,
)
from ._evaluate_inputs import (
    check_nir as check_nir,
    load_user_lamp,
    merge_candidates,
    parse_prior_lamps as parse_prior_lamps,
    prior_class_warning as prior_class_warning,
    prior_lamp_names,
    read_reflectance as read_reflectance,
)
from ._options import add_list_option


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
    add_estimator_options(p)
    p.add_argument(
        "--model",
        metavar="MODEL",
        help="a fitted estimator written by `bandopt fit`, used instead of "
        "fitting: refused unless it was fitted for these --bands, estimator "
        "options, --prior-lamps and --surface knowledge with this bandopt and "
        "its data. Without it the fit is cached ($BANDOPT_CACHE_DIR, "
        "$XDG_CACHE_HOME/bandopt or ~/.cache/bandopt; BANDOPT_NO_CACHE=1: off) "
        "and loaded by the next call with the same fingerprint",
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
        "--plot", metavar="PNG", help="figure: truth vs estimate with 90 %% intervals"
    )
    p.add_argument("--json", action="store_true", help="print JSON (input order)")
    p.set_defaults(func=run)


_config = config_of
"""The estimator configuration of the options (`config_of`)."""

_fit = fit_on
"""The estimator fitted on a context (`fit_on`), without model or cache."""


def run(args) -> int:
    import math

    import numpy as np

    from ..estimate import METRICS, truth_with_reasons
    from ..estimators import Surface
    from ..forward import band_radiance
    from ..photometry import ler as ler_fn
    from ..scene import class_illuminance_lx
    from ..spectra import GRID_1NM

    bands, name, config, warnings = prepare(args)
    lamps = [load_user_lamp(p, args.nir) for p in args.lamps]  # before training
    prior_files, prior_loaded = read_prior_lamps(args, warnings)
    grid = np.asarray(GRID_1NM, float)
    refl, surface_label, mode, knowledge = surface_of(args, grid)
    fitted, _ = obtain_fitted(
        args, bands, config, mode, lambda ctx: _fit(args, ctx, bands, mode)
    )
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
