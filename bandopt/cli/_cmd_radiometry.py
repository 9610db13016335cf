"""`bandopt radiometry`: detection limit, saturation, SNR/NER and bit depth of a
band set (thesis section 4.2)."""


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
            "two gain stages and square-root companding. NAME|FILE: 'ours' (the "
            "'spectral' bands of results/recommendation.json, else SDGSAT-1), a "
            "reference sensor name (see `bandopt bands`) or a band-set JSON file. "
            "Writes tables (CSV/JSON), histograms and a manifest to --out."
        ),
    )
    p.add_argument(
        "--bands", default="ours", metavar="NAME|FILE", help="band set (default: ours)"
    )
    p.add_argument(
        "--out",
        default=None,
        metavar="DIR",
        help="output folder (default results/radiometry, or "
        "results/radiometry/<name> for a band set other than ours)",
    )
    p.add_argument(
        "--quick",
        action="store_true",
        help="small scenario sets, no reference sensors (seconds)",
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
        "--snr", type=float, default=10.0, help="SNR target at the detection limit"
    )
    p.add_argument(
        "--dim-percentile",
        type=float,
        default=5.0,
        help="percentile over lamps of the dim scenes [%%]",
    )
    p.add_argument(
        "--headroom",
        type=float,
        default=2.0,
        help="saturation margin above the brightest scene [1]",
    )
    p.add_argument(
        "--sensor-limited",
        action="store_true",
        help="raise the detection limit to where the sensor reaches --snr",
    )
    p.add_argument(
        "--gsd",
        type=float,
        default=None,
        metavar="M",
        help="integration time from this GSD at 600 km (default: Table 2.3)",
    )
    p.add_argument("--read-noise", type=float, default=0.0, help="read noise [e-]")
    p.add_argument(
        "--dark-current", type=float, default=0.0, help="dark current [e-/s]"
    )
    p.add_argument("--tdi", type=int, default=256, help="TDI stages")
    p.add_argument(
        "--recommend",
        action="store_true",
        help="write key 'radiometry' of results/recommendation.json "
        "(default only for --bands ours)",
    )
    p.add_argument("--seed", type=int, default=0)
    p.set_defaults(func=run)


def run(args) -> int:
    from pathlib import Path

    from ..radiometry import (
        LimitRule,
        RadiometryConfig,
        load_band_set,
        run as run_radiometry,
    )
    from ..sensor import SensorParams

    bands, label, note = load_band_set(args.bands)
    kw = dict(
        read_noise_e=args.read_noise,
        dark_current_e_s=args.dark_current,
        tdi_stages=args.tdi,
    )
    params = SensorParams.for_gsd(args.gsd, **kw) if args.gsd else SensorParams(**kw)
    rule = LimitRule(
        snr_target=args.snr,
        dim_percentile=args.dim_percentile,
        headroom=args.headroom,
        sensor_limited=args.sensor_limited,
    )
    over = {"seed": args.seed}
    if args.no_references:
        over["references"] = False
    if args.no_bit_depth:
        over["bit_depth_table"] = False
    config = RadiometryConfig.quick(**over) if args.quick else RadiometryConfig(**over)
    ours = label == "ours"
    out = (
        Path(args.out)
        if args.out
        else (
            Path("results/radiometry") if ours else Path("results/radiometry") / label
        )
    )
    summary = run_radiometry(
        bands,
        label,
        out,
        config=config,
        params=params,
        rule=rule,
        recommend=ours or args.recommend,
        note=note,
    )
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
    print(f"(radiance in W m-2 sr-1 nm-1; tables in {out})")
    return 0
