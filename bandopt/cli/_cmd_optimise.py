"""`bandopt optimise`: search the bands that best estimate LER, G and/or CCT."""

from ._options import bounded, seed_type
from ._output import add_locked_out


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
            "on all lamps), metrics.json (outer-fold test MAE with 95 % "
            "lamp-bootstrap intervals), bands.png and manifest.json to --out. "
            "Finished searches are kept in --out/tasks and reused on a rerun."
        ),
    )
    p.add_argument(
        "--target",
        required=True,
        choices=["ler", "g", "cct", "all"],
        help="what the bands must estimate (all: LER, G and CCT jointly)",
    )
    p.add_argument(
        "--bands",
        type=bounded(int, lo=1, hi=12, why="(free bands)"),
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
    p.add_argument("--seed", type=seed_type(), default=0, help="search and fold seed")
    p.add_argument(
        "--max-evals",
        type=bounded(int, lo=1, why="(objective evaluations)"),
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
    add_locked_out(p)
    p.add_argument(
        "--force",
        action="store_true",
        help="recompute task files in DIR/tasks that are corrupt (else an error)",
    )
    p.add_argument("--json", action="store_true", help="print metrics.json on stdout")
    p.set_defaults(func=run)


def check_task_files(tasks, out, *, force: bool, log) -> None:
    """A task file that is not its task's result (a run killed while the disk
    was full, an edited file, one copied from another run: `read_task_file`)
    is named; with `force` it is removed and recomputed."""
    from ..search import read_task_file, task_path

    for t in tasks:
        p = task_path(out, t)
        if not p.is_file():
            continue
        try:
            read_task_file(p, t)
        except ValueError as err:
            if not force:
                raise ValueError(f"{err} Rerun with --force to recompute it.") from None
            p.unlink()
            why = str(err).rstrip(".")
            print(f"note: {why}; recomputing (--force)", file=log)


def run(args) -> int:
    import sys

    from ._output import OutputLock

    if not 1 <= args.bands <= 12:
        raise ValueError(f"--bands {args.bands}: expected 1-12 free bands.")
    if args.max_evals < 1:
        raise ValueError("--max-evals must be >= 1.")
    if args.bands == 1 and not args.pan:
        print(
            "warning: one band without --pan has no band ratio; the estimate is the "
            "training mean whatever the band.",
            file=sys.stderr,
        )
    with OutputLock(args.out) as lock:
        return _optimise(args, lock.directory)


TIMING_KEYS = ("wall_s", "trace_s")
"""Wall-clock fields of a search result, reported under `timing` only."""


def _optimise(args, out) -> int:
    import sys

    from ..search import (
        get_context,
        mae_ci,
        make_task,
        plot_bands_over_lamps,
        print_progress,
        run_sweep,
    )
    from ..sensor import BandSet
    from ._output import (
        atomic_path,
        atomic_write_json,
        atomic_write_text,
        print_json,
        write_manifest,
    )

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
    check_task_files(tasks, out, force=args.force, log=sys.stderr)
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
    search = {k: final[k] for k in ("loss", "spread", "global", "local")}
    glob = dict(search["global"])
    timing = {k: glob.pop(k) for k in TIMING_KEYS if k in glob}
    search["global"] = glob
    metrics = {
        "target": args.target,
        "bands": final["bands"],
        "final_search": search,
        "noise": args.noise,
        "context": ctx.config,
        # wall-clock times differ between identical runs: kept apart, so the
        # rest of metrics.json is the same for the same seed
        "timing": {
            "final_search_global": timing,
            "task_wall_s": [r.get("wall_s") for r in res],
        },
    }
    if not args.no_folds:
        idx = [i for r in res[:3] for i in r["lamp_index"]]
        err = [e for r in res[:3] for e in r["lamp_errors"]]
        metrics["test_mae"] = mae_ci(err, idx, ctx.table.classes)
        metrics["fold_bands"] = [r["bands"] for r in res[:3]]
    # every top-level file is written whole or not at all (temporary + rename)
    atomic_write_text(out / "bands.json", bands.to_json())
    atomic_write_json(out / "metrics.json", metrics)
    with atomic_path(out / "bands.png") as tmp:
        plot_bands_over_lamps(bands, tmp)
    write_manifest(out, seed=args.seed, config={"tasks": tasks})
    if args.json:
        print_json(metrics)
    else:
        for b in final["bands"]["bands"]:
            print(
                f"{b['name']:>4s}  centre {b['centre_nm']:7.1f} nm  "
                f"FWHM {b['fwhm_nm']:6.1f} nm"
            )
        for m, v in metrics.get("test_mae", {}).items():
            print(
                f"test MAE {m}: {v['mae']:.4g} {v['unit']} "
                f"(95 % CI {v['ci95'][0]:.4g}-{v['ci95'][1]:.4g})"
            )
    print(
        f"wrote {out}/bands.json, metrics.json, bands.png, manifest.json",
        file=sys.stderr,
    )
    return 0
