"""`bandopt report`: the self-contained HTML report built from `results/`."""

import json


def register(subparsers):
    p = subparsers.add_parser(
        "report",
        help="build the self-contained HTML report from results/",
        description=(
            "Build one self-contained HTML file (figures embedded) from the files "
            "of a results folder only: the recommended sensor, the comparison with "
            "every reference sensor, the search, classification, radiometry and "
            "spatial results, and provenance. An experiment that has not been run "
            "is named MISSING; two results files that disagree about the same "
            "number stop the build (exit status 3) with every disagreement listed."
        ),
    )
    p.add_argument(
        "--out",
        metavar="DIR",
        required=True,
        help="folder to write index.html into (created; an existing index.html "
        "there is replaced)",
    )
    p.add_argument(
        "--results",
        metavar="DIR",
        default="results",
        help="results folder to read (default: results)",
    )
    p.add_argument("--json", action="store_true", help="print a JSON summary")
    p.set_defaults(func=run)


def run(args) -> int:
    import sys

    from ..report import ReportDriftError, build_report

    try:
        res = build_report(args.results, args.out)
    except ReportDriftError as err:
        print(f"bandopt report: error: {err}", file=sys.stderr)
        return 3
    summary = {
        "path": str(res.path),
        "bytes": res.bytes,
        "missing": list(res.missing),
        "numbers_linked": res.numbers,
        "sources": list(res.sources),
    }
    if args.json:
        print(json.dumps(summary, indent=2))
    else:
        print(
            f"wrote {res.path} ({res.bytes / 1e6:.2f} MB, {res.numbers} numbers "
            f"linked to {len(res.sources)} results files)"
        )
        if res.missing:
            print("MISSING experiments: " + ", ".join(res.missing))
    return 0
