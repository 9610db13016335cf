"""The band search's candidates judged by the shipped estimator on clean and
perturbed held-out lamps (the study is `bandopt.studies.judge`).

    python -m experiments.judge [--partitions 4] [--out DIR] [--resume]
        [--only-partitions P ...]

Reads `results/search/` (`compare.json`, `recommended_bands.json`) and
writes to `results/judge/`: `candidates/` (the band-set files judged),
`records.jsonl.gz` (resumable per (partition, band set)), `summary.json`,
`judge.json`, `judge.png`, `README.md` and `manifest.json`.
"""

import argparse
from pathlib import Path

from bandopt.provenance import add_allow_dirty, refuse_dirty_at_start


OUT = Path("results/judge")
"""Where the study writes."""


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--partitions", type=int, default=4, help="lamp partitions")
    ap.add_argument("--out", default=str(OUT), help=f"output (default {OUT})")
    ap.add_argument("--search", default="results/search", help="the search judged")
    ap.add_argument("--resume", action="store_true", help="keep finished units")
    ap.add_argument(
        "--only-partitions", type=int, nargs="+", default=None, metavar="P",
        help="compute only these partitions (no summary; join with --resume)",
    )  # fmt: skip
    add_allow_dirty(ap)
    args = ap.parse_args(argv)
    refuse_dirty_at_start(ap, args, Path(args.out))

    from bandopt import configure

    configure()
    from bandopt.studies import judge, log

    result = judge.run(
        Path(args.out),
        search=Path(args.search),
        partitions=args.partitions,
        only_partitions=args.only_partitions,
        resume=args.resume,
        log=lambda m: log(m, "judge"),
    )
    if result is not None:
        ch = result["choice"]
        log(f"chosen {ch['chosen']} (search: {result['searched']})", "judge")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
