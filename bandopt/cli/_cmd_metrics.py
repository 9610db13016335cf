"""`bandopt metrics`: photometry (LER, G, CCT, Duv) of user spectrum files."""

import json
import sys


def register(subparsers):
    p = subparsers.add_parser(
        "metrics",
        help="LER, G index, CCT and Duv of spectrum files",
        description=(
            "Compute the photometric ground truth of lamp spectrum files (two-column "
            "CSV, LI-1800 PRN, IES TM-27 XML): LER with the 380-780 nm denominator and "
            "with the file's full range, the spectral G index (capped and flagged "
            "without blue emission), CCT and Duv (Ohno 2013; flagged not meaningful "
            "for |Duv| > 0.05 or outside 1000-25000 K)."
        ),
    )
    p.add_argument("files", nargs="+", metavar="FILE")
    p.add_argument(
        "--unit",
        default="relative",
        help="unit of CSV values (photon units are converted), default relative",
    )
    p.add_argument(
        "--json", action="store_true", help="print a JSON list in input order"
    )
    p.set_defaults(func=run)


def spectrum_metrics(loaded) -> dict:
    """Photometry of one `LoadedSpectrum` on the 1 nm grid inside its range."""
    import numpy as np

    from ..photometry import ler, metrics

    lo = np.ceil(loaded.wavelength_nm[0])
    hi = np.floor(loaded.wavelength_nm[-1])
    grid = np.arange(lo, hi + 0.5, 1.0)
    values = np.interp(grid, loaded.wavelength_nm, loaded.values)
    vis = (grid >= 380.0) & (grid <= 780.0)
    m = metrics(values[None, vis], grid[vis])
    full = float(np.asarray(ler(values[None], grid, denominator="full"))[0])
    return {
        "file": loaded.path,
        "LER": float(m["LER"][0]),
        "LER_full_range": full,
        "G": float(m["G"][0]),
        "G_flag": bool(m["G_flag"][0]),
        "CCT": float(m["CCT"][0]),
        "Duv": float(m["Duv"][0]),
        "CCT_flag": bool(m["CCT_flag"][0]),
    }


def run(args) -> int:
    from ..datasets.loaders import read_spectrum

    rows = [spectrum_metrics(read_spectrum(f, unit=args.unit)) for f in args.files]
    if args.json:
        json.dump(rows, sys.stdout, indent=2)
        print()
        return 0
    print(f"{'file':<40}{'LER':>8}{'LER_full':>9}{'G':>7}{'CCT':>8}{'Duv':>8}  flags")
    for r in rows:
        flags = ",".join(k for k in ("G_flag", "CCT_flag") if r[k])
        print(
            f"{r['file'][-39:]:<40}{r['LER']:8.1f}{r['LER_full_range']:9.1f}"
            f"{r['G']:7.2f}{r['CCT']:8.0f}{r['Duv']:8.4f}  {flags}"
        )
    return 0
