"""Noise-aware band design: how the optimum bands move with signal level
(`bandopt.search.run_noise_aware`).

Run:  python -m experiments.noise_aware [--levels none,C0,P4,P6] [--bands 3]
Writes results/noise_aware/: noise_aware.json, bands_vs_signal.png,
manifest.json, tasks/.
"""

import argparse
import sys
from pathlib import Path

from bandopt.provenance import add_allow_dirty, refuse_dirty_at_start


def main(argv=None) -> int:
    from bandopt import configure

    configure()
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--levels", default="none,C0,P4,P6")
    p.add_argument("--bands", type=int, default=3)
    p.add_argument("--max-evals", type=int, default=300)
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--workers", type=int, default=1)
    p.add_argument("--out", default="results/noise_aware")
    add_allow_dirty(p)
    args = p.parse_args(argv)
    refuse_dirty_at_start(p, args, args.out)

    from bandopt.search import run_noise_aware

    levels = [None if v.lower() == "none" else v for v in args.levels.split(",")]
    rows = run_noise_aware(
        levels,
        args.out,
        n_bands=args.bands,
        max_evals=args.max_evals,
        seed=args.seed,
        workers=args.workers,
    )
    if Path(args.out) == Path("results/noise_aware"):
        # the README section quotes the committed results only
        from bandopt.report import write_readme_section

        write_readme_section("noise-aware")
    for r in rows:
        print(
            f"{r['level']:>10s}: loss {r['cv_loss']:.4f}  "
            + "  ".join(f"{c:.0f}/{f:.0f}" for c, f in r["bands"])
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
