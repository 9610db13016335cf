"""Ceiling of the level-1 family of unseen lamp types:
`bandopt.studies.unseen_ceiling` on the command line.

    python -m experiments.unseen_ceiling [--out DIR]
"""


def main(argv=None) -> int:
    from bandopt import configure

    configure()  # XLA threads and the compilation cache, before JAX loads
    from bandopt.studies.unseen_ceiling import run

    return run(argv)


if __name__ == "__main__":
    raise SystemExit(main())
