"""Worked tutorial: your own lamp spectra, three sensors, the report
(`bandopt.tutorial`, the steps of docs/tutorial.rst).

Run:   python -m experiments.tutorial [--out DIR] [--open]      (or `make tutorial`)

Writes into `--out` (default: a new temporary folder): the three CSV files,
`evaluate_<sensor>.json` per sensor, `errors.csv` (|estimate - truth| per lamp,
sensor and metric), and `report/index.html`. Nothing under `results/` changes.
"""

import argparse
import sys
import tempfile
from pathlib import Path


def main(argv=None) -> int:
    from bandopt.tutorial import run

    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument(
        "--out",
        type=Path,
        default=None,
        help="folder for the tutorial's files (default: a new temp folder)",
    )
    p.add_argument("--open", action="store_true", help="open the report in a browser")
    args = p.parse_args(argv)
    out = args.out or Path(tempfile.mkdtemp(prefix="bandopt-tutorial-"))
    run(out, args.open)
    return 0


if __name__ == "__main__":
    sys.exit(main())
