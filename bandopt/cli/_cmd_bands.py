"""`bandopt bands`: print a band set and draw its responses over lamp spectra."""

import sys


def register(subparsers):
    p = subparsers.add_parser(
        "bands",
        help="show a band set (reference sensor name or JSON file)",
        description=(
            "Print a band set: each band's centre, FWHM, shape k, half-maximum "
            "edges and the fraction of its response area outside the 380-900 nm "
            "data grid, plus the reference sensor's GSD, bit depth, citations and "
            "how its edges became a response. NAME is a reference sensor "
            "(viirs-dnb, viirs-dnb-tabulated, dmsp-ols, sac-c, sac-d, cumulos, "
            "luojia-1-01, aerocube, iss-dslr, jilin-1-03b, eros-b, sdgsat-1, "
            "nightsat; case and separators ignored) or a JSON file "
            '{"name", "bands": [{"name", "centre_nm", "fwhm_nm", "shape_k"}]}.'
        ),
    )
    p.add_argument(
        "source",
        nargs="?",
        metavar="NAME|FILE",
        help="reference sensor or JSON file (required unless --list)",
    )
    p.add_argument(
        "--list", action="store_true", help="list the reference sensor names"
    )
    p.add_argument("--json", action="store_true", help="print JSON instead of a table")
    p.add_argument(
        "--plot",
        metavar="FILE",
        help="draw the responses over NIST HPS, LPS, metal halide and a white LED",
    )
    p.add_argument(
        "--export-csv",
        metavar="FILE",
        help="write each band's response on 380-900 nm at 1 nm as CSV",
    )
    p.add_argument(
        "--force",
        action="store_true",
        help="replace an existing --export-csv file (else an error)",
    )
    p.set_defaults(func=run)


def _load(source: str):
    from ..sensor import resolve_band_set

    found = resolve_band_set(source)
    return found.bands, found.entry


def summary(bands, entry) -> dict:
    """A JSON-ready description of a band set on the library grid."""
    import numpy as np

    from ..spectra import GRID_1NM

    centre = np.asarray(bands.centre_nm, float)
    fwhm = np.asarray(bands.fwhm_nm, float)
    edges = np.asarray(bands.edges_nm, float)
    k = np.asarray(bands.shape_k, float) if hasattr(bands, "shape_k") else None
    lost = np.asarray(bands.fraction_outside(GRID_1NM), float)
    out = {
        "name": bands.name,
        "kind": "tabulated" if k is None else "super-gaussian",
        "grid_nm": [float(GRID_1NM[0]), float(GRID_1NM[-1])],
        "bands": [
            {
                "name": n,
                "centre_nm": round(float(centre[i]), 3),
                "fwhm_nm": round(float(fwhm[i]), 3),
                "shape_k": None if k is None else round(float(k[i]), 4),
                "half_max_edges_nm": [round(float(e), 3) for e in edges[i]],
                "fraction_outside_grid": float(f"{lost[i]:.4g}"),
            }
            for i, n in enumerate(bands.names)
        ],
    }
    if entry is not None:
        out.update(
            key=entry.key,
            title=entry.title,
            gsd_m=list(entry.gsd_m),
            bit_depth=entry.bit_depth,
            detection_limit_w_m2_sr_nm=entry.detection_limit_w_m2_sr_nm,
            citations=list(entry.citations),
            response=entry.response_note,
            note=entry.note,
        )
    if getattr(bands, "source_note", ""):
        out["table_note"] = bands.source_note
    return out


def _print_table(info: dict) -> None:
    print(f"{info.get('title', info['name'])}  [{info['kind']}]")
    head = f"{'band':<14}{'centre':>9}{'FWHM':>9}{'k':>8}{'50% edges':>18}{'lost':>9}"
    print(head)
    print("-" * len(head))
    for b in info["bands"]:
        k = "tab" if b["shape_k"] is None else f"{b['shape_k']:g}"
        lo, hi = b["half_max_edges_nm"]
        print(
            f"{b['name']:<14}{b['centre_nm']:>9.1f}{b['fwhm_nm']:>9.1f}{k:>8}"
            f"{lo:>9.1f}-{hi:<8.1f}{100 * b['fraction_outside_grid']:>8.2f}%"
        )
    lo, hi = info["grid_nm"]
    print(
        f"(centre, FWHM, edges in nm; 'lost': response area outside {lo:g}-{hi:g} nm)"
    )
    for field in ("gsd_m", "bit_depth", "detection_limit_w_m2_sr_nm", "citations"):
        if info.get(field) is not None:
            print(f"{field}: {info[field]}")
    for field in ("response", "note", "table_note"):
        if info.get(field):
            print(f"{field}: {info[field]}")


LAMPS_SHOWN = (
    ("HPS", "nist_traditional_hps"),
    ("LPS", "nist_traditional_lps"),
    ("metal halide", "metal_halide"),
    ("white LED (YAG)", "nist_led_phosphor_led_yag"),
)
"""Lamps drawn under the bands: NIST CQS spectra (`Ohno2008a`/`Ohno2008b`)
from the library, which extends them beyond 780 nm to 900 nm
(`bandopt.datasets.nir`); "metal_halide" takes the first library lamp of
that class."""


def _lamps(wavelength_nm):
    """The `LAMPS_SHOWN` library spectra on `wavelength_nm`, peak 1, over the
    whole band range (NIR-extended beyond their measured end)."""
    import numpy as np

    from ..datasets.lamps import library

    lib = library()
    ids = list(lib.ids)
    out = {}
    for label, key in LAMPS_SHOWN:
        if key in ids:
            i = ids.index(key)
        else:
            i = next(
                (j for j, r in enumerate(lib.records) if r.level2 == key), None
            )
            if i is None:
                continue
        r = lib.records[i]
        v = np.interp(wavelength_nm, lib.wavelength_nm, lib.values[i])
        ext = f", extended beyond {r.measured_range_nm[1]:g} nm" if r.extended else ""
        out[f"{label} ({r.id}{ext})"] = v / np.nanmax(v)
    return out


def plot(bands, info: dict, path: str) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np

    from ..spectra import GRID_1NM
    from ._plots import band_colour, legend_outside

    wl = np.asarray(GRID_1NM)
    fig, ax = plt.subplots(figsize=(11, 4.5), constrained_layout=True)
    shades = ("0.55", "goldenrod", "0.8", "lightsteelblue")
    for (label, v), shade in zip(_lamps(wl).items(), shades, strict=False):
        ax.fill_between(wl, 0, v, color=shade, alpha=0.45, lw=0, label=label)
    r = np.asarray(bands.response(wl))
    centre = np.asarray(bands.centre_nm, float)
    fwhm = np.asarray(bands.fwhm_nm, float)
    for i, name in enumerate(bands.names):
        c = band_colour(centre[i], fwhm[i], name)
        ax.plot(wl, r[i], lw=2, color=c, label=f"{name} ({centre[i]:.0f} nm)")
    ax.set_xlim(wl[0], wl[-1])
    ax.set_ylim(0, 1.05)
    ax.set_xlabel("wavelength [nm]")
    ax.set_ylabel("relative response / lamp spectrum (peak 1) [1]")
    ax.set_title(info.get("title", info["name"]))
    legend_outside(ax, fontsize=7)
    fig.savefig(path, dpi=120)
    plt.close(fig)


def _list(as_json: bool) -> int:
    from ..sensor import REFERENCE_SENSORS
    from ._output import print_json

    rows = [
        {"name": key, "title": e.title, "n_bands": len(e.build().names)}
        for key, e in REFERENCE_SENSORS.items()
    ]
    if as_json:
        print_json(rows)
        return 0
    for r in rows:
        print(f"{r['name']:<22}{r['n_bands']:>3} band(s)  {r['title']}")
    return 0


def run(args) -> int:
    from ..sensor import export_response_csv
    from ._output import atomic_path, prepare_file, print_json, refuse_existing

    if args.list:
        return _list(args.json)
    if args.source is None:
        raise ValueError("give a band set NAME|FILE, or --list for the names.")
    if args.export_csv:
        refuse_existing(args.export_csv, "--export-csv", args.force)
    for opt, path in (("--export-csv", args.export_csv), ("--plot", args.plot)):
        if path:
            prepare_file(path, opt)
    bands, entry = _load(args.source)
    info = summary(bands, entry)
    if args.json:
        print_json(info)
    else:
        _print_table(info)
    if args.export_csv:
        with atomic_path(args.export_csv) as tmp:
            export_response_csv(bands, tmp)
        print(f"wrote {args.export_csv}", file=sys.stderr)
    if args.plot:
        with atomic_path(args.plot) as tmp:
            plot(bands, info, tmp)
        print(f"wrote {args.plot}", file=sys.stderr)
    return 0
