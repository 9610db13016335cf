"""Run a registered study (`bandopt.studies.STUDIES`) by name; without a
name, list them.

    python -m experiments.study NAME [--partitions 4] [--out DIR] [--resume]
        [--only-partitions P ...] [--no-unseen]
"""

import sys


def main(argv=None) -> int:
    argv = sys.argv[1:] if argv is None else list(argv)
    from bandopt import configure

    configure()  # XLA threads and the compilation cache, before JAX loads
    from bandopt.studies import STUDIES, run

    if not argv or argv[0].startswith("-"):
        for name, study in STUDIES.items():
            print(f"{name:22s} {study.description or study.title}")
        print('\nrun one: make study NAME=<name> [ARGS="--resume"]')
        return 0
    try:
        study = STUDIES[STUDIES.resolve(argv[0])]
    except ValueError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    return run(study, argv[1:])


if __name__ == "__main__":
    raise SystemExit(main())
