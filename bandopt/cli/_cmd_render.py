"""`bandopt render`: render a road-lighting layout and see it at one or more GSDs."""

from ._options import add_list_option, bounded, gsd_type, seed_type
from ._output import add_locked_out


FIELD_OPTIONS = {
    "gsd_m": "--gsd",
    "mtf_nyquist": "--mtf-nyquist",
    "visibility_km": "--atmosphere VIS_KM",
}
"""Library argument names in error messages and the options that set them."""


def register(subparsers):
    p = subparsers.add_parser(
        "render",
        help="render a road-lighting layout to TOA radiance images at given GSDs",
        description=(
            "Render a road-lighting layout (a shipped name: single, single-sided, "
            "staggered, opposite, central-twin, mixed-led-hps; or a TOML/JSON file) "
            "analytically to top-of-atmosphere band radiance [W m-2 sr-1 nm-1] on a "
            "fine grid, then blur (Gaussian PSF, FWHM = 1 GSD unless --mtf-nyquist), "
            "box-average to each GSD, add photon noise and 14-bit quantisation "
            "(seeded) and detect single lamps with a Difference of Gaussians. "
            "Writes per GSD a float32 TIFF (bands x rows x columns), a PNG with the "
            "detections (+) and true lamps (o), and summary.json with precision, "
            "recall and F1. Adjacency effects are neglected."
        ),
    )
    p.add_argument(
        "--layout",
        required=True,
        metavar="NAME|FILE",
        help="shipped layout name or a TOML/JSON layout file",
    )
    add_list_option(
        p,
        "--gsd",
        type=gsd_type(),
        default=[10.0],
        metavar="M",
        help="ground sample distances [m]",
    )
    p.add_argument(
        "--bands",
        default="viirs-dnb",
        metavar="NAME|FILE",
        help="reference sensor name or band-set JSON (default viirs-dnb)",
    )
    add_locked_out(p)
    p.add_argument(
        "--dx",
        type=float,
        default=0.25,
        metavar="M",
        help="fine grid step in metres (default 0.25); GSDs must be multiples",
    )
    p.add_argument("--seed", type=seed_type(), default=0, help="noise seed")
    p.add_argument(
        "--no-noise", action="store_true", help="skip noise and quantisation"
    )
    p.add_argument(
        "--json",
        action="store_true",
        help="print summary.json on stdout (progress lines go to stderr)",
    )
    p.add_argument(
        "--mtf-nyquist",
        type=bounded(lo=0.0, hi=1.0, lo_open=True, hi_open=True, why="(MTF)"),
        default=None,
        help="PSF from its MTF at Nyquist instead of FWHM = GSD",
    )
    p.add_argument(
        "--atmosphere",
        nargs=3,
        default=None,
        metavar=("ATMOSPHERE", "AEROSOL", "VIS_KM"),
        help="6S table for T_up, e.g. midlatitude_summer urban 23 (default: none)",
    )
    p.add_argument(
        "--neighbourhood",
        default=None,
        metavar="NAME",
        help="adjacency: what the diffuse upward transmittance sees around the "
        "tile: lit_street_dark_district (default; k = 0.1 of the tile's mean), "
        "isolated (direct only) or uniform (total transmittance per pixel); "
        "only with --atmosphere",
    )
    p.add_argument(
        "--geotiff",
        action="store_true",
        help="also write per GSD a GeoTIFF of the TOA image (<stem>_toa.tif, "
        "float32, one band per band-set band, north up) and the truth map "
        "(<stem>_truth.tif: code of the lamp type giving most of each pixel's "
        "radiance, its share; codes in <stem>_truth.json), the input and the "
        "check of `bandopt map`",
    )
    p.add_argument(
        "--geo-origin",
        nargs=3,
        default=list(GEO_ORIGIN),
        metavar=("CRS", "EASTING", "NORTHING"),
        help="where --geotiff puts the scene: a projected CRS in metres and the "
        "map coordinates of its x = 0, y = 0 (x east, y north)",
    )
    p.set_defaults(func=run, field_options=FIELD_OPTIONS)


GEO_ORIGIN = ("EPSG:32632", "691000", "5335000")
"""Default `--geo-origin`: UTM zone 32N, Munich (the thesis' scenes)."""


def _bands(source: str):
    from ..sensor import load_band_set

    return load_band_set(source)


def check_lamps_inside(layout) -> None:
    """A lamp outside the rendered scene is a mistake in the layout, not a
    result (it would score as a missed lamp): refuse it, naming the lamp."""
    x_hi, y_half = layout.length_m, layout.width_m / 2
    for i, p in enumerate(layout.lamps):
        if not (0.0 <= p.x_m <= x_hi and -y_half <= p.y_m <= y_half):
            raise ValueError(
                f"layout {layout.name!r}: lamp {i + 1} ({p.lamp}) at x {p.x_m:g} m, "
                f"y {p.y_m:g} m lies outside the scene (x 0-{x_hi:g} m, "
                f"y {-y_half:g}-{y_half:g} m); move it or enlarge length_m/width_m."
            )


BYTES_PER_PIXEL_PER_IMAGE = 8
"""float64 images; the renderer holds about `n_bands + 3 n_lamp_types + 4`
images of the fine grid at once (illuminance, uplight and radiance per lamp
type, band radiance, surface index, sums)."""


def _available_bytes() -> int | None:
    try:
        with open("/proc/meminfo") as fh:
            for line in fh:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except OSError:
        pass
    return None


def check_memory(layout, dx_m: float, n_bands: int) -> None:
    """Refuse a fine grid whose images would not fit in the available memory
    (half of /proc/meminfo MemAvailable), before allocating anything."""
    nx = max(1, round(layout.length_m / dx_m))
    ny = max(1, round(layout.width_m / dx_m))
    n_types = len({p.lamp for p in layout.lamps})
    need = nx * ny * BYTES_PER_PIXEL_PER_IMAGE * (n_bands + 3 * n_types + 4)
    avail = _available_bytes()
    limit = avail // 2 if avail else 8 * 2**30
    if need > limit:
        raise ValueError(
            f"layout {layout.name!r}: {layout.length_m:g} m x {layout.width_m:g} m at "
            f"--dx {dx_m:g} m is a {nx} x {ny} pixel grid needing about "
            f"{need / 2**30:.3g} GiB (limit {limit / 2**30:.3g} GiB, half the "
            "available memory); use a larger --dx or a smaller layout."
        )


def run(args) -> int:
    import math
    import sys

    from ..spatial import load_layout
    from ._checks import coverage_check
    from ._output import OutputLock

    if not (args.dx > 0 and math.isfinite(args.dx)):
        raise ValueError(f"--dx {args.dx:g}: the fine grid step must be > 0 m.")
    layout = load_layout(args.layout)
    check_lamps_inside(layout)
    bands = _bands(args.bands)
    coverage_check(bands, source=args.bands, log=sys.stderr)
    atmosphere = None
    if args.atmosphere:
        a, aer, vis = args.atmosphere
        try:
            atmosphere = (a, aer, float(vis))
        except ValueError:
            raise ValueError(
                f"--atmosphere: visibility {vis!r} is not a number"
            ) from None
    if args.neighbourhood is not None and atmosphere is None:
        raise ValueError(
            f"--neighbourhood {args.neighbourhood}: the neighbourhood is what the "
            "diffuse upward transmittance sees, so it needs --atmosphere (without "
            "one there is no diffuse transmittance)."
        )
    if args.neighbourhood is not None:
        from ..scene import resolve_neighbourhood

        try:
            resolve_neighbourhood(args.neighbourhood)
        except ValueError as err:
            raise ValueError(f"--neighbourhood: {err}") from None
    for g in args.gsd:
        if g <= 0 or abs(g / args.dx - round(g / args.dx)) > 1e-6:
            raise ValueError(
                f"--gsd {g:g}: must be a positive multiple of --dx {args.dx:g}"
            )
    check_memory(layout, args.dx, len(bands.names))
    with OutputLock(args.out) as lock:
        return _render(args, layout, bands, atmosphere, lock.directory)


def _render(args, layout, bands, atmosphere, out) -> int:
    import sys

    import numpy as np

    from ..spatial import observe, render, true_targets
    from ._output import atomic_path, atomic_write_json, print_json, write_manifest

    log = sys.stderr if args.json else sys.stdout
    from ..scene import DEFAULT_NEIGHBOURHOOD

    scene = render(
        layout,
        bands,
        dx_m=args.dx,
        atmosphere=atmosphere,
        neighbourhood=args.neighbourhood or DEFAULT_NEIGHBOURHOOD,
    )
    truth = true_targets(scene)
    rows = []
    for g in args.gsd:
        obs = observe(
            scene,
            bands,
            g,
            seed=args.seed,
            noise=not args.no_noise,
            bit_depth=None if args.no_noise else 14,
            mtf_nyquist=args.mtf_nyquist,
        )
        stem = f"{layout.name}_gsd{g:g}m"
        with atomic_path(out / f"{stem}.tif") as tmp:
            _write_tiff(tmp, obs.image, obs.grid)
        if args.geotiff:
            _write_geotiffs(out, stem, scene, obs, args)
        with atomic_path(out / f"{stem}.png") as tmp:
            _plot(tmp, obs, truth, f"{layout.name}, GSD {g:g} m", scene.band_names)
        rows.append(
            {
                "gsd_m": g,
                **obs.score.as_dict(),
                "n_detected": int(obs.detections.xy_m.shape[0]),
                "threshold": obs.detections.threshold,
                "tiff": f"{stem}.tif",
                "png": f"{stem}.png",
            }
        )
        s = obs.score
        print(
            f"GSD {g:6g} m: precision {s.precision:.2f} recall {s.recall:.2f} "
            f"F1 {s.f1:.2f} ({s.tp} of {len(truth)} lamps, {s.fp} false)",
            file=log,
        )
    summary = {
        "layout": layout.describe(),
        "bands": list(scene.band_names),
        "lamp_flux_lm": scene.lamps.flux_lm.tolist(),
        "n_targets": len(truth),
        "fine_grid_m": args.dx,
        "render": scene.config,
        "results": rows,
        "peak_radiance_w_m2_sr_nm": float(np.max(scene.radiance)),
    }
    atomic_write_json(out / "summary.json", summary)
    write_manifest(
        out,
        seed=args.seed,
        config={
            "layout": args.layout,
            "gsd": args.gsd,
            "bands": args.bands,
            "dx": args.dx,
            "noise": not args.no_noise,
            "mtf_nyquist": args.mtf_nyquist,
            "atmosphere": atmosphere,
        },
    )
    if args.json:
        print_json(summary)
    print(f"wrote {out}", file=log if not args.json else sys.stderr)
    return 0


def _write_tiff(path, image, grid):
    import numpy as np
    import tifffile

    tifffile.imwrite(
        path,
        np.asarray(image, np.float32),
        photometric="minisblack",  # bands of radiance, never RGB
        metadata={
            "unit": "W m-2 sr-1 nm-1",
            "gsd_m": grid.dx_m,
            "x0_m": grid.x0_m,
            "y0_m": grid.y0_m,
            "axes": "band,y,x",
        },
    )


def _geo(args, grid):
    """(CRS, affine transform) of a north-up GeoTIFF of `grid` at `--geo-origin`."""
    from affine import Affine
    from rasterio.crs import CRS

    crs, e0, n0 = args.geo_origin
    try:
        crs, e0, n0 = CRS.from_user_input(crs), float(e0), float(n0)
    except (ValueError, TypeError) as exc:
        raise ValueError(f"--geo-origin {' '.join(args.geo_origin)}: {exc}") from None
    top = n0 + grid.y0_m + grid.ny * grid.dx_m
    return crs, Affine(grid.dx_m, 0.0, e0 + grid.x0_m, 0.0, -grid.dx_m, top)


def _write_geotiffs(out, stem, scene, obs, args) -> None:
    """`<stem>_toa.tif`, `<stem>_truth.tif` and `<stem>_truth.json` (see
    `--geotiff`); the truth is each lamp type's radiance through the same PSF
    and box average as the image, without noise."""
    import numpy as np

    from ..datasets.lamps import library
    from ..spatial import psf_sigma_m, resample_to_gsd
    from ._map_raster import write_geotiff
    from ._output import atomic_path, atomic_write_json

    crs, transform = _geo(args, obs.grid)
    with atomic_path(out / f"{stem}_toa.tif") as tmp:
        write_geotiff(tmp, obs.image[:, ::-1], crs, transform, scene.band_names)
    sigma = psf_sigma_m(obs.gsd_m, mtf_nyquist=args.mtf_nyquist)
    by_type = resample_to_gsd(scene.type_radiance, scene.grid.dx_m, obs.gsd_m,
                              sigma_m=sigma)  # fmt: skip
    total = by_type.sum(0)
    lit = total > 0
    code = np.where(lit, np.argmax(by_type, 0), -1).astype(float)
    share = np.where(lit, by_type.max(0) / np.where(lit, total, 1.0), np.nan)
    with atomic_path(out / f"{stem}_truth.tif") as tmp:
        write_geotiff(
            tmp, np.stack([code, share])[:, ::-1], crs, transform,
            ("lamp type code (-1: unlit)", "share of the pixel's radiance [1]"),
            nodata=-1.0,
        )  # fmt: skip
    recs = {r.id: r for r in library().records}
    atomic_write_json(out / f"{stem}_truth.json", {
        "codes": {
            i: {"lamp": t, "level1": recs[t].level1, "level2": recs[t].level2}
            if t in recs else {"lamp": t, "level1": None, "level2": None}
            for i, t in enumerate(scene.lamps.lamp_types)
        },
        "unlit": -1,
        "share": "the type's part of the pixel's band-summed radiance (its own "
        "light: ground and uplight, no adjacency term, no noise)",
    })  # fmt: skip


def _plot(path, obs, truth, title, band_names=()):
    """The mean of the bands (the image shown) on a square-root colour scale
    with its colour bar in radiance units, true lamps (o) and detections (+)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.colors import PowerNorm

    from ._plots import save_figure

    g = obs.grid
    ext = (g.x0_m, g.x0_m + g.nx * g.dx_m, g.y0_m, g.y0_m + g.ny * g.dx_m)
    fig, ax = plt.subplots(figsize=(11, 10 * g.ny / max(g.nx, 1) + 1.6))
    pan = obs.image.mean(axis=0)
    top = float(pan.max()) if float(pan.max()) > 0 else 1.0
    im = ax.imshow(
        pan,
        origin="lower",
        extent=ext,
        cmap="magma",
        norm=PowerNorm(0.5, vmin=0.0, vmax=top),
    )
    shown = (
        f"mean of {len(band_names)} bands ({', '.join(band_names)})"
        if len(band_names) > 1
        else f"band {band_names[0]}"
        if band_names
        else "band mean"
    )
    fig.colorbar(
        im,
        ax=ax,
        shrink=0.8,
        label=f"TOA radiance, {shown} [W m$^{{-2}}$ sr$^{{-1}}$ nm$^{{-1}}$] "
        "(square-root scale)",
    )
    ax.plot(truth[:, 0], truth[:, 1], "o", mfc="none", mec="cyan", ms=8, label="lamps")
    d = obs.detections.xy_m
    if d.size:
        ax.plot(d[:, 0], d[:, 1], "+", color="lime", ms=10, label="detected")
    s = obs.score
    ax.set_title(f"{title}: P {s.precision:.2f} R {s.recall:.2f} F1 {s.f1:.2f}")
    ax.set_xlabel("along road x [m]")
    ax.set_ylabel("across road y [m]")
    ax.legend(
        loc="upper left",
        bbox_to_anchor=(0.0, -0.12),
        ncols=2,
        fontsize=8,
        frameon=False,
    )
    save_figure(fig, path, 110)
