"""`bandopt classify`: score band sets for lamp-type classification."""

from ._options import add_list_option, bounded, seed_type


def register(subparsers):
    p = subparsers.add_parser(
        "classify",
        help="score band sets for lamp-type classification (KNN or inversion, "
        "macro F1)",
        description=(
            "Lamp-type classification with each band set, nested lamp-grouped "
            "3x2 cross-validation (seed 0, the band search's folds), scored "
            "classes only. Estimators: 'knn' (default) -- scale-free log band "
            "ratios, one-vs-all KNN, k chosen by inner folds; 'inversion' -- the "
            "physics-based inversion of `bandopt evaluate` (lamp x surface x "
            "atmosphere, surface unknown unless --surface-knowledge, prior over "
            "the training lamps), type "
            "from its posterior: level 1 first, then the most probable level-2 "
            "class inside that family. Prints F1 per class, macro F1, accuracy, "
            "per-lamp accuracy and the reject option (confidence of the predicted "
            "class < 0.6 -> unknown; the inversion also rejects pixels it flags "
            "unexplained). --modelled-per-class N adds modelled training lamps "
            "of the rare classes (never scored)."
        ),
    )
    add_list_option(
        p,
        "--bands",
        required=True,
        metavar="NAME|FILE",
        help="reference sensor names (`bandopt bands --list`) or band-set JSON "
        "files; a value that exists as a file is not split at commas",
        keep_paths=True,
    )
    p.add_argument(
        "--estimator",
        default="knn",
        choices=("knn", "inversion"),
        help="knn: one-vs-all KNN on band features (default: it scored the "
        "higher macro F1 than the inversion on the quick and default scenario "
        "sets, see the user guide); inversion: the physics-based inversion of "
        "`bandopt evaluate`, lamp type read from its posterior (level 1, then "
        "level 2 inside that family), pixels it flags unexplained rejected",
    )
    p.add_argument(
        "--modelled-per-class",
        type=bounded(int, lo=0, why="(a count)"),
        default=0,
        metavar="N",
        help="also train on N modelled lamps per rare class (mercury, "
        "led_amber, metal_halide, hps; lps too for the inversion's prior; "
        "physical lamp models of bandopt.lampmodels calibrated on the "
        "measured training lamps of each fold only), lighting the same "
        "scenes; they train, never score (test lamps are measured ones). "
        "knn: extra training rows (inner folds too); inversion: in its "
        "prior. Default 0: measured lamps only. The first use fits the "
        "models (several minutes); the JSON's config says modelled_per_class",
    )
    p.add_argument(
        "--surface-knowledge",
        default="unknown",
        choices=("unknown", "class", "measured"),
        help="inversion only: what it knows of the surface under each pixel: "
        "unknown (default, as the KNN), class (the surface type), measured "
        "(a simulated daytime Sentinel-2 measurement of it, noise seed --seed)",
    )
    p.add_argument(
        "--moon",
        default="fitted",
        choices=("fitted", "known"),
        help="inversion only: fitted (default: the Moon's brightness in each "
        "pixel is a free non-negative parameter) or known (told each scene's "
        "Moon brightness, as it is known from the acquisition's time and place; "
        "the estimate's largest confounder, see results/estimate_moon)",
    )
    p.add_argument(
        "--mixtures",
        type=bounded(int, lo=0, why="(a count)"),
        default=0,
        metavar="N",
        help="inversion only: also put pairwise blends of two measured lamps of "
        "one class into its prior, up to N pairs per class (default 0: measured "
        "lamps only, as make classify-partitions scored it; bandopt evaluate "
        "uses 50: see results/estimate_mix)",
    )
    p.add_argument(
        "--planck",
        choices=("on", "off"),
        default="off",
        help="inversion only: also put the library's modelled incandescent "
        "spectra (Planck's law, 2400-3200 K) into its prior, as bandopt evaluate "
        "does by default (default off: measured lamps only, as make "
        "classify-partitions scored it; modelled spectra train, never score; "
        "results/estimate_planck)",
    )
    p.add_argument(
        "--peak-shifts",
        choices=("on", "off"),
        default="off",
        help="inversion only: also put copies of each prior's direct-emission "
        "LEDs shifted by +-2.5 to +-10 nm into it, as bandopt evaluate does by "
        "default (default off, as make classify-partitions scored it; "
        "results/estimate_shift)",
    )
    p.add_argument(
        "--no-noise",
        action="store_true",
        help="noise-free radiance (scenes deduplicated) instead of photon noise",
    )
    p.add_argument(
        "--features",
        default="log_ratio",
        choices=("log_ratio", "sum_normalised"),
        help="KNN features: log band ratios or band radiances divided by "
        "their sum (default log_ratio; the inversion uses the radiances)",
    )
    p.add_argument(
        "--scenarios",
        default="default",
        choices=("default", "quick"),
        help="default: 7 surfaces x atmospheres x 3 Moon states x 4 classes; "
        "quick: asphalt and grass, no Moon, class P4 (seconds)",
    )
    p.add_argument(
        "--atmospheres",
        default="auto",
        choices=("auto", "none"),
        help="auto: the 6S atmospheres when their tables are installed",
    )
    p.add_argument(
        "--seed", type=seed_type(), default=0, help="noise seed (folds: seed 0)"
    )
    p.add_argument("--json", action="store_true", help="print JSON instead of a table")
    p.add_argument(
        "--plot",
        metavar="FILE",
        help="draw the confusion matrices (level 1 and 2, pooled outer-fold test "
        "scenes) of every band set (png, pdf)",
    )
    p.set_defaults(func=run)


QUICK = dict(surfaces=("asphalt", "grass"), moons=(None,), classes=("P4",))


def plot_confusion(results, path, *, noise: bool, estimator: str = "knn") -> None:
    """One row per band set, one column per level: the confusion matrix of the
    pooled outer-fold test scenes, as the fraction of each true class (rows)
    given each predicted class (columns: the scored classes, then classes the
    estimator may predict but that are not scored, then "unknown" = rejected,
    which stays empty without the reject option); counts in the cells."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np

    levels = list(results[0][1].levels)
    sizes = [len(results[0][1].level(lv).confusion) for lv in levels]
    fig, axes = plt.subplots(
        len(results),
        len(levels),
        figsize=(
            sum(0.55 * n + 2.5 for n in sizes),
            0.55 * max(sizes) * len(results) + 2,
        ),
        squeeze=False,
        constrained_layout=True,
    )
    im = None
    for i, (src, res) in enumerate(results):
        for j, lv in enumerate(levels):
            ax = axes[i, j]
            cm = np.asarray(res.level(lv).confusion, float)
            cols = list(res.level(lv).confusion_columns)
            rows = cols[: cm.shape[0]]
            frac = cm / np.maximum(cm.sum(axis=1, keepdims=True), 1.0)
            im = ax.imshow(frac, cmap="Blues", vmin=0.0, vmax=1.0, aspect="auto")
            for (r, c), n in np.ndenumerate(cm):
                if n:
                    ax.text(
                        c,
                        r,
                        f"{int(n)}",
                        ha="center",
                        va="center",
                        fontsize=6,
                        color="white" if frac[r, c] > 0.6 else "black",
                    )
            ax.set_xticks(range(len(cols)), cols, rotation=60, ha="right", fontsize=7)
            ax.set_yticks(range(len(rows)), rows, fontsize=7)
            ax.set_xlabel("predicted class")
            ax.set_ylabel("true class")
            ax.set_title(
                f"{src}, {lv}: macro F1 {res.level(lv).macro_f1:.2f}", fontsize=9
            )
    fig.colorbar(
        im, ax=axes, shrink=0.8, label="fraction of the true class's test scenes [1]"
    )
    fig.suptitle(
        f"lamp-type confusion, {estimator} (outer-fold test scenes, "
        f"noise={'on' if noise else 'off'})"
    )
    fig.savefig(path, dpi=120)
    plt.close(fig)


def run(args) -> int:
    import sys

    from .. import inversion as inv_mod
    from ..classify import (
        TRAINING_SCENARIOS,
        available_atmospheres,
        evaluate_band_set,
        summary,
    )
    from ..forward import scenario_table
    from ..scene import build_scenarios
    from ..sensor import load_band_set
    from ._checks import band_set_warnings
    from ._output import atomic_path, prepare_file, print_json

    if args.modelled_per_class < 0:
        raise ValueError(
            f"--modelled-per-class {args.modelled_per_class}: must be >= 0."
        )
    if args.surface_knowledge != "unknown" and args.estimator != "inversion":
        raise ValueError(
            f"--surface-knowledge {args.surface_knowledge}: only --estimator "
            f"inversion uses surface knowledge (got --estimator {args.estimator})."
        )
    if args.mixtures < 0:
        raise ValueError(f"--mixtures {args.mixtures}: must be >= 0.")
    if args.mixtures and args.estimator != "inversion":
        raise ValueError(
            f"--mixtures {args.mixtures}: blends go into the prior of --estimator "
            f"inversion only (got --estimator {args.estimator})."
        )
    for opt in ("planck", "peak_shifts"):
        if getattr(args, opt) == "on" and args.estimator != "inversion":
            flag = "--" + opt.replace("_", "-")
            raise ValueError(
                f"{flag} on: only the prior of --estimator inversion holds "
                f"modelled or shifted spectra (got --estimator {args.estimator})."
            )
    if args.moon != "fitted" and args.estimator != "inversion":
        raise ValueError(
            f"--moon {args.moon}: only --estimator inversion is told the Moon "
            f"(got --estimator {args.estimator})."
        )
    if args.plot:
        prepare_file(args.plot, "--plot")

    band_sets = [(src, load_band_set(src)) for src in args.bands]
    warnings = {
        src: band_set_warnings(bands, src, log=sys.stderr) for src, bands in band_sets
    }
    atms = available_atmospheres(args.atmospheres)
    kw = QUICK if args.scenarios == "quick" else TRAINING_SCENARIOS
    table = scenario_table(build_scenarios(scored_only=True, atmospheres=atms, **kw))
    noise = not args.no_noise
    knn = args.estimator == "knn"
    out = {
        "band_sets": [],
        "config": {
            "estimator": args.estimator,
            "scenarios": args.scenarios,
            "atmospheres": [a if isinstance(a, str) else list(a) for a in atms],
            "noise": noise,
            "features": args.features if knn else None,
            "modelled_per_class": args.modelled_per_class,
            "surface_knowledge": args.surface_knowledge,
            "moon": None if knn else args.moon,
            "mixtures": None if knn else args.mixtures,
            "planck": None if knn else args.planck,
            "peak_shifts": None if knn else args.peak_shifts,
            "seed": args.seed,
            "n_scenes": table.n_rows,
            "n_lamps": len(table.lamp_ids),
        },
    }
    results = []
    for src, bands in band_sets:
        kw = dict(
            noise=noise, seed=args.seed, modelled_per_class=args.modelled_per_class
        )
        if knn:
            res = evaluate_band_set(table, bands, kind=args.features, **kw)
        else:
            res = evaluate_band_set(
                table,
                bands,
                estimator="inversion",
                surface_mode=args.surface_knowledge,
                moon_known=args.moon == "known",
                mixtures=args.mixtures,
                planck=args.planck == "on",
                peak_shifts=inv_mod.PEAK_SHIFTS_NM if args.peak_shifts == "on" else (),
                **kw,
            )
        results.append((src, res))
        centre = getattr(bands, "centre_nm", None)
        fwhm = getattr(bands, "fwhm_nm", None)
        out["band_sets"].append(
            {
                "source": src,
                "n_bands": len(bands),
                "centre_nm": None if centre is None else [float(c) for c in centre],
                "fwhm_nm": None if fwhm is None else [float(f) for f in fwhm],
                **summary(res),
                **(
                    {"modelled_lamps": res.config["modelled_lamps"]}
                    if args.modelled_per_class
                    else {}
                ),
                "warnings": warnings[src],
            }
        )
    if args.plot:
        with atomic_path(args.plot) as tmp:
            plot_confusion(results, tmp, noise=noise, estimator=args.estimator)
    if args.json:
        print_json(out)
        return 0
    for b in out["band_sets"]:
        head = f"{b['source']} ({b['n_bands']} bands, noise={noise}"
        extra = (
            ""
            if knn
            else f", estimator inversion, surface {args.surface_knowledge}, "
            f"Moon {args.moon}"
        )
        if not knn and args.mixtures:
            extra += f", {args.mixtures} blend pairs per class in the prior"
        if not knn and args.planck == "on":
            extra += ", modelled incandescent (Planck) spectra in the prior"
        if not knn and args.peak_shifts == "on":
            extra += ", shifted direct-emission LEDs in the prior"
        if args.modelled_per_class:
            extra += f", {args.modelled_per_class} modelled lamps per rare class"
        print(head + extra + ")")
        for level in ("level1", "level2"):
            s = b[level]
            rej = s["reject"]
            print(
                f"  {level}: macro F1 {s['macro_f1']:.3f} "
                f"(folds {s['macro_f1_fold_mean']:.3f} ± {s['macro_f1_fold_sd']:.3f}), "
                f"accuracy {s['accuracy']:.3f}, "
                f"per-lamp {s['mean_lamp_accuracy']:.3f}, "
                f"reject@{rej['threshold']}: coverage {rej['coverage']:.2f}"
                + ("" if knn else f" (unexplained {rej['unexplained']:.2f})")
            )
            print("    " + ", ".join(f"{c} {v:.2f}" for c, v in s["f1"].items()))
    return 0
