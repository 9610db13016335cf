"""What a lamp the library lacks costs: `bandopt.studies.library` on the
command line.

    python -m experiments.estimate_library [--partitions 4] [--out DIR]
        [--resume] [--only-partitions P ...]
"""


def main(argv=None) -> int:
    from bandopt import configure

    configure()  # XLA threads and the compilation cache, before JAX loads
    from bandopt.studies.library import run

    return run(argv)


if __name__ == "__main__":
    raise SystemExit(main())
