"""Robustness suite: the shipped estimate on held-out library lamps under what
real spectra hold (the study and its outputs are `bandopt.robustness`).

    python -m experiments.robustness [--config suite|quick|tolerance]
        [--partitions 4] [--out DIR] [--resume] [--only-partitions P ...]

Writes to `results/robustness/` (`--quick`: `results/robustness/quick/`, one
partition, a few rows, our bands; `--config tolerance`:
`results/robustness/tolerance/`, our bands read through as-built sensors,
with `tolerance.json`, `tolerance.png` and the intervals in `README.md`):
`records.jsonl.gz` (gzip-compressed JSON
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

OUTS = {"suite": OUT, "quick": QUICK_OUT, "tolerance": OUT / "tolerance"}
"""Where each configuration writes by default."""


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument(
        "--config", choices=sorted(OUTS), default="suite",
        help="suite: every measurement effect, ours and the references (default); "
        "quick: 1 partition, few rows, ours; tolerance: our bands' centre, FWHM, "
        "leakage and angle of incidence scanned until the errors grow 10 %%",
    )  # fmt: skip
    ap.add_argument("--quick", action="store_true", help="same as --config quick")
    ap.add_argument("--partitions", type=int, default=None, help="lamp partitions")
    ap.add_argument("--out", default=None, help=f"output (default {OUT})")
    ap.add_argument("--resume", action="store_true", help="keep finished units")
    ap.add_argument(
        "--only-partitions", type=int, nargs="+", default=None, metavar="P",
        help="compute only these partitions (the summary covers what is there)",
    )  # fmt: skip
    add_allow_dirty(ap)
    args = ap.parse_args(argv)
    if args.quick:
        args.config = "quick"
    out = Path(args.out) if args.out else OUTS[args.config]
    refuse_dirty_at_start(ap, args, out)

    from bandopt import configure

    configure()
    from bandopt import robustness as rb
    from bandopt.studies import log

    if args.config == "quick":
        study = rb.RobustnessStudy(
            band_sets=rb.BAND_SETS[:1],
            perturbations=rb.QUICK_PERTURBATIONS,
            partitions=args.partitions or 1,
        )
    elif args.config == "tolerance":
        study = rb.tolerance_study(partitions=args.partitions or 4)
    else:
        study = rb.RobustnessStudy(partitions=args.partitions or 4)
    out.mkdir(parents=True, exist_ok=True)
    t0 = time.time()
    records = rb.run_study(
        study,
        out / "records.jsonl.gz",
        resume=args.resume,
        partitions=args.only_partitions,
        log=lambda m: log(f"{m} ({time.time() - t0:.0f} s)", "robustness"),
    )
    if args.only_partitions is not None and args.config == "tolerance":
        log(f"partitions {args.only_partitions} done; join with --resume", "robustness")
        return 0
    summary = rb.summarise(records, study)
    rb.write_outputs(summary, study, out)
    if args.config == "tolerance":
        rb.write_tolerances(summary, out)
    log(f"done: {out} ({time.time() - t0:.0f} s)", "robustness")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
