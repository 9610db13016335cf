"""The enlarged lamp library: counts before/after, NIR validation,
line-position checks of the undocumented color-pollution tables, build time
(`bandopt.datasets.lamp_report`).

Run:   python -m experiments.lamp_library [--before COMMIT]
Writes results/library/ counts_before_after.json and .md, nir_validation.json,
nir_validation.png, color_pollution_lines.json, build_time.json, manifest.json.
"""

import argparse
import sys
from pathlib import Path

from bandopt.provenance import add_allow_dirty, refuse_dirty_at_start


ROOT = Path(__file__).resolve().parents[1]
OUT = ROOT / "results" / "library"


def main(argv=None) -> int:
    from bandopt.datasets.lamp_report import BEFORE_COMMIT, write_report

    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--before", default=BEFORE_COMMIT, help="commit of 'before'")
    add_allow_dirty(ap)
    args = ap.parse_args(argv)
    refuse_dirty_at_start(ap, args, OUT)
    write_report(OUT, before=args.before)
    return 0


if __name__ == "__main__":
    sys.exit(main())
