"""Paired comparison of the stability search's solvers (nlopt + optimistix
BFGS against a plain Adam loop) on the same resamples: `bandopt.search.
compare_solvers` on the command line.

Run:  python -m experiments.search_solvers [--bands 3,5] [--out results/search_solvers]
"""

import argparse
import sys

from bandopt.provenance import add_allow_dirty, refuse_dirty_at_start


def main(argv=None) -> int:
    from bandopt import configure

    configure()  # XLA threads and the compilation cache, before JAX loads
    from bandopt.search import compare_solvers

    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--bands", default="5", help="band counts (the recommended: 5)")
    p.add_argument("--alpha", type=float, default=0.0)
    p.add_argument("--partitions", type=int, default=4)
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--out", default="results/search_solvers")
    add_allow_dirty(p)
    args = p.parse_args(argv)
    refuse_dirty_at_start(p, args, args.out)
    compare_solvers(
        args.out,
        bands=[int(v) for v in args.bands.split(",")],
        alpha=args.alpha,
        partitions=args.partitions,
        seed=args.seed,
        config=vars(args),
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
