"""`bandopt library`: the lamp library with typology and photometry."""

import sys


def register(subparsers):
    p = subparsers.add_parser(
        "library",
        help="list the lamp library (typology, source, LER, G, CCT)",
        description=(
            "List every spectrum of the built-in lamp library with its id, name, "
            "level-1 and level-2 class, source key, measured range, whether the "
            "near-infrared extension was used, and its photometry (LER, G, CCT, Duv)."
        ),
    )
    p.add_argument("--json", action="store_true", help="print JSON instead of a table")
    p.add_argument(
        "--counts",
        action="store_true",
        help="print the count table per level-2 class and the rules used",
    )
    p.add_argument("--plot", metavar="FILE", help="draw the spectra grouped by type")
    p.add_argument(
        "--no-extension",
        action="store_true",
        help="switch the near-infrared extension off (values beyond 780 nm unknown)",
    )
    p.set_defaults(func=run)


def library_rows(lib) -> list[dict]:
    """One dict per spectrum: record fields plus photometry on the library grid."""
    import numpy as np

    from ..photometry import metrics

    w = lib.wavelength_nm
    vis = (w >= 380.0) & (w <= 780.0)
    m = metrics(lib.values[:, vis], w[vis])
    finite = np.all(np.isfinite(lib.values), axis=1)
    full = np.full(len(lib), np.nan)
    if finite.any():
        from ..photometry import ler

        full[finite] = np.asarray(ler(lib.values[finite], w, denominator="full"))
    rows = []
    for i, r in enumerate(lib.records):
        rows.append(
            {
                "id": r.id,
                "name": r.name,
                "level1": r.level1,
                "level2": r.level2,
                "source": r.source,
                "measured_range_nm": list(r.measured_range_nm),
                "extended": r.extended,
                "extension_validated": r.extension_validated,
                "modelled": r.modelled,
                "cie_typical": r.cie_typical,
                "scored": lib.is_scored(r),
                "excluded": r.excluded,
                "duplicates_removed": list(r.duplicates),
                "LER": float(m["LER"][i]),
                "LER_full_range": None if np.isnan(full[i]) else float(full[i]),
                "G": float(m["G"][i]),
                "G_flag": bool(m["G_flag"][i]),
                "CCT": float(m["CCT"][i]),
                "Duv": float(m["Duv"][i]),
                "CCT_flag": bool(m["CCT_flag"][i]),
            }
        )
    return rows


RULES = {
    "distinct_lamps": "measured spectra after near-duplicate removal; modelled "
    "(Planck) spectra are not counted; 'excl.' lamps are in the class but never "
    "scored (a datasheet-like curve)",
    "duplicate_rule": "same lamp when RMS difference of unit-visible-power spectra "
    "(380-780 nm, 5 nm) < 3 % of their mean, across all sets including "
    "colour-science's CIE and NIST ones; the copy from the first source in "
    "li1800 > nist_philips > nist_traditional > nist_led > cie015 > "
    "color_pollution > photobiology > lspdd is kept (documented provenance first)",
    "led_warm_cool": "phosphor LEDs: led_warm for CCT <= 3500 K (Ohno 2013), "
    "else led_cool",
    "led_amber": "LEDs with excitation purity >= 0.9 (illuminant E) and dominant "
    "wavelength 575-610 nm: subtype direct_amber (half-maximum width < 40 nm), "
    "pc_amber (broad, >= 0.2 % of visible power below 500 nm) or broad_amber",
    "excluded": "fluorescent tubes and LEDs with |Duv| > 0.02 or CCT outside "
    "1000-25000 K are coloured: no level-2 class, never scored; led_rgb research "
    "mixes are their own class and never scored",
    "white_son": "HPS with CCT >= 2300 K: subtype white_son, NIR extension never "
    "flagged validated",
    "nir": "NIR column: lamps measured to 900 nm (LSPDD, photobiology, "
    "color-pollution, LI-1800), never extended; a class with 0 has no measured "
    "near-infrared (its extension is unvalidated)",
    "sets": "LSPDD (CC BY-NC-ND) is switchable: library(lspdd=False) or "
    "BANDOPT_LSPDD=0",
    "sufficient": "a level-2 class needs >= 3 distinct measured lamps to be scored",
}


def _plot(lib, rows, path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np

    from ._plots import save_figure

    groups = [g for g in dict.fromkeys(r["level2"] or "excluded" for r in rows)]
    n = len(groups)
    cols = 3
    fig, axes = plt.subplots(
        (n + cols - 1) // cols, cols, figsize=(13, 2.6 * ((n + 2) // 3)), sharex=True
    )
    for ax, g in zip(axes.flat, groups, strict=False):
        idx = [i for i, r in enumerate(rows) if (r["level2"] or "excluded") == g]
        for i in idx:
            v = lib.values[i]
            ax.plot(lib.wavelength_nm, v / np.nanmax(v), lw=0.7, alpha=0.7)
        ax.axvline(780, color="k", ls=":", lw=0.8)
        ax.set_title(f"{g} ({len(idx)})", fontsize=9)
    for ax in axes.flat[n:]:
        ax.axis("off")
    for ax in axes[-1]:
        ax.set_xlabel("wavelength [nm]")
    for ax in axes[:, 0]:
        ax.set_ylabel("spectral power\n(peak 1) [1]")
    fig.suptitle(
        "bandopt lamp library (peak-normalised; dotted: 780 nm, extension beyond)"
    )
    save_figure(fig, path, 110)


def run(args) -> int:
    from . import _cache
    from ._output import atomic_path, prepare_file, print_json

    if args.plot:
        prepare_file(args.plot, "--plot")
    cache_key = None
    if args.json and not args.plot:  # the listing alone: served from the cache
        opts = {"counts": args.counts, "no_extension": args.no_extension}
        cache_key = _cache.key("library", opts)
        text = _cache.load("library", cache_key)
        if text is not None:
            sys.stdout.write(text)
            return 0
    from ..datasets.lamps import library

    lib = library(extend_nir=not args.no_extension)
    rows = library_rows(lib)
    if args.plot:
        with atomic_path(args.plot) as tmp:
            _plot(lib, rows, tmp)
    counts = lib.counts()
    if args.json:
        out = {"counts": counts, "rules": RULES} if args.counts else rows
        if cache_key is not None:
            from ._output import dumps

            text = dumps(out) + "\n"
            _cache.store("library", cache_key, text)
            sys.stdout.write(text)
            return 0
        print_json(out)
        return 0
    if args.counts:
        print(
            f"{'level1':<13}{'level2':<22}{'lamps':>6}{'excl.':>6}{'CIE':>5}"
            f"{'NIR':>5}  status"
        )
        for c in counts:
            print(
                f"{c['level1']:<13}{c['level2'] or '-':<22}{c['lamps']:>6}"
                f"{c.get('excluded', 0):>6}{c['cie_typical']:>5}"
                f"{c.get('nir_measured', 0):>5}  {c['status']}"
            )
        n = sum(not r.modelled for r in lib.records)
        print(
            f"\n{n} distinct measured lamps ({len(lib.removed)} near-duplicates "
            f"removed), {len(lib) - n} modelled spectra (Planck: incandescent, fire); "
            f"sets: {', '.join(lib.source_sets)}."
        )
        print("Rules:")
        for k, v in RULES.items():
            print(f"  {k}: {v}")
        return 0
    print(
        f"{'id':<42}{'level2':<22}{'source':<11}{'ext':>4}{'LER':>7}{'G':>7}"
        f"{'CCT':>8}{'Duv':>8}"
    )
    for r in rows:
        print(
            f"{r['id'][:41]:<42}{(r['level2'] or '-'):<22}{r['source']:<11}"
            f"{'yes' if r['extended'] else 'no':>4}{r['LER']:7.1f}{r['G']:7.2f}"
            f"{r['CCT']:8.0f}{r['Duv']:8.4f}"
        )
    return 0
