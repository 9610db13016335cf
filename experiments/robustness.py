"""Robustness suite: the shipped estimate on held-out library lamps under what
real spectra hold (the study and its outputs are `bandopt.robustness`).

    python -m experiments.robustness [--quick] [--partitions 4] [--out DIR]
        [--resume] [--only-partitions P ...]

Writes to `results/robustness/` (`--quick`: `results/robustness/quick/`, one
partition, a few rows, our bands): `records.jsonl.gz` (gzip-compressed JSON
lines, one per held-out lamp, band set and row, with each pixel's level-1
confidence; resumable per (partition, band set)), `summary.json`
(strict JSON), `robustness.png`, `manifest.json` and `README.md`.
"""

import argparse
import time
from pathlib import Path

from bandopt.provenance import add_allow_dirty, refuse_dirty_at_start


OUT = Path("results/robustness")
"""Where the full study writes."""

QUICK_OUT = OUT / "quick"
"""Where `--quick` writes (kept apart from the full study's files)."""


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="1 partition, few rows, ours")
    ap.add_argument("--partitions", type=int, default=None, help="lamp partitions")
    ap.add_argument("--out", default=None, help=f"output (default {OUT})")
    ap.add_argument("--resume", action="store_true", help="keep finished units")
    ap.add_argument(
        "--only-partitions", type=int, nargs="+", default=None, metavar="P",
        help="compute only these partitions (the summary covers what is there)",
    )  # fmt: skip
    add_allow_dirty(ap)
    args = ap.parse_args(argv)
    refuse_dirty_at_start(
        ap, args, Path(args.out) if args.out else (QUICK_OUT if args.quick else OUT)
    )

    from bandopt import configure

    configure()
    from bandopt import robustness as rb
    from bandopt.studies import log

    if args.quick:
        study = rb.RobustnessStudy(
            band_sets=rb.BAND_SETS[:1],
            perturbations=rb.QUICK_PERTURBATIONS,
            partitions=args.partitions or 1,
        )
    else:
        study = rb.RobustnessStudy(partitions=args.partitions or 4)
    out = Path(args.out) if args.out else (QUICK_OUT if args.quick else OUT)
    out.mkdir(parents=True, exist_ok=True)
    t0 = time.time()
    records = rb.run_study(
        study,
        out / "records.jsonl.gz",
        resume=args.resume,
        partitions=args.only_partitions,
        log=lambda m: log(f"{m} ({time.time() - t0:.0f} s)", "robustness"),
    )
    rb.write_outputs(rb.summarise(records, study), study, out)
    log(f"done: {out} ({time.time() - t0:.0f} s)", "robustness")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
