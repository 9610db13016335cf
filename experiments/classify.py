"""Lamp-type classification: `bandopt.studies.classification` on the command
line.

    python -m experiments.classify [--quick] [--out DIR] [--report-only]
"""

import argparse

from bandopt.provenance import add_allow_dirty, refuse_dirty_at_start
from bandopt.results import RESULTS_DIR


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="tiny budgets (smoke test)")
    ap.add_argument(
        "--out", default=None, help="output folder (default results/classify)"
    )
    ap.add_argument(
        "--report-only", action="store_true", help="rewrite report.md from summary.json"
    )
    add_allow_dirty(ap)
    args = ap.parse_args(argv)
    refuse_dirty_at_start(ap, args, args.out or RESULTS_DIR / "classify")
    from bandopt import configure

    configure()  # XLA threads and the compilation cache, before JAX loads
    from bandopt.studies.classification import run

    return run(args.out, quick=args.quick, report_only=args.report_only)


if __name__ == "__main__":
    raise SystemExit(main())
