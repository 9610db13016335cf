"""`bandopt surfaces`: the measured surface reflectance library at a glance."""

from ._options import bounded


REPORT_NM = (450.0, 550.0, 650.0, 850.0, 1000.0)


def register(subparsers):
    p = subparsers.add_parser(
        "surfaces",
        help="list surface reflectance types, counts, mean and spread",
        description=(
            "List the surface types of bandopt.datasets.surfaces with their number "
            "of measured spectra, source, measured and extrapolated ranges, and the "
            "mean and percentile spread of reflectance at a few wavelengths. "
            "--plot draws the mean with a percentile band per type (cf. thesis "
            "Figure 3.5)."
        ),
    )
    p.add_argument("--json", action="store_true", help="print JSON instead of a table")
    p.add_argument("--plot", metavar="FILE", help="write a figure (PNG, PDF, SVG)")
    p.add_argument(
        "--percentiles",
        nargs=2,
        type=bounded(lo=0.0, hi=100.0, why="%"),
        default=(5.0, 95.0),
        metavar=("LOW", "HIGH"),
        help="percentiles of the spread band [%%] (default 5 95)",
    )
    p.set_defaults(func=run)


def _summary(percentiles: tuple[float, float]) -> list[dict]:
    import numpy as np

    from ..datasets.surfaces import SURFACE_TYPES, library_info, surface

    info = library_info()["classes"]
    rows = []
    for name in SURFACE_TYPES:
        s = surface(name)
        at = s.resample(np.asarray(REPORT_NM)).reflectance
        lo, hi = np.percentile(at, percentiles, axis=0)
        rows.append(
            {
                "name": name,
                "n": s.n,
                "n_in_source": info.get(name, {}).get("n_in_earthlib", s.n),
                "source": s.source,
                "measured_range_nm": list(s.measured_range_nm),
                "extrapolated_range_nm": (
                    list(s.extrapolated_range_nm) if s.extrapolated_range_nm else None
                ),
                "wavelength_nm": list(REPORT_NM),
                "mean": [round(float(v), 5) for v in at.mean(axis=0)],
                "percentile_low": [round(float(v), 5) for v in lo],
                "percentile_high": [round(float(v), 5) for v in hi],
                "description": s.description,
            }
        )
    return rows


def _plot(path: str, percentiles: tuple[float, float]) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np

    from ..datasets.surfaces import RANGE_NM, SURFACE_TYPES, surface
    from ._plots import save_figure

    grid = np.arange(RANGE_NM[0], RANGE_NM[1] + 0.5, 2.0)
    ncol = 4
    nrow = -(-len(SURFACE_TYPES) // ncol)
    fig, axes = plt.subplots(
        nrow, ncol, figsize=(3.2 * ncol, 2.4 * nrow), sharex=True, squeeze=False
    )
    for ax, name in zip(axes.flat, SURFACE_TYPES, strict=False):
        s = surface(name).resample(grid)
        r = s.reflectance
        lo, hi = np.percentile(r, percentiles, axis=0)
        ax.fill_between(grid, lo, hi, color="C0", alpha=0.3, lw=0)
        ax.plot(grid, r.mean(axis=0), color="C0", lw=1.2)
        if s.extrapolated_range_nm:
            ax.axvspan(*s.extrapolated_range_nm, color="0.85", lw=0)
        ax.set_title(f"{name} (n={s.n})", fontsize=9)
        ax.set_ylim(0, max(0.05, float(hi.max()) * 1.1))
        ax.tick_params(labelsize=7)
    for ax in axes.flat[len(SURFACE_TYPES) :]:
        ax.set_visible(False)
    for ax in axes[-1]:
        ax.set_xlabel("wavelength [nm]", fontsize=8)
    for ax in axes[:, 0]:
        ax.set_ylabel("reflectance [1]", fontsize=8)
    fig.suptitle(
        f"Surface reflectance: mean and {percentiles[0]:g}-{percentiles[1]:g} "
        "percentile band (grey: extrapolated)",
        fontsize=10,
    )
    save_figure(fig, path, 120)


def run(args) -> int:
    from ._output import atomic_path, prepare_file, print_json

    if args.plot:
        prepare_file(args.plot, "--plot")
    percentiles = tuple(args.percentiles)
    if not 0.0 <= percentiles[0] < percentiles[1] <= 100.0:
        raise ValueError(
            f"--percentiles: need 0 <= LOW < HIGH <= 100, got {list(percentiles)}."
        )
    rows = _summary(percentiles)
    if args.json:
        print_json({"percentiles": list(percentiles), "types": rows}, indent=1)
    else:
        head = "  ".join(f"{w:>11g}" for w in REPORT_NM)
        print(
            f"{'type':20s} {'n':>4s} {'of':>5s}  {'source':12s} {'extrap. nm':>10s}  "
            f"mean [p{percentiles[0]:g}-p{percentiles[1]:g}] at nm: {head}"
        )
        for r in rows:
            ext = r["extrapolated_range_nm"]
            ext = f"{ext[0]:g}-{ext[1]:g}" if ext else "-"
            cells = "  ".join(
                f"{m:.3f}[{lo:.2f}-{hi:.2f}]"
                for m, lo, hi in zip(
                    r["mean"], r["percentile_low"], r["percentile_high"], strict=True
                )
            )
            print(
                f"{r['name']:20s} {r['n']:4d} {r['n_in_source']:5d}  {r['source']:12s} "
                f"{ext:>10s}  {cells}"
            )
    if args.plot:
        with atomic_path(args.plot) as tmp:
            _plot(tmp, percentiles)
        if not args.json:
            print(f"wrote {args.plot}")
    return 0
