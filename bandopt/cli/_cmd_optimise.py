"""`bandopt optimise`: search the bands that best estimate LER, G and/or CCT."""


def register(subparsers):
    p = subparsers.add_parser(
        "optimise",
        help="search band centres and widths for LER, G, CCT (nlopt + optimistix)",
        description=(
            "Search the centres and FWHMs of N super-Gaussian bands (plus an optional "
            "fixed panchromatic band) that best estimate LER, the G index and/or CCT "
            "from brightness-free band ratios, by nested lamp-grouped cross-validation "
            "(3 outer x 2 inner folds). Global search: nlopt MLSL-LDS with L-BFGS on "
            "JAX gradients; local polish: optimistix BFGS. Writes bands.json (searched "
            "on all lamps), metrics.json (outer-fold test MAE with 95 %% "
            "lamp-bootstrap intervals), bands.png and manifest.json to --out. "
            "Finished searches are kept in --out/tasks and reused on a rerun."
        ),
    )
    p.add_argument("--target", required=True, choices=["ler", "g", "cct", "all"])
    p.add_argument(
        "--bands",
        type=int,
        required=True,
        metavar="N",
        help="number of free bands (1-12)",
    )
    p.add_argument(
        "--pan",
        action="store_true",
        help="add a fixed panchromatic band (50 %% points 400 and 880 nm)",
    )
    p.add_argument(
        "--noise",
        default=None,
        metavar="LEVEL",
        help="photon noise (thesis Table 2.3 sensor) at an EN 13201 class "
        "(e.g. P4) or a mean radiance [W m-2 sr-1 nm-1]",
    )
    p.add_argument("--seed", type=int, default=0)
    p.add_argument(
        "--max-evals",
        type=int,
        default=400,
        metavar="N",
        help="objective evaluations per global search (default 400)",
    )
    p.add_argument(
        "--preset",
        default="search",
        choices=["search", "quick", "tiny"],
        help="scenario preset (default: search)",
    )
    p.add_argument(
        "--no-folds",
        action="store_true",
        help="only the all-lamp search (no test errors; faster)",
    )
    p.add_argument("--out", required=True, metavar="DIR")
    p.set_defaults(func=run)


def run(args) -> int:
    import json
    import sys
    from pathlib import Path

    from ..provenance import write_manifest
    from ..search import (
        get_context,
        mae_ci,
        make_task,
        plot_bands_over_lamps,
        print_progress,
        run_sweep,
    )
    from ..sensor import BandSet

    if not 1 <= args.bands <= 12:
        raise ValueError(f"--bands {args.bands}: expected 1-12 free bands.")
    if args.max_evals < 1:
        raise ValueError("--max-evals must be >= 1.")
    if args.bands == 1 and not args.pan:
        print(
            "note: one band without --pan has no band ratio; the estimate is the "
            "training mean whatever the band.",
            file=sys.stderr,
        )
    out = Path(args.out)
    folds = ["final"] if args.no_folds else [0, 1, 2, "final"]
    tasks = [
        make_task(
            target=args.target,
            n_bands=args.bands,
            pan="fixed" if args.pan else "none",
            fold=f,
            seed=args.seed,
            max_evals=args.max_evals,
            preset=args.preset,
            noise=args.noise,
        )
        for f in folds
    ]
    ctx = get_context(args.preset, args.noise, 0, "auto")  # validates --noise early
    res = run_sweep(tasks, out, workers=1, progress=print_progress)
    if any(r is None for r in res):
        raise ValueError(f"{out}/tasks: some searches failed; see *.failed.json there.")
    final = res[-1]
    bands = BandSet.from_dict(
        final["bands"],
        lower_nm=final["bands"]["range_nm"][0],
        upper_nm=final["bands"]["range_nm"][1],
        min_fwhm_nm=1.0,
    )
    bands.to_json(out / "bands.json")
    metrics = {
        "target": args.target,
        "bands": final["bands"],
        "final_search": {k: final[k] for k in ("loss", "spread", "global", "local")},
        "noise": args.noise,
        "context": ctx.config,
    }
    if not args.no_folds:
        idx = [i for r in res[:3] for i in r["lamp_index"]]
        err = [e for r in res[:3] for e in r["lamp_errors"]]
        metrics["test_mae"] = mae_ci(err, idx, ctx.table.classes)
        metrics["fold_bands"] = [r["bands"] for r in res[:3]]
    (out / "metrics.json").write_text(
        json.dumps(metrics, indent=2, default=float) + "\n"
    )
    plot_bands_over_lamps(bands, out / "bands.png")
    write_manifest(out, seed=args.seed, config={"tasks": tasks})
    for b in final["bands"]["bands"]:
        print(
            f"{b['name']:>4s}  centre {b['centre_nm']:7.1f} nm  "
            f"FWHM {b['fwhm_nm']:6.1f} nm"
        )
    if "test_mae" in metrics:
        for m, v in metrics["test_mae"].items():
            print(
                f"test MAE {m}: {v['mae']:.4g} {v['unit']} "
                f"(95 % CI {v['ci95'][0]:.4g}-{v['ci95'][1]:.4g})"
            )
    print(
        f"wrote {out}/bands.json, metrics.json, bands.png, manifest.json",
        file=sys.stderr,
    )
    return 0
