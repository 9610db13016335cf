"""Spatial sampling: the GSD needed to detect single street lamps (thesis 4.3).

Run:   python -m experiments.spatial [--quick] [--out results/spatial]
           [--moon PHASE]
       python -m experiments.spatial --recommend-only

The study, its scenes and outputs are `bandopt.spatial.run_gsd_study`; it
also writes key "spatial" of results/recommendation.json.
"""

import argparse
from pathlib import Path

from bandopt.provenance import add_allow_dirty, refuse_dirty_at_start


def cli(argv=None) -> int:
    import bandopt
    from bandopt.spatial import GsdStudy, recommend_from_summary, run_gsd_study

    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--quick", action="store_true", help="coarser grid, fewer scenes")
    p.add_argument("--out", default="results/spatial")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument(
        "--moon", default=None, metavar="PHASE",
        help="moonlit ground under every scene (a named phase, e.g. full); "
        "default: no Moon",
    )  # fmt: skip
    p.add_argument(
        "--recommend-only",
        action="store_true",
        help="only (re)write key 'spatial' of results/recommendation.json from "
        "the existing OUT/summary.json (no rendering)",
    )
    add_allow_dirty(p)
    args = p.parse_args(argv)
    if not args.recommend_only:
        refuse_dirty_at_start(p, args, args.out)
    if args.recommend_only:
        return recommend_from_summary(Path(args.out))
    bandopt.configure()
    kw = {"seed": args.seed, "moon": args.moon}
    study = GsdStudy.quick(**kw) if args.quick else GsdStudy(**kw)
    s = run_gsd_study(study, Path(args.out))
    for name, v in s["gsd_needed_m"].items():
        print(f"{name:28s} needed GSD: {v['coarsest_gsd_m']}  F1 {v['f1_by_gsd']}")
    print(f"done in {s['seconds']} s -> {args.out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(cli())
