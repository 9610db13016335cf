"""The rasters of `bandopt map`: the input image checked (band count and
order, georeference, calibration of integer DN, nodata and NaN pixels),
read tile by tile, the output GeoTIFFs written tile by tile, and the tile
ledger that makes a run resumable.

Every error names the file, the field and the fix. rasterio is imported
by the functions (the CLI's start-up rule, `bandopt.cli`)."""

import contextlib
import dataclasses
import json
import os
import warnings
from pathlib import Path

import numpy as np

from ..strict_json import strict_dumps


NODATA = -9999.0
"""Nodata value of every output GeoTIFF (float32)."""

NO_TYPE = -1
"""Type code of an estimated pixel without a type (unexplained)."""

MASK_CODES = {0: "estimated", 1: "input nodata", 2: "NaN in a band", 3: "dark"}
"""Codes of `mask.tif`: why a pixel has no estimate (0: it has one)."""

OUTPUTS = {
    "LER": ("LER [lm W-1]", "LER lower 90 % [lm W-1]", "LER upper 90 % [lm W-1]"),
    "G": ("G [1]", "G lower 90 % [1]", "G upper 90 % [1]"),
    "CCT": ("CCT [K]", "CCT lower 90 % [K]", "CCT upper 90 % [K]"),
    "level1": ("level-1 type code", "level-1 type probability"),
    "level2": ("level-2 type code", "level-2 type probability"),
    "unexplained": ("unexplained (1) or explained (0)",),
    "mask": ("mask code (0 estimated, 1 input nodata, 2 NaN, 3 dark)",),
}
"""Output file stem -> its bands' descriptions. A null estimate of an
estimated pixel (CCT not meaningful, an unexplained pixel) is NaN; a
masked pixel is `NODATA` in every file but `mask.tif`."""


@contextlib.contextmanager
def quiet():
    """rasterio without its NotGeoreferencedWarning: `open_image` decides
    about a missing georeference itself (refused unless allowed)."""
    from rasterio.errors import NotGeoreferencedWarning

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", NotGeoreferencedWarning)
        yield


@dataclasses.dataclass(frozen=True)
class Image:
    """What `bandopt map` needs of its input GeoTIFF: `order[k]` the image
    band (0-based) of band-set band k, `gain`/`offset` (k,) turning its
    values into radiance [W m-2 sr-1 nm-1] (`gain * value + offset`),
    `nodata` (k,) the input's nodata per band-set band (NaN: none), and
    JSON-ready `notes` on how each was decided."""

    path: Path
    width: int
    height: int
    crs: object
    transform: object
    order: np.ndarray
    gain: np.ndarray
    offset: np.ndarray
    nodata: np.ndarray
    notes: dict


def _per_band(values, n: int, flag: str, path) -> np.ndarray:
    v = np.asarray(values, float)
    if v.size == 1:
        v = np.full(n, float(v[0]))
    if v.size != n or not np.all(np.isfinite(v)):
        raise ValueError(
            f"{flag} {','.join(f'{x:g}' for x in np.ravel(values))}: need one "
            f"finite value or one per band of {path} ({n})."
        )
    return v


def _order(src, path, names, band_order) -> tuple[np.ndarray, str]:
    names = list(names)
    if band_order:
        given = list(band_order)
        if sorted(given) != sorted(names):
            raise ValueError(
                f"--band-order {','.join(given)}: name each band of the band set "
                f"once ({', '.join(names)}), in the order of {path}'s bands."
            )
        return np.array([given.index(n) for n in names]), "--band-order"
    desc = [d or "" for d in src.descriptions]
    if sorted(desc) == sorted(names) and desc != names:
        return np.array([desc.index(n) for n in names]), "band descriptions"
    return np.arange(len(names)), "band-set order"


def open_image(
    path, names, *, band_order=None, gain=None, offset=None, allow_no_georef=False
) -> Image:
    """Check the GeoTIFF `path` for a band set with band `names` (see `Image`):
    one band per band-set band, a georeference (unless `allow_no_georef`),
    integer DN only with a calibration (`gain`/`offset`, one value or one
    per image band, else the GeoTIFF's band scales/offsets)."""
    import rasterio

    path = Path(path)
    if not path.is_file():
        raise ValueError(f"{path}: no such image file.")
    try:
        with quiet(), rasterio.open(path) as src:
            return _checked(src, path, names, band_order, gain, offset, allow_no_georef)
    except rasterio.errors.RasterioIOError as exc:
        raise ValueError(f"{path}: not a readable raster ({exc}).") from None


def _checked(src, path, names, band_order, gain, offset, allow_no_georef):
    n = len(names)
    if src.count != n:
        raise ValueError(
            f"{path}: band count {src.count}, but the band set has {n} bands "
            f"({', '.join(names)}); give an image with one band per band-set band."
        )
    order, order_from = _order(src, path, names, band_order)
    georef = src.crs is not None and not src.transform.is_identity
    if not georef and not allow_no_georef:
        raise ValueError(
            f"{path}: no georeference (CRS {src.crs}, transform "
            f"{'identity' if src.transform.is_identity else 'set'}); the maps "
            "could not be placed. Georeference the image, or add "
            "--allow-no-georef to map it in pixel coordinates."
        )
    dtype = np.dtype(src.dtypes[0])
    stored = not (all(s == 1.0 for s in src.scales) and not any(src.offsets))
    if gain is not None or offset is not None:
        g = _per_band(1.0 if gain is None else gain, n, "--gain", path)
        o = _per_band(0.0 if offset is None else offset, n, "--offset", path)
        calib = "--gain/--offset"
    elif stored:
        g, o = np.asarray(src.scales, float), np.asarray(src.offsets, float)
        calib = "the GeoTIFF's band scales/offsets"
    elif np.issubdtype(dtype, np.integer):
        raise ValueError(
            f"{path}: integer DN ({dtype}) without a calibration to radiance: "
            "give --gain G --offset O (radiance = G * DN + O, W m-2 sr-1 nm-1; "
            "one value or one per band), or store band scales/offsets in the "
            "GeoTIFF."
        )
    else:
        g, o, calib = np.ones(n), np.zeros(n), "none: the values are radiance"
    nod = np.array([np.nan if v is None else float(v) for v in src.nodatavals])
    return Image(
        path=path,
        width=src.width,
        height=src.height,
        crs=src.crs,
        transform=src.transform,
        order=order,
        gain=g[order],
        offset=o[order],
        nodata=nod[order],
        notes={
            "band_order": [src.descriptions[i] or f"band {i + 1}" for i in order],
            "band_order_from": order_from,
            "dtype": str(dtype),
            "calibration": calib,
            "gain": g[order].tolist(),
            "offset": o[order].tolist(),
            "georeferenced": georef,
            "crs": None if src.crs is None else src.crs.to_string(),
            "transform": list(src.transform)[:6],
        },
    )


def tiles(image: Image, size: int) -> list:
    """The windows of `size` x `size` pixels covering the image, row-major."""
    from rasterio.windows import Window

    return [
        Window(c, r, min(size, image.width - c), min(size, image.height - r))
        for r in range(0, image.height, size)
        for c in range(0, image.width, size)
    ]


def read_tile(image: Image, window, dark_below):
    """(radiance (h, w, k) [W m-2 sr-1 nm-1], mask code (h, w), see
    `MASK_CODES`) of one window: input nodata first, then NaN, then dark
    (every band below its `dark_below` (k,) [W m-2 sr-1 nm-1]; None: no band
    above 0)."""
    import rasterio

    with quiet(), rasterio.open(image.path) as src:
        raw = src.read([int(i) + 1 for i in image.order], window=window)
    raw = np.moveaxis(raw.astype(np.float64), 0, -1)
    code = np.zeros(raw.shape[:2], np.int8)
    hit = np.isfinite(image.nodata) & (raw == image.nodata)
    code[hit.any(-1)] = 1
    rad = image.gain * raw + image.offset
    code[(code == 0) & np.isnan(rad).any(-1)] = 2
    dark = rad <= 0.0 if dark_below is None else rad < np.asarray(dark_below)
    code[(code == 0) & dark.all(-1)] = 3
    return rad, code


def create_outputs(out: Path, image: Image) -> None:
    """The empty (all nodata) output GeoTIFFs of `OUTPUTS` in `out`: float32,
    the input's CRS and transform."""
    import rasterio

    profile = {
        "driver": "GTiff",
        "dtype": "float32",
        "width": image.width,
        "height": image.height,
        "crs": image.crs,
        "transform": image.transform,
        "nodata": NODATA,
    }
    for stem, desc in OUTPUTS.items():
        with (
            quiet(),
            rasterio.open(out / f"{stem}.tif", "w", count=len(desc), **profile) as dst,
        ):
            for i, d in enumerate(desc, 1):
                dst.set_band_description(i, d)


def write_tile(out: Path, window, planes: dict) -> None:
    """Write one window of every output (`planes[stem]` (bands, h, w)); each
    file is closed (flushed) before the tile is entered in the ledger."""
    import rasterio

    for stem, data in planes.items():
        with quiet(), rasterio.open(out / f"{stem}.tif", "r+") as dst:
            dst.write(np.asarray(data, np.float32), window=window)


class Ledger:
    """`tiles.jsonl` in the output folder: a header line (what the run maps:
    image, size, tiling, bands and options) and one line per finished tile
    with its pixel counts, appended and synced after the tile's data is on
    disk. A killed run keeps its finished tiles; `--resume` skips them."""

    NAME = "tiles.jsonl"

    def __init__(self, out: Path, header: dict, resume: bool):
        self.path = Path(out) / self.NAME
        self.header = json.loads(json.dumps(header))
        self.done: dict[int, dict] = {}
        if resume:
            self._read()
        elif self.path.exists():
            raise ValueError(
                f"{self.path.parent}: holds a map run ({self.NAME}); add --resume "
                "to finish it, or choose another --out."
            )
        else:
            self._write_line(self.header, mode="w")

    def _read(self) -> None:
        if not self.path.exists():
            raise ValueError(
                f"--resume: {self.path} does not exist; nothing to resume "
                "(run without --resume)."
            )
        lines = self.path.read_text().splitlines()
        try:
            head = json.loads(lines[0])
        except (IndexError, ValueError):
            raise ValueError(f"{self.path}: no readable header line.") from None
        diff = [k for k in self.header if head.get(k) != self.header[k]]
        if diff:
            raise ValueError(
                f"--resume: {self.path} was written for another "
                f"{', '.join(diff)}; rerun without --resume into a new --out."
            )
        for line in lines[1:]:
            try:
                rec = json.loads(line)
                self.done[int(rec["tile"])] = rec
            except (ValueError, KeyError, TypeError):
                continue  # a line cut by a kill: that tile is done again

    def _write_line(self, rec: dict, mode: str = "a") -> None:
        with open(self.path, mode) as fh:
            fh.write(strict_dumps(rec, indent=None) + "\n")
            fh.flush()
            os.fsync(fh.fileno())

    def record(self, tile: int, counts: dict) -> None:
        rec = {"tile": int(tile), **counts}
        self._write_line(rec)
        self.done[int(tile)] = rec


def write_geotiff(path, data, crs, transform, descriptions, nodata=None) -> None:
    """A float32 GeoTIFF of `data` (bands, rows, columns; row 0 the top) with
    `crs`, `transform` and one description per band."""
    import rasterio

    data = np.asarray(data, np.float32)
    with quiet(), rasterio.open(
        path, "w", driver="GTiff", dtype="float32", count=data.shape[0],
        height=data.shape[1], width=data.shape[2], crs=crs, transform=transform,
        nodata=nodata,
    ) as dst:  # fmt: skip
        dst.write(data)
        for i, d in enumerate(descriptions, 1):
            dst.set_band_description(i, str(d))
