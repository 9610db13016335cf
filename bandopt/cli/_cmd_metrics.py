"""`bandopt metrics`: photometry (LER, G, CCT, Duv) of user spectrum files."""


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
    visible_power = (
        float(np.trapezoid(values[vis], grid[vis])) if vis.sum() > 1 else 0.0
    )
    row = {
        "file": loaded.path,
        "LER": float(m["LER"][0]),
        "LER_full_range": full,
        "G": float(m["G"][0]),
        "G_flag": bool(m["G_flag"][0]),
        "CCT": float(m["CCT"][0]),
        "Duv": float(m["Duv"][0]),
        "CCT_flag": bool(m["CCT_flag"][0]),
    }
    if not visible_power > 0:  # G compares blue with V(λ)-weighted light: 0/0
        row["G"] = float("nan")
    return _null_reasons(row, visible_power)


def _null_reasons(row: dict, visible_power: float) -> dict:
    """Replace each non-finite value by None and say why in `null_reason`
    (JSON has no NaN; a reader must not take a missing number for a result)."""
    import math

    why = (
        "no light in 380-780 nm (visible power 0): undefined"
        if not visible_power > 0
        else "not defined for this spectrum (computation gave NaN)"
    )
    reasons = {}
    for k, v in row.items():
        if isinstance(v, float) and not math.isfinite(v):
            row[k] = None
            reasons[k] = why
    if reasons:
        row["null_reason"] = reasons
    return row


def run(args) -> int:
    from ..datasets.loaders import read_spectrum
    from ._output import print_json

    rows = [spectrum_metrics(read_spectrum(f, unit=args.unit)) for f in args.files]
    if args.json:
        print_json(rows)
        return 0
    print(f"{'file':<40}{'LER':>8}{'LER_full':>9}{'G':>7}{'CCT':>8}{'Duv':>8}  flags")
    for r in rows:
        flags = ",".join(k for k in ("G_flag", "CCT_flag") if r[k])
        cells = [
            ("LER", 8, ".1f"),
            ("LER_full_range", 9, ".1f"),
            ("G", 7, ".2f"),
            ("CCT", 8, ".0f"),
            ("Duv", 8, ".4f"),
        ]
        text = "".join(
            f"{'n/a':>{w}}" if r[k] is None else f"{r[k]:{w}{f}}" for k, w, f in cells
        )
        print(f"{r['file'][-39:]:<40}{text}  {flags}")
        for k, why in r.get("null_reason", {}).items():
            print(f"  {k}: {why}")
    return 0
