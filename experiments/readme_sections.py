"""Sections of results/README.md generated from the experiments' own files
(`bandopt.report.write_readme_section`).

Run:   python -m experiments.readme_sections classification|spatial|noise-aware
       [--results DIR]

`make classify` and `make spatial` call this after the experiment;
`make noise-aware` writes its section from `results/noise_aware/noise_aware.json`.
The radiometry section is written by `experiments.radiometry`, the search
section by `experiments.search`.
"""

import argparse
import sys

from bandopt.report import README_SECTIONS, write_readme_section


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("section", choices=README_SECTIONS)
    p.add_argument("--results", default="results")
    args = p.parse_args(argv)
    print(f"wrote {write_readme_section(args.section, args.results)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
