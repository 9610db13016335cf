"""Band search for LER, G and CCT, and the comparison with existing sensors.

Run:
    python -m experiments.search run              # the stability study (`make run`)
    python -m experiments.search ler|g|cct|all    # one target, n = 1..6 + pan
    python -m experiments.search sweep            # every target, n = 1..6 + pan
    python -m experiments.search compare          # tables, figures, recommendation
    python -m experiments.search budget           # run time against error table
Options: --out DIR (default results/search), --workers K, --scheduler ADDRESS
(Dask), --max-evals N, --seed S, --preset NAME, --bands 1,2,...

`run` is the stability study (`bandopt.search.run_study`), with options
--partitions, --max-steps, --scorer, --tolerance-scorer and --force (recompute
cached tasks; otherwise a rerun says which results of the identical
configuration it reuses). The other commands are the single-split study
(`bandopt.search.single_split_*`, outputs named `single_split_*`): the
searches of one target or all of them, then their comparison with the
reference sensors.
"""

import argparse
import sys
from pathlib import Path


COMMANDS = ["run", "ler", "g", "cct", "all", "sweep", "compare", "budget"]


def main(argv=None) -> int:
    from bandopt import configure

    configure()  # XLA threads and the compilation cache, before JAX loads
    from bandopt import search
    from bandopt.provenance import add_allow_dirty, refuse_dirty_at_start

    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("command", choices=COMMANDS)
    p.add_argument("--out", default=str(search.DEFAULT_OUT))
    p.add_argument(
        "--workers",
        type=int,
        default=1,
        help="spawned worker processes (default 1: this process; XLA uses both cores)",
    )
    p.add_argument("--scheduler", default=None, metavar="ADDRESS")
    p.add_argument("--max-evals", type=int, default=None)
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--preset", default="search")
    p.add_argument("--bands", default="1,2,3,4,5,6", help="band counts (without pan)")
    p.add_argument("--partitions", type=int, default=search.STUDY["partitions"])
    p.add_argument(
        "--max-steps",
        type=int,
        default=search.STUDY["max_steps"],
        help="optimistix steps per local fit",
    )
    p.add_argument(
        "--scorer",
        default=search.DEFAULT_SCORER,
        help="outer-fold estimator (default: bandopt.search.DEFAULT_SCORER)",
    )
    p.add_argument(
        "--tolerance-scorer",
        default="ridge",
        help="estimator of the tolerance scan: ridge by default, because the "
        "scan scores 227 perturbed band sets on every resample (227 x the "
        "inversion's inverting of all test lamps, hours on 2 cores) and refits "
        "the estimator on each of them for the calibrated variant (227 x 12 "
        "refits with the nominal hyper-parameters, about 35 s with ridge); the "
        "rule is relative (<= 1.10 x "
        "nominal MAE) (default: ridge)",
    )
    p.add_argument("--force", action="store_true", help="recompute cached tasks")
    add_allow_dirty(p)
    parsed = p.parse_args(argv)
    refuse_dirty_at_start(p, parsed, parsed.out)
    args = vars(parsed)
    args.pop("allow_dirty")
    command = args.pop("command")
    args["out"] = Path(args["out"])
    args["bands"] = tuple(int(v) for v in args["bands"].split(","))
    options = search.SearchOptions(**args)
    options.out.mkdir(parents=True, exist_ok=True)
    if command == "run":
        search.run_study(options)
    elif command == "budget":
        search.single_split_budget(options)
    else:
        if command != "compare":
            targets = search.TARGETS if command == "sweep" else [command]
            search.single_split_sweep(options, targets)
        search.single_split_compare(options)
    return 0


if __name__ == "__main__":
    sys.exit(main())
