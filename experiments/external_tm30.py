"""External check, `bandopt evaluate` on the 210 measured IES TM-30-15
lamps the library lacks: `bandopt.studies.external_tm30` on the command
line.

    python -m experiments.external_tm30 [--out DIR]
"""


def main(argv=None) -> int:
    from bandopt import configure

    configure()  # XLA threads and the compilation cache, before JAX loads
    from bandopt.studies.external_tm30 import run

    return run(argv)


if __name__ == "__main__":
    raise SystemExit(main())
