"""`bandopt simulate`: band radiances of a scenario set, with every label."""

from ._options import add_list_option, bounded, gsd_type, seed_type


FIELD_OPTIONS = {
    "moon_zenith_deg": "--moon-zenith",
    "zenith_deg": "--moon-zenith",  # the 6S tables name the Moon zenith so
    "uplight_ratio": "--uplight",
    "gsd_m": "--gsd",
    "bit_depth": "--bits",
    "visibility_km": "--atmospheres VIS_KM",
}
"""Library argument names in error messages and the options that set them."""


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
    add_list_option(
        p,
        "--lamps",
        metavar="ID",
        help="library lamp ids (see bandopt library), A+B@F for a pixel lit by "
        "lamp A for a fraction F of its light and by B for the rest, or 'scored' "
        "for the scored classes only",
        default_help="all measured lamps",
    )
    add_list_option(
        p,
        "--surfaces",
        metavar="TYPE",
        help="surface types (see bandopt surfaces), or A+B@F for a pixel covered "
        "by A over a fraction F of its area and by B over the rest",
        default_help="the seven default surfaces, bandopt.scene.DEFAULT_SURFACES",
    )
    add_list_option(
        p,
        "--atmospheres",
        metavar="ATMOSPHERE/AEROSOL/VIS_KM",
        help="6S atmospheres, e.g. midlatitude_summer/urban/23, or none",
        default_help="the four default atmospheres, bandopt.scene.DEFAULT_ATMOSPHERES",
    )
    add_list_option(
        p,
        "--moon",
        metavar="PHASE",
        help="named Moon phases (full, first_quarter, ...) or none",
        default=["none", "full"],
    )
    p.add_argument(
        "--moon-zenith",
        type=bounded(
            lo=0.0, hi=90.0, hi_open=True, why="deg (90 puts the Moon on the horizon)"
        ),
        default=30.0,
        metavar="DEG",
        help="Moon zenith angle, 0 to below 90 (the Moon above the horizon; "
        "with a 6S atmosphere at most its table's 75) [deg] (default 30)",
    )
    add_list_option(
        p,
        "--classes",
        metavar="CLASS",
        help="EN 13201 lighting classes",
        default_help="the eight default classes, bandopt.scene.DEFAULT_CLASSES",
    )
    p.add_argument(
        "--uplight",
        type=bounded(lo=0.0, hi=0.5, why="(upward light output ratio)"),
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
        "--noise",
        action="store_true",
        help="add photon noise (thesis Table 2.3 sensor): Gaussian shot, dark and "
        "read noise, e + sigma(e) z with z standard normal, so a noisy radiance "
        "CAN BE NEGATIVE for a dim scene (as an offset-subtracted signal can); "
        "--bits clips to the quantiser's range",
    )
    p.add_argument(
        "--gsd",
        type=gsd_type(),
        default=None,
        metavar="M",
        help="ground sample distance setting the integration time, > 0 [m] "
        "(default: none, the Table 2.3 integration time)",
    )
    p.add_argument(
        "--bits",
        type=bounded(int, lo=1, hi=53, why="(float64 holds integers exactly to 2^53)"),
        default=None,
        metavar="N",
        help="quantise to N bits (1-53) between the noise-free minimum and maximum "
        "radiance of each band, which must differ (default: none)",
    )
    p.add_argument("--seed", type=seed_type(), default=0, help="noise seed")
    p.add_argument(
        "--out",
        required=True,
        metavar="DIR|FILE",
        help="output folder (gets radiances.parquet and manifest.json) or a "
        ".parquet/.csv file name",
    )
    p.add_argument(
        "--force",
        action="store_true",
        help="replace an existing --out .parquet/.csv file (else an error)",
    )
    p.add_argument(
        "--json",
        action="store_true",
        help="print a JSON summary (file, shape, radiance range per band) on stdout",
    )
    p.set_defaults(func=run, field_options=FIELD_OPTIONS)


def _atm(text: str):
    if text.lower() == "none":
        return "none"
    parts = text.split("/")
    if len(parts) != 3:
        raise ValueError(
            f"--atmospheres {text!r}: expected ATMOSPHERE/AEROSOL/VIS_KM or none."
        )
    return (parts[0], parts[1], float(parts[2].lower().removesuffix("km")))


def _entry(text: str, what: str):
    """A list value of --lamps or --surfaces: a name, or a mixed pixel
    ``A+B@F`` (F the fraction of A, as `scene.mix_label` writes it) as the
    tuple `build_scenarios` takes."""
    if "+" not in text and "@" not in text:
        return text
    head, sep, frac = text.rpartition("@")
    a, plus, b = head.partition("+")
    if not (sep and plus and a and b and "+" not in b):
        raise ValueError(
            f"--{what} {text!r}: a mixed pixel is written A+B@F (F the fraction "
            "of A, 0-1)."
        )
    try:
        fraction = float(frac)
    except ValueError:
        raise ValueError(
            f"--{what} {text!r}: the fraction {frac!r} of a mixed pixel A+B@F is "
            "not a number."
        ) from None
    if not 0.0 <= fraction <= 1.0:
        raise ValueError(
            f"--{what} {text!r}: the fraction of a mixed pixel must lie in [0, 1]."
        )
    return (a, b, fraction)


def run(args) -> int:
    from pathlib import Path

    from ._output import made_dir, prepare_file, refuse_existing

    out = Path(args.out)
    if out.suffix.lower() not in (".parquet", ".csv"):
        # any other name is a folder, dots included (run_v1.2); a failed run
        # removes the folder it created
        with made_dir(out):
            return _simulate(args, out / "radiances.parquet", folder=True)
    refuse_existing(out, "--out", args.force)
    prepare_file(out, "--out")
    return _simulate(args, out, folder=False)


def _simulate(args, out, *, folder: bool) -> int:
    import sys

    import numpy as np
    from tqdm import tqdm

    from ..forward import simulate, to_frame
    from ..scene import (
        DEFAULT_ATMOSPHERES,
        DEFAULT_CLASSES,
        DEFAULT_NEIGHBOURHOOD,
        DEFAULT_SURFACES,
        build_scenarios,
    )
    from ._checks import coverage_check, sensor_for_gsd
    from ._cmd_bands import _load
    from ._output import atomic_path, print_json

    bands, _ = _load(args.bands)
    warnings = coverage_check(bands, source=args.bands, log=sys.stderr)
    lamps = args.lamps
    scored_only = bool(lamps) and lamps == ["scored"]
    moons = tuple(None if m.lower() == "none" else m for m in args.moon)
    scen = build_scenarios(
        lamps=None
        if (not lamps or scored_only)
        else [_entry(x, "lamps") for x in lamps],
        scored_only=scored_only,
        surfaces=[_entry(x, "surfaces") for x in args.surfaces]
        if args.surfaces
        else DEFAULT_SURFACES,
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
    params = sensor_for_gsd(args.gsd)
    limits = None
    if args.bits is not None:
        clean = simulate(scen, bands).radiance
        axes = tuple(range(clean.ndim - 1))
        limits = (clean.min(axis=axes), clean.max(axis=axes))
        flat = [n for n, a, b in zip(bands.names, *limits, strict=True) if not b > a]
        if flat:
            raise ValueError(
                f"--bits {args.bits}: the quantiser spans each band's noise-free "
                f"minimum to maximum radiance over the scenarios, and band "
                f"{', '.join(flat)} has one value (min = max) in this set of "
                f"{scen.n_lamp_scenes} scenario(s); give more scenarios or leave "
                "out --bits."
            )
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
        if not np.all(np.isfinite(sim.radiance)):
            raise ValueError(
                f"--gsd {args.gsd:g}: the photon counts overflow float64 (an "
                f"integration time of {float(params.integration_time_s):.3g} s); "
                "give a GSD of a real sensor."
            )
        frames.append(to_frame(sub, sim))
    import pandas as pd

    table = pd.concat(frames, ignore_index=True)
    with atomic_path(out) as tmp:
        if out.suffix.lower() == ".parquet":
            table.to_parquet(tmp, index=False)
        else:
            table.to_csv(tmp, index=False)
    config = {k: v for k, v in vars(args).items() if k != "func"}
    if folder:
        from ._output import write_manifest

        write_manifest(out.parent, seed=args.seed, config=config)
    names = list(sim.band_names)
    summary = {
        "out": str(out),
        "n_scenarios": len(table),
        "bands": names,
        "noise": bool(args.noise),
        "radiance_unit": "W m-2 sr-1 nm-1",
        "negative_note": "with --noise a dim scene's radiance can be negative "
        "(Gaussian photon noise)",
        "warnings": warnings,
        "per_band": {},
    }
    for n in names:
        col = next((c for c in table.columns if str(c).endswith(n)), None)
        if col is None:
            continue
        v = table[col].to_numpy(float)
        summary["per_band"][n] = {
            "column": str(col),
            "min": float(v.min()),
            "median": float(np.median(v)),
            "max": float(v.max()),
            "negative_fraction": float(np.mean(v < 0)),
        }
    if args.json:
        print_json(summary)
    log = sys.stderr if args.json else sys.stdout
    print(f"wrote {len(table)} scenarios x {len(names)} bands to {out}", file=log)
    return 0
