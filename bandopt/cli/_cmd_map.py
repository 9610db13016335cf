"""`bandopt map`: a multi-band GeoTIFF to GeoTIFF maps of LER, G, CCT with
their 90 % intervals, level-1 and level-2 lamp type with probability and
the unexplained flag, tile by tile in bounded memory, resumable."""

from ._estimator_options import (
    add_estimator_options,
    obtain_fitted,
    prepare,
    read_prior_lamps,
    surface_of,
)
from ._options import add_list_option, add_place_options, bounded
from ._output import add_locked_out


FIELD_OPTIONS = {"lat_deg": "--lat", "lon_deg": "--lon", "local_time": "--overpass"}
"""Library argument names in error messages and the options that set them."""


def register(subparsers):
    p = subparsers.add_parser(
        "map",
        help="map LER, G, CCT and lamp type of every pixel of a GeoTIFF",
        description=(
            "Estimate LER, G index, CCT (with 90 %% intervals), level-1 and "
            "level-2 lamp type (with probability) and the unexplained flag for "
            "every pixel of a multi-band GeoTIFF of band radiance "
            "[W m-2 sr-1 nm-1], with the inversion of `bandopt evaluate` (same "
            "estimator options; --model MODEL from `bandopt fit`, else the "
            "fingerprinted cache). Writes float32 GeoTIFFs with the input's CRS "
            "and transform into --out (LER, G, CCT: estimate, lower, upper; "
            "level1, level2: code, probability, codes in classes.json; "
            "unexplained; mask: why a pixel has no estimate), map.json and "
            "manifest.json. Input nodata, NaN and dark pixels (every band below "
            "the detection limit) are masked and counted. Tile by tile: a "
            "killed run keeps its finished tiles, --resume finishes it."
        ),
    )
    p.add_argument("image", metavar="IMAGE", help="multi-band GeoTIFF")
    add_estimator_options(p)
    p.add_argument(
        "--model",
        metavar="MODEL",
        help="a fitted estimator written by `bandopt fit` (see evaluate --model)",
    )
    add_locked_out(p)
    add_list_option(
        p,
        "--band-order",
        metavar="NAME",
        default=None,
        default_help="the band descriptions when they name the band set's "
        "bands, else the band set's order",
        help="the band-set band name of each image band, in image order",
    )
    p.add_argument(
        "--tile",
        type=bounded(int, lo=16, why="(pixels)"),
        default=256,
        metavar="N",
        help="tile size [pixels]: the unit of reading, writing and resuming",
    )
    p.add_argument("--resume", action="store_true", help="skip finished tiles")
    p.add_argument(
        "--dark-below",
        type=bounded(lo=0.0, why="(radiance)"),
        default=None,
        metavar="L",
        help="a pixel is dark (masked) when every band is below L [image "
        "radiance unit after --gain/--offset]; default: the band set's "
        "detection limit, or, without one, no band above 0",
    )
    add_list_option(
        p,
        "--gain",
        type=float,
        metavar="G",
        default=None,
        default_help="none",
        help="radiance = G * DN + O: one gain or one per image band",
    )
    add_list_option(
        p,
        "--offset",
        type=float,
        metavar="O",
        default=None,
        default_help="none",
        help="the offset O of --gain: one or one per image band",
    )
    p.add_argument(
        "--allow-no-georef",
        action="store_true",
        help="map an image without CRS/transform (outputs in pixel coordinates)",
    )
    add_place_options(
        p,
        required=False,
        date_help="acquisition YYYY-MM-DDTHH:MM (UTC) or YYYY-MM-DD (with --overpass); "
        "with --lat/--lon the Moon is checked: the estimator knows moonless "
        "scenes, so a map with the Moon up is refused",
        overpass_help="overpass local mean solar time for --date without time",
    )
    p.add_argument("--json", action="store_true", help="print map.json")
    p.set_defaults(func=run, field_options=FIELD_OPTIONS)


def _moon(args) -> dict | None:
    """The Moon at --date/--lat/--lon, refused when it is up (the estimator
    was fitted on moonless scenes); None without a date."""
    import types

    from ._cmd_moon import _states

    given = [args.date is not None, args.lat is not None, args.lon is not None]
    if not any(given):
        return None
    if not all(given):
        raise ValueError("--date, --lat and --lon go together (the Moon's place).")
    (state,) = _states(
        types.SimpleNamespace(
            date=args.date, lat=args.lat, lon=args.lon, overpass=args.overpass, nights=1
        )
    )
    out = {
        "date_utc": state.date_utc.isoformat(timespec="minutes"),
        "above_horizon": bool(state.above_horizon),
        "illuminated_fraction": float(state.illuminated_fraction),
        "zenith_deg": float(state.zenith_deg),
    }
    if state.above_horizon:
        raise ValueError(
            f"--date {args.date}: the Moon is up (zenith {state.zenith_deg:.0f} deg, "
            f"{state.illuminated_fraction:.0%} lit); the estimator knows moonless "
            "scenes only and moonlit ground would bias every estimate."
        )
    return out


def _dark_rule(args, entry, source, names) -> dict:
    """The dark threshold per band-set band (`names` order) and where it came
    from: --dark-below, else the band set's detection limit (a reference
    sensor's, or a band-set file's `detection_limit_w_m2_sr_nm`, one value
    or {band: value} as `bandopt radiometry` gives it), else none."""
    import json
    from pathlib import Path

    import numpy as np

    if args.dark_below is not None:
        return {"below": [args.dark_below] * len(names), "from": "--dark-below"}
    limit = None if entry is None else entry.detection_limit_w_m2_sr_nm
    if limit is None and Path(source).is_file():
        data = json.loads(Path(source).read_text())  # read by --bands already
        limit = (
            data.get("detection_limit_w_m2_sr_nm") if isinstance(data, dict) else None
        )
    if isinstance(limit, dict):
        missing = [n for n in names if n not in limit]
        if missing:
            raise ValueError(
                f"--bands {source}: detection_limit_w_m2_sr_nm gives no limit for "
                f"band {', '.join(missing)}; give one per band or --dark-below."
            )
        limit = [limit[n] for n in names]
    if limit is not None:
        below = [
            float(x) for x in np.broadcast_to(np.asarray(limit, float), len(names))
        ]
        return {"below": below, "from": f"detection limit of --bands {source}"}
    return {"below": None, "from": "no detection limit known: no band above 0"}


def run(args) -> int:
    import numpy as np

    from ..estimators import Surface
    from ..sensor import resolve_band_set
    from ..spectra import GRID_1NM
    from ._map_raster import open_image
    from ._output import OutputLock

    bands, name, config, warnings = prepare(args)
    if args.estimator != "inversion":
        raise ValueError(
            f"--estimator {args.estimator}: map uses the inversion (lamp types "
            "with probabilities, the unexplained flag, chunked prediction)."
        )
    names = list(bands.names)
    image = open_image(
        args.image,
        names,
        band_order=args.band_order,
        gain=args.gain,
        offset=args.offset,
        allow_no_georef=args.allow_no_georef,
    )
    moon = _moon(args)
    dark = _dark_rule(args, resolve_band_set(args.bands).entry, args.bands, names)
    read_prior_lamps(args, warnings)
    refl, surface_label, mode, knowledge = surface_of(args, np.asarray(GRID_1NM))
    fitted, fp = obtain_fitted(args, bands, config, mode)
    surface = Surface(mode, knowledge if mode == "class" else None, refl)
    with OutputLock(args.out) as lock:
        return _map(
            args,
            image,
            fitted,
            fp,
            surface,
            lock.directory,
            {
                "bands": name,
                "band_names": names,
                "warnings": warnings,
                "moon": moon,
                "dark": dark,
                "surface": surface_label,
                "surface_knowledge": mode,
            },
        )


def _planes(res, n: int, labels1, labels2):
    """(13, n) output values of `n` estimated pixels (`OUTPUTS` order)."""
    import numpy as np

    from ._map_raster import NO_TYPE

    out = []
    for m in range(3):
        out += [res.estimate[:, m], res.interval90[:, m, 0], res.interval90[:, m, 1]]
    for called, labels, prob in (
        (res.level1, labels1, res.level1_probabilities),
        (res.level2, labels2, res.level2_probabilities),
    ):
        code = np.array([NO_TYPE if c is None else labels.index(c) for c in called])
        p = np.where(code >= 0, prob[np.arange(n), np.maximum(code, 0)], np.nan)
        out += [code, p]
    out.append(np.asarray(res.unexplained, float))
    return np.asarray(out, float)


def _map(args, image, fitted, fp, surface, out, info) -> int:
    import hashlib
    import json
    import sys

    import numpy as np

    from ._map_raster import (
        MASK_CODES,
        NO_TYPE,
        NODATA,
        OUTPUTS,
        Ledger,
        create_outputs,
        read_tile,
        tiles,
        write_tile,
    )
    from ._output import atomic_write_json, print_json, write_manifest
    from ._progress import Steps

    model = fitted.model
    step = model.predict_chunk_pixels()
    labels1, labels2 = (list(x) for x in model.type_labels())
    header = {
        "image": str(image.path.resolve()),
        "size": [image.height, image.width],
        "tile": args.tile,
        "bands": info["band_names"],
        "calibration": [image.gain.tolist(), image.offset.tolist()],
        "dark": info["dark"],
        "fingerprint": hashlib.sha256(
            json.dumps(fp, sort_keys=True).encode()
        ).hexdigest()[:16],
    }
    ledger = Ledger(out, header, args.resume)
    if not ledger.done:
        create_outputs(out, image)
    classes = {
        "level1": dict(enumerate(labels1)),
        "level2": dict(enumerate(labels2)),
        "no_type": NO_TYPE,
        "mask": MASK_CODES,
        "nodata": NODATA,
    }
    atomic_write_json(out / "classes.json", classes)
    windows = tiles(image, args.tile)
    skipped = sum(k in ledger.done for k in range(len(windows)))
    steps = Steps("bandopt map: tiles", len(windows), skipped=skipped)
    below = info["dark"]["below"]
    stems = list(OUTPUTS)
    for k, win in enumerate(windows):
        if k in ledger.done:
            continue
        rad, code = read_tile(image, win, below)
        h, w = code.shape
        planes = np.full((sum(len(OUTPUTS[s]) for s in stems[:-1]), h * w), NODATA)
        ok = np.flatnonzero(code.ravel() == 0)
        y = rad.reshape(h * w, -1)[ok]
        # every chunk the same size, the last padded with copies of a pixel
        # (results dropped): a chunk of a new size compiles a new program,
        # which stays in memory, and masks make every tile's remainder new
        y = np.concatenate([y, np.repeat(y[:1], -len(ok) % step, axis=0)])
        chunks = fitted.predict_chunks(y, surface, chunk_pixels=step) if len(ok) else ()
        for i0, res in chunks:
            idx = ok[i0 : i0 + step]
            vals = _planes(res, len(res.misfit), labels1, labels2)
            planes[:, idx] = vals[:, : len(idx)]
        split = np.cumsum([len(OUTPUTS[s]) for s in stems[:-1]])[:-1]
        data = dict(zip(stems[:-1], np.split(planes, split), strict=True))
        data = {s: v.reshape(-1, h, w) for s, v in data.items()}
        data["mask"] = code[None].astype(float)
        write_tile(out, win, data)
        counts = {
            MASK_CODES[c].replace(" ", "_"): int(np.sum(code == c)) for c in MASK_CODES
        }
        counts["unexplained"] = int(np.nansum(data["unexplained"] == 1))
        ledger.record(k, counts)
        steps.step(k + 1)
    totals = {
        key: sum(r[key] for r in ledger.done.values())
        for key in next(iter(ledger.done.values()))
        if key != "tile"
    }
    if totals["NaN_in_a_band"]:
        print(
            f"warning: {image.path}: {totals['NaN_in_a_band']} pixels with NaN in "
            "a band, masked (mask code 2)",
            file=sys.stderr,
        )
    summary = {
        "image": str(image.path),
        "out": str(out),
        "bands": info["bands"],
        "image_bands": image.notes,
        "pixels": image.width * image.height,
        "tiles": len(windows),
        "tiles_skipped_on_resume": skipped,
        "counts": totals,
        "dark": {**info["dark"], "unit": "W m-2 sr-1 nm-1 (after calibration)"},
        "moon": info["moon"]
        or "not checked (no --date/--lat/--lon): the estimator assumes no Moon",
        "surface": info["surface"],
        "surface_knowledge": info["surface_knowledge"],
        "estimator_description": fitted.description,
        "outputs": {f"{s}.tif": list(d) for s, d in OUTPUTS.items()},
        "classes": "classes.json",
        "nodata": NODATA,
        "warnings": info["warnings"],
    }
    atomic_write_json(out / "map.json", summary)
    write_manifest(
        out,
        config={
            "image": str(image.path),
            "bands": args.bands,
            "tile": args.tile,
            "fingerprint": fp,
            "model": args.model,
        },
    )
    if args.json:
        print_json(summary)
    else:
        print(
            f"wrote {out}: {totals['estimated']} of {summary['pixels']} pixels "
            f"estimated ({totals['dark']} dark, {totals['input_nodata']} nodata, "
            f"{totals['NaN_in_a_band']} NaN masked)"
        )
    return 0
