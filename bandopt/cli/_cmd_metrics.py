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
    p.add_argument(
        "--plot",
        metavar="FILE",
        help="draw the spectra (peak 1) with V(λ) and their LER and CCT (png, pdf)",
    )
    p.set_defaults(func=run)


def spectrum_metrics(loaded) -> dict:
    """Photometry of one `LoadedSpectrum` on the 1 nm grid inside its range;
    LER, G and CCT undefined by the rule `bandopt evaluate` uses for its
    truth (`estimate.truth_with_reasons`), with the reason."""
    import math

    import numpy as np

    from ..estimate import truth_with_reasons
    from ..photometry import ler, metrics

    lo = np.ceil(loaded.wavelength_nm[0])
    hi = np.floor(loaded.wavelength_nm[-1])
    grid = np.arange(lo, hi + 0.5, 1.0)
    values = np.interp(grid, loaded.wavelength_nm, loaded.values)
    vis = (grid >= 380.0) & (grid <= 780.0)
    m = metrics(values[None, vis], grid[vis])
    truth, reasons = truth_with_reasons(values[None], grid)
    full = float(np.asarray(ler(values[None], grid, denominator="full"))[0])
    row = {
        "file": loaded.path,
        "LER": float(truth[0, 0]),
        "LER_full_range": full,
        "G": float(truth[0, 1]),
        "G_flag": bool(m["G_flag"][0]),
        "CCT": float(truth[0, 2]),
        "Duv": float(m["Duv"][0]),
        "CCT_flag": bool(m["CCT_flag"][0]),
    }
    why = dict(reasons[0])
    other = why.get("LER", "not defined for this spectrum (computation gave NaN)")
    for k, v in row.items():
        if isinstance(v, float) and not math.isfinite(v):
            row[k] = None
            why.setdefault(k, other)
    if why:
        row["null_reason"] = why
    return row


def plot(spectra, rows, path) -> None:
    """Each spectrum (peak 1) over its measured range, the CIE 1924 photopic
    V(λ) for reference, LER and CCT in the legend."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np

    from .._photometry_tables import observer_tables
    from ._plots import legend_outside

    fig, ax = plt.subplots(figsize=(10, 4.5), constrained_layout=True)
    lo = min(float(s.wavelength_nm[0]) for s in spectra)
    hi = max(float(s.wavelength_nm[-1]) for s in spectra)
    for s, r in zip(spectra, rows, strict=True):
        w, v = np.asarray(s.wavelength_nm), np.asarray(s.values)
        if w.size > 20000:  # a plot needs no more than ~1 point per 0.05 nm
            step = int(np.ceil(w.size / 20000))
            w, v = w[::step], v[::step]
        ler = "n/a" if r["LER"] is None else f"{r['LER']:.0f} lm/W"
        cct = "n/a" if r["CCT"] is None else f"{r['CCT']:.0f} K"
        ax.plot(w, v / v.max(), lw=1.2, label=f"{s.name}: LER {ler}, CCT {cct}")
    vw, vl, _ = observer_tables()
    ax.plot(vw, vl, "k--", lw=1, label="V(λ) (CIE 1924)")
    ax.set_xlim(lo, hi)
    ax.set_ylim(0, 1.05)
    ax.set_xlabel("wavelength [nm]")
    ax.set_ylabel("relative spectral power (peak 1) [1]")
    ax.set_title("lamp spectra (energy units) and the photopic luminosity function")
    legend_outside(ax, fontsize=8)
    fig.savefig(path, dpi=120)
    plt.close(fig)


def run(args) -> int:
    from ..datasets.loaders import read_spectrum
    from ._output import atomic_path, prepare_file, print_json

    if args.plot:
        prepare_file(args.plot, "--plot")
    spectra = [read_spectrum(f, unit=args.unit) for f in args.files]
    rows = [spectrum_metrics(s) for s in spectra]
    if args.plot:
        with atomic_path(args.plot) as tmp:
            plot(spectra, rows, tmp)
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
