"""`bandopt fit`: an estimator fitted once for a band set and written to a
file that `bandopt evaluate --model` uses instead of fitting again."""

from ._estimator_options import (
    add_estimator_options,
    obtain_fitted,
    prepare,
    read_prior_lamps,
    surface_of,
)


def register(subparsers):
    p = subparsers.add_parser(
        "fit",
        help="fit an estimator for a band set once and write it to a file",
        description=(
            "Fit the estimator of `bandopt evaluate` (same options, same "
            "defaults) for a band set and write it to MODEL (.npz: numpy arrays "
            "and a JSON header, no pickle), with the fingerprint of what it "
            "depends on: the bands' centres, FWHMs, shapes and response, the "
            "estimator and its options, your --prior-lamps, the surface "
            "knowledge (--surface), the lamp library and package data, and the "
            "bandopt code. `bandopt evaluate --model MODEL` with the same "
            "options uses it instead of fitting and refuses it, naming the "
            "field, when anything differs. The fit goes into the cache too "
            "(see evaluate --model), and a cached fit is reused here."
        ),
    )
    add_estimator_options(p)
    p.add_argument(
        "--out", required=True, metavar="MODEL", help="model file to write (.npz)"
    )
    p.add_argument("--json", action="store_true", help="print JSON")
    p.set_defaults(func=run)


def run(args) -> int:
    import numpy as np

    from ..estimators import save_fitted
    from ..spectra import GRID_1NM

    bands, name, config, warnings = prepare(args)
    read_prior_lamps(args, warnings)
    _, surface_label, mode, _ = surface_of(args, np.asarray(GRID_1NM, float))
    fitted, fp = obtain_fitted(args, bands, config, mode)
    path = save_fitted(args.out, fitted, fp)
    out = {
        "model": str(path),
        "bytes": path.stat().st_size,
        "bands": name,
        "estimator": args.estimator,
        "surface_knowledge": mode,
        "surface": surface_label,
        "estimator_description": fitted.description,
        "fingerprint": fp,
        "warnings": warnings,
    }
    if args.json:
        from ._output import print_json

        print_json(out)
        return 0
    print(
        f"wrote {path} ({out['bytes'] / 1e6:.1f} MB): {args.estimator} for {name}, "
        f"surface {mode}; use it with `bandopt evaluate --bands {args.bands} "
        f"--model {path}` and the same options"
    )
    return 0
