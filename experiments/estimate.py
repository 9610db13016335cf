"""Estimators of LER, G and CCT on lamps the estimator has never seen:
`bandopt.studies.estimate` on the command line.

    python -m experiments.estimate [--partitions 4] [--quick] [--out DIR]
        [--band-sets NAME ...] [--no-unseen] [--resume]
        [--modelled-per-class N] [--summarise-only]
"""


def main(argv=None) -> int:
    from bandopt import configure

    configure()  # XLA threads and the compilation cache, before JAX loads
    from bandopt.studies.estimate import run

    return run(argv)


if __name__ == "__main__":
    raise SystemExit(main())
