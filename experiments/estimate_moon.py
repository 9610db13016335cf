"""Where the estimate's G error comes from, the Moon: `bandopt.studies.moon`
on the command line.

    python -m experiments.estimate_moon [--partitions 4] [--out DIR]
"""


def main(argv=None) -> int:
    from bandopt import configure

    configure()  # XLA threads and the compilation cache, before JAX loads
    from bandopt.studies.moon import run

    return run(argv)


if __name__ == "__main__":
    raise SystemExit(main())
