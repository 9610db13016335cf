"""Headline numbers of every downstream experiment at a git revision and in
the working tree, side by side: `bandopt.report.before_after` on the
command line.

    python -m experiments.before_after --before 0e7885f [--after REV]
                                       [--results DIR] [--no-write]
    make before-after                  (BEFORE=0e7885f unless given)
"""

from bandopt.report.before_after import run


def main(argv=None) -> int:
    return run(argv)


if __name__ == "__main__":
    raise SystemExit(main())
