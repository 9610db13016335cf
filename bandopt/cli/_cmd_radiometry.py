"""`bandopt radiometry`: detection limit, saturation, SNR/NER and bit depth of a
band set (thesis section 4.2)."""

from pathlib import Path

from ._options import add_list_option, bounded, gsd_type, seed_type
from ._output import OutputLock, add_locked_out


FIELD_OPTIONS = {
    "snr_target": "--snr",
    "dim_percentile": "--dim-percentile",
    "headroom": "--headroom",
    "gsd_m": "--gsd",
    "read_noise_e": "--read-noise",
    "dark_current_e_s": "--dark-current",
    "tdi_stages": "--tdi",
}
"""Library argument names in error messages and the options that set them."""


def register(subparsers):
    p = subparsers.add_parser(
        "radiometry",
        help="detection limit, saturation, SNR/NER and bit depth of a band set",
        description=(
            "Band radiance distributions (lamp scenes, moonlit surfaces, direct "
            "uplight, fires), recommended detection limit and saturation per band "
            "from a stated rule with a natural night-sky floor, SNR and "
            "noise-equivalent radiance with the photon model, and LER/G/CCT "
            "errors and classification F1 for 8-16 bit linear quantisation, "
            "two gain stages and square-root companding. Writes tables (CSV), "
            "summary.json, histograms and manifest.json into --out, and nothing "
            "else (`make radiometry` owns results/radiometry and the 'radiometry' "
            "key of results/recommendation.json)."
        ),
    )
    p.add_argument(
        "--bands",
        default="sdgsat-1",
        metavar="NAME|FILE",
        help="reference sensor name (`bandopt bands --list`), band-set JSON "
        "file, or a recommendation JSON file whose 'spectral' key holds the bands "
        "(e.g. results/recommendation.json) (default: sdgsat-1)",
    )
    add_locked_out(p)
    p.add_argument(
        "--quick",
        action="store_true",
        help="small scenario sets, no reference sensors (seconds); recorded as "
        "mode 'quick' in summary.json and in --recommend",
    )
    p.add_argument(
        "--no-references", action="store_true", help="skip the reference-sensor tables"
    )
    p.add_argument(
        "--no-bit-depth",
        action="store_true",
        help="skip the bit-depth error table (the slow part)",
    )
    p.add_argument(
        "--snr",
        type=bounded(lo=0.0, lo_open=True, why="(SNR)"),
        default=10.0,
        help="SNR target at the detection limit [1] (default 10)",
    )
    p.add_argument(
        "--dim-percentile",
        type=bounded(lo=0.0, hi=100.0, why="%"),
        default=5.0,
        help="percentile over lamps of the dim scenes [%%] (default 5)",
    )
    p.add_argument(
        "--headroom",
        type=bounded(lo=1.0, why="(saturation at or above the brightest scene)"),
        default=2.0,
        help="saturation margin above the brightest scene [1] (default 2)",
    )
    p.add_argument(
        "--sensor-limited",
        action="store_true",
        help="raise the detection limit to where the sensor reaches --snr",
    )
    p.add_argument(
        "--gsd",
        type=gsd_type(),
        default=None,
        metavar="M",
        help="integration time from this GSD at 600 km [m] (default: Table 2.3)",
    )
    p.add_argument(
        "--read-noise",
        type=bounded(lo=0.0, why="e-"),
        default=0.0,
        help="read noise [e-] (default 0)",
    )
    p.add_argument(
        "--dark-current",
        type=bounded(lo=0.0, why="e-/s"),
        default=0.0,
        help="dark current [e-/s] (default 0)",
    )
    p.add_argument(
        "--tdi",
        type=bounded(int, lo=1, why="(TDI stages)"),
        default=256,
        help="TDI stages (default 256)",
    )
    p.add_argument(
        "--recommend",
        default=None,
        metavar="FILE",
        help="also put the limits and bit depth, with the mode and settings that "
        "made them, under key 'radiometry' of this recommendation JSON file "
        "(default: none)",
    )
    add_list_option(
        p,
        "--lamps",
        metavar="ID",
        help="library lamp ids to use (see `bandopt library`)",
        default_help="all",
    )
    p.add_argument("--seed", type=seed_type(), default=0, help="noise seed")
    p.add_argument("--json", action="store_true", help="print summary.json on stdout")
    p.set_defaults(func=run, field_options=FIELD_OPTIONS)


def write_csv(rows: list[dict], path) -> None:
    """`rows` as CSV (floats to 6 significant digits), written atomically."""
    import csv

    from ._output import atomic_path

    keys: list[str] = []
    for r in rows:
        keys += [k for k in r if k not in keys]
    with atomic_path(path) as tmp, open(tmp, "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=keys)
        w.writeheader()
        for r in rows:
            w.writerow(
                {k: (f"{v:.6g}" if isinstance(v, float) else v) for k, v in r.items()}
            )


def write_results(result: dict, out) -> None:
    """Write a `bandopt.radiometry.compute` result into folder `out`: the
    tables, `histograms/<band set>.png`, `summary.json` and `manifest.json`
    (each file atomically)."""
    from ..radiometry import plot_histograms
    from ._output import atomic_path, atomic_write_json, prepare_dir, write_manifest

    out = Path(out)
    prepare_dir(out / "histograms")
    for name, rows in result["tables"].items():
        write_csv(rows, out / name)
    for slug, (groups, limits, key) in result["histograms"].items():
        with atomic_path(out / "histograms" / f"{slug}.png") as tmp:
            plot_histograms(
                groups,
                limits,
                Path(tmp),
                title=f"{key}: TOA band radiance by scene group",
            )
    atomic_write_json(out / "summary.json", result["summary"])
    write_manifest(out, seed=result["seed"], config=result["manifest_config"])


def run_radiometry(
    bands,
    label: str,
    out,
    *,
    config=None,
    params=None,
    rule=None,
    note: str = "",
    log=print,
    recommend=None,
) -> dict:
    """Lock folder `out`, compute (`bandopt.radiometry.compute`) and write the
    result into it (`write_results`); with `recommend` (a recommendation JSON
    file), put the limits and bit depth, with the mode and settings that made
    them, under its key "radiometry". Returns the `compute` result."""
    from ..radiometry import compute
    from ..results import update_recommendation

    with OutputLock(out) as lock:
        result = compute(
            bands, label, config=config, params=params, rule=rule, note=note, log=log
        )
        write_results(result, lock.directory)
    if recommend is not None:
        rec = {**result["recommendation"], "results": str(out)}
        update_recommendation("radiometry", rec, path=recommend)
    return result


def run(args) -> int:
    import sys

    from ..radiometry import LimitRule, RadiometryConfig, load_band_set
    from ._checks import coverage_check, sensor_for_gsd
    from ._output import prepare_file, print_json

    recommend = None
    if args.recommend:
        recommend = prepare_file(args.recommend, "--recommend")
        if recommend.suffix.lower() != ".json":
            raise ValueError(f"--recommend {recommend}: expected a .json file name.")
    bands, label, note = load_band_set(args.bands)
    coverage_check(bands, source=args.bands, log=sys.stderr)
    kw = dict(
        read_noise_e=args.read_noise,
        dark_current_e_s=args.dark_current,
        tdi_stages=args.tdi,
    )
    params = sensor_for_gsd(args.gsd, **kw)
    rule = LimitRule(
        snr_target=args.snr,
        dim_percentile=args.dim_percentile,
        headroom=args.headroom,
        sensor_limited=args.sensor_limited,
    )
    over = {"seed": args.seed}
    if args.lamps:
        over["lamps"] = tuple(args.lamps)
    if args.no_references:
        over["references"] = False
    if args.no_bit_depth:
        over["bit_depth_table"] = False
    config = RadiometryConfig.quick(**over) if args.quick else RadiometryConfig(**over)
    log = sys.stderr if args.json else sys.stdout
    out = Path(args.out)
    result = run_radiometry(
        bands,
        label,
        out,
        config=config,
        params=params,
        rule=rule,
        note=note,
        log=lambda *a: print(*a, file=log, flush=True),
        recommend=recommend,
    )
    summary = result["summary"]
    if args.json:
        print_json(summary)
        return 0
    print(f"{'band':<12}{'L_min':>11}{'L_max':>11}{'limited by':>12}{'SNR@L_min':>11}")
    for b in summary["bands"]:
        print(
            f"{b['band']:<12}{b['detection_limit_w_m2_sr_nm']:>11.3g}"
            f"{b['saturation_w_m2_sr_nm']:>11.3g}{b['limited_by']:>12}"
            f"{b['snr_at_limit']:>11.3g}"
        )
    bd = summary.get("bit_depth")
    if bd:
        print(f"bit depth (linear): {bd['recommended_linear_bits']}  ({bd['rule']})")
    print(f"(radiance in W m-2 sr-1 nm-1; mode {config.mode}; tables in {out})")
    if recommend is not None:
        print(f"updated key 'radiometry' of {recommend}")
    return 0
