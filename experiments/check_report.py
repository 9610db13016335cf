"""Open the HTML report in headless Chromium and check what a reader sees
(`bandopt.report.check_in_browser`).

Run:   python -m experiments.check_report [--report results/report/index.html]
           [--screenshot results/report/screenshot.png]

Needs Debian's `chromium` and `chromium-driver` and the `selenium` package
(`make check-report` installs them when absent). Exit status 1 with the
list of failures when a check fails.
"""

import argparse
import sys
from pathlib import Path

from bandopt.report import check_in_browser


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--report", default="results/report/index.html", type=Path)
    p.add_argument("--screenshot", default="results/report/screenshot.png", type=Path)
    args = p.parse_args(argv)
    if not args.report.is_file():
        print(f"{args.report}: no report; run `make report` first.", file=sys.stderr)
        return 2
    failures = check_in_browser(args.report, args.screenshot)
    for f in failures:
        print("FAIL:", f, file=sys.stderr)
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
