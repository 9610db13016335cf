"""Lamp-type identification where two lamp types share pixels, per GSD.

Run:   python -m experiments.spatial_overlap [--quick]
Writes results/spatial/overlap.{json,csv,png} and overlap_manifest/manifest.json
(`bandopt.spatial.run_overlap_study`).
"""

import argparse
from pathlib import Path

from bandopt.provenance import add_allow_dirty, refuse_dirty_at_start


def main(argv=None) -> Path:
    import bandopt
    from bandopt.spatial import run_overlap_study

    bandopt.configure()
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--quick", action="store_true", help="coarser grid, fewer GSDs")
    p.add_argument("--out", default="results/spatial")
    p.add_argument("--seed", type=int, default=0)
    add_allow_dirty(p)
    args = p.parse_args(argv)
    refuse_dirty_at_start(p, args, args.out)
    out = Path(args.out)
    rows = run_overlap_study(out, quick=args.quick, seed=args.seed, config=vars(args))
    for r in rows:
        print(
            f"GSD {r['gsd_m']:>5g} m  lit {r['n_lit']:>6d}  mixed "
            f"{r['mixed_fraction']:.2f}  F1 {r['macro_f1']:.2f} (pure "
            f"{r['f1_pure']:.2f}, mixed {r['f1_mixed']:.2f})"
        )
    return out / "overlap.json"


if __name__ == "__main__":
    main()
