"""`bandopt simulate`: band radiances of a scenario set, with every label."""


def register(subparsers):
    p = subparsers.add_parser(
        "simulate",
        help="band radiances for lamps x surfaces x atmospheres x Moon x classes",
        description=(
            "Simulate top-of-atmosphere band radiances [W m-2 sr-1 nm-1] for every "
            "combination of the chosen lamps, surfaces, atmospheres, Moon states and "
            "EN 13201 lighting classes, optionally with photon noise and quantisation, "
            "and write them with all scenario labels to Parquet or CSV."
        ),
    )
    p.add_argument(
        "--bands",
        required=True,
        metavar="NAME|FILE",
        help="reference sensor name (e.g. viirs-dnb) or band-set JSON file",
    )
    p.add_argument(
        "--lamps",
        nargs="*",
        metavar="ID",
        help="library lamp ids (default: all measured lamps; 'scored' for "
        "the scored classes only)",
    )
    p.add_argument("--surfaces", nargs="*", metavar="TYPE", help="surface types")
    p.add_argument(
        "--atmospheres",
        nargs="*",
        metavar="ATM/AEROSOL/VISkm",
        help="e.g. midlatitude_summer/urban/23 or none",
    )
    p.add_argument(
        "--moon",
        nargs="*",
        metavar="PHASE",
        help="named phases (full, first_quarter, ...) or none",
    )
    p.add_argument("--moon-zenith", type=float, default=30.0, metavar="DEG")
    p.add_argument("--classes", nargs="*", metavar="CLASS", help="EN 13201 classes")
    p.add_argument(
        "--uplight",
        type=float,
        default=0.0,
        metavar="RATIO",
        help="upward light output ratio 0-0.5 (default 0)",
    )
    p.add_argument(
        "--uplight-model",
        default="profile",
        choices=("profile", "lambertian"),
        help="uplight towards the sensor from the measured luminaire profiles "
        "(default) or the old Lambertian u/(1-u) shortcut",
    )
    p.add_argument(
        "--neighbourhood",
        default=None,
        metavar="NAME",
        help="what the diffuse upward transmittance sees: uniform (coarse pixels, "
        "total transmittance), lit_street_dark_district (default) or isolated",
    )
    p.add_argument(
        "--noise", action="store_true", help="add photon noise (Table 2.3 sensor)"
    )
    p.add_argument(
        "--gsd",
        type=float,
        default=None,
        metavar="M",
        help="ground sample distance setting the integration time",
    )
    p.add_argument(
        "--bits", type=int, default=None, metavar="N", help="quantise to N bits"
    )
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--out", required=True, metavar="FILE.parquet|csv")
    p.set_defaults(func=run)


def _atm(text: str):
    if text.lower() == "none":
        return "none"
    parts = text.split("/")
    if len(parts) != 3:
        raise ValueError(
            f"--atmospheres {text!r}: expected ATMOSPHERE/AEROSOL/VISIBILITY_KM "
            "or none."
        )
    return (parts[0], parts[1], float(parts[2].lower().removesuffix("km")))


def run(args) -> int:
    from pathlib import Path

    from tqdm import tqdm

    from ..forward import simulate, to_frame
    from ..scene import (
        DEFAULT_ATMOSPHERES,
        DEFAULT_CLASSES,
        DEFAULT_NEIGHBOURHOOD,
        DEFAULT_SURFACES,
        build_scenarios,
    )
    from ..sensor import SensorParams
    from ._cmd_bands import _load

    out = Path(args.out)
    if out.suffix.lower() not in (".parquet", ".csv"):
        raise ValueError(f"--out {out}: expected a .parquet or .csv file name.")
    bands, _ = _load(args.bands)
    lamps = args.lamps
    scored_only = bool(lamps) and lamps == ["scored"]
    moons = (
        (None, "full")
        if args.moon is None
        else tuple(None if m.lower() == "none" else m for m in args.moon)
    )
    scen = build_scenarios(
        lamps=None if (not lamps or scored_only) else lamps,
        scored_only=scored_only,
        surfaces=args.surfaces or DEFAULT_SURFACES,
        atmospheres=[_atm(a) for a in args.atmospheres]
        if args.atmospheres
        else DEFAULT_ATMOSPHERES,
        moons=moons,
        moon_zenith_deg=args.moon_zenith,
        classes=args.classes or DEFAULT_CLASSES,
        uplight_ratio=args.uplight,
        uplight_model=args.uplight_model,
        neighbourhood=args.neighbourhood or DEFAULT_NEIGHBOURHOOD,
    )
    params = SensorParams.for_gsd(args.gsd) if args.gsd else SensorParams()
    limits = None
    if args.bits is not None:
        clean = simulate(scen, bands).radiance
        axes = tuple(range(clean.ndim - 1))
        limits = (clean.min(axis=axes), clean.max(axis=axes))
    frames = []
    # One lamp block at a time keeps memory flat and shows progress on large sets.
    block = max(1, 20000 // max(1, scen.n_lamp_scenes // len(scen.lamp_ids)))
    starts = range(0, len(scen.lamp_ids), block)
    for k, i0 in enumerate(
        tqdm(starts, desc="simulate", unit="lamp block", disable=len(starts) < 3)
    ):
        sub = scen.subset_lamps(slice(i0, i0 + block))
        sim = simulate(
            sub,
            bands,
            noise=args.noise,
            params=params,
            seed=args.seed + k,
            bits=args.bits,
            limits=limits,
        )
        frames.append(to_frame(sub, sim))
    import pandas as pd

    table = pd.concat(frames, ignore_index=True)
    out.parent.mkdir(parents=True, exist_ok=True)
    if out.suffix.lower() == ".parquet":
        table.to_parquet(out, index=False)
    else:
        table.to_csv(out, index=False)
    print(f"wrote {len(table)} scenarios x {len(sim.band_names)} bands to {out}")
    return 0
