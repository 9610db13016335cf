"""Lamp-type classification of fixed designs over lamp partitions:
`bandopt.studies.classification_partitions` on the command line.

    python -m experiments.classify_partitions [--partitions 4] [--quick]
        [--surface-modes] [--one-band-inversion] [--moon-all-designs] [--fresh]
        [--out DIR]
"""

import argparse

from bandopt.provenance import add_allow_dirty, refuse_dirty_at_start
from bandopt.results import RESULTS_DIR


def main(argv=None) -> int:
    from bandopt import configure

    configure()  # XLA threads and the compilation cache, before JAX loads
    from bandopt.studies.classification_partitions import MOON_MIN_BANDS, run

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument(
        "--partitions",
        type=int,
        default=4,
        help="lamp partitions, fold and noise seeds 0..P-1 (default 4)",
    )
    ap.add_argument(
        "--quick",
        action="store_true",
        help="smoke test: 2 partitions, 2 designs, 27 lamps on one surface, "
        "surface modes on (default off)",
    )
    ap.add_argument(
        "--surface-modes",
        action="store_true",
        help="also the inversion with the surface class known / measured by "
        "Sentinel-2, for our two designs (default off: ~2-3x the inversion's "
        "cost each)",
    )
    ap.add_argument(
        "--one-band-inversion",
        action="store_true",
        help="also the inversion for one-band sensors (default off: its "
        "posterior is its prior)",
    )
    ap.add_argument(
        "--moon-all-designs",
        action="store_true",
        help="also the told-Moon inversion for reference sensors with fewer than "
        f"{MOON_MIN_BANDS} bands (default off: 3-5 min per unit)",
    )
    ap.add_argument(
        "--fresh",
        action="store_true",
        help="discard finished units in the output folder (default: resume)",
    )
    ap.add_argument(
        "--out",
        default=None,
        metavar="DIR",
        help="output folder (default results/classify_partitions; --quick: "
        "results/classify_partitions/_scratch/quick)",
    )
    add_allow_dirty(ap)
    args = ap.parse_args(argv)
    if args.partitions < 1:
        raise SystemExit(f"--partitions {args.partitions}: must be >= 1.")
    default = RESULTS_DIR / "classify_partitions"
    quick = default / "_scratch" / "quick"
    refuse_dirty_at_start(ap, args, args.out or (quick if args.quick else default))
    return run(
        args.out,
        partitions=args.partitions,
        quick=args.quick,
        surface_modes=args.surface_modes,
        one_band_inversion=args.one_band_inversion,
        moon_all_designs=args.moon_all_designs,
        fresh=args.fresh,
    )


if __name__ == "__main__":
    raise SystemExit(main())
