"""Reference night-time sensors: a registry of published band sets.

Each entry cites its source (keys in `bandopt/datasets/references.bib`) and
says how published band edges became a response. Unless stated otherwise the
edges are read as the 50 % points of a super-Gaussian with k = 6 (thesis Eq.
2.15 default): centre = mean of the edges, FWHM = their difference.

The Table 1.1 sensors of the thesis (`DeMeester2019`, Table 1.1, whose own
sources are its refs. [18]-[25]) carry the thesis's GSD and bit depth.

**Beyond the data range.** The library grid is 380-900 nm. DMSP-OLS (to
1100 nm), Luojia 1-01 (to 980 nm) and the tabulated VIIRS DNB (whose table
itself stops at 899.5 nm) reach past it. Their band sets keep the published
edges (their parametrisation range is widened to hold them); on a 380-900 nm
grid the response is clipped to the grid and `fraction_outside(grid)` reports
the lost share of the response area. Nothing is silently renormalised:
`bands.band_average(..., outside="raise")` (the default) refuses such a band
and the caller chooses `"renormalise"` or `"zero"` knowingly.

Names are matched ignoring case and separators (`"VIIRS_DNB"` is
`viirs-dnb`); an unknown name raises `ValueError` listing the choices.
"""

import dataclasses
import json
import os
from collections.abc import Callable
from importlib.resources import files
from pathlib import Path

import numpy as np

from ..names import CanonicalMapping
from ._bands import DATA_RANGE_NM, Bands, BandSet, TabulatedBands


@dataclasses.dataclass(frozen=True)
class ReferenceSensor:
    """One registry entry.

    - `key`: canonical CLI name, e.g. `"viirs-dnb"`.
    - `title`: human-readable name.
    - `build`: returns the band set (built lazily; some need colour-science).
    - `gsd_m`: ground sample distance(s). [m]
    - `bit_depth`: radiometric resolution, or None if not given. [bit]
    - `detection_limit_w_m2_sr_nm`: or None. [W m-2 sr-1 nm-1]
    - `citations`: BibTeX keys.
    - `response_note`: how edges (or tables) became a response.
    - `note`: anything else (data range, reconstructions).
    """

    key: str
    title: str
    build: Callable[[], Bands]
    gsd_m: tuple[float, ...]
    bit_depth: int | None
    detection_limit_w_m2_sr_nm: float | None
    citations: tuple[str, ...]
    response_note: str
    note: str = ""

    @property
    def bands(self) -> Bands:
        return self.build()


_EDGE_NOTE = "published edges read as 50 % points of a super-Gaussian, k = 6"
_TABLE11 = "Edges, GSD and bit depth from the thesis Table 1.1."


def _edges(title: str, edges, names=None) -> Callable[[], BandSet]:
    edges = [tuple(map(float, e)) for e in edges]
    lo = min(DATA_RANGE_NM[0], min(e[0] for e in edges) - 1.0)
    hi = max(DATA_RANGE_NM[1], max(e[1] for e in edges) + 1.0)
    if names is None:
        names = ["PAN"] if len(edges) == 1 else [f"B{i + 1}" for i in range(len(edges))]

    def build() -> BandSet:
        return BandSet.from_edges(
            edges, 6.0, names=names, name=title, lower_nm=lo, upper_nm=hi
        )

    return build


def _viirs_tabulated() -> TabulatedBands:
    path = files("bandopt.sensor") / "data" / "viirs_dnb_relative_response.dat"
    with path.open("r") as fh:
        table = np.loadtxt(fh, skiprows=1)
    return TabulatedBands.from_table(
        table[:, 0],
        table[:, 1],
        names=["DNB"],
        name="VIIRS DNB (tabulated)",
        source_note="Illumina viirs.dat, 273-899.5 nm at 0.5 nm; 0 beyond 899.5 nm "
        "(the table is truncated while the response is still 0.147).",
    )


def _nightsat() -> TabulatedBands:
    # start-up time: colour takes ~1.5 s to import
    from colour.colorimetry import SDS_LEFS_PHOTOPIC, SDS_LEFS_SCOTOPIC

    tm = _edges(
        "Nightsat TM-like",
        [(450, 520), (520, 600), (630, 690), (760, 900)],
        ["TM1-blue", "TM2-green", "TM3-red", "TM4-nir"],
    )()
    eyes = []
    for label, sd in (
        ("photopic-V", SDS_LEFS_PHOTOPIC["CIE 1924 Photopic Standard Observer"]),
        ("scotopic-V'", SDS_LEFS_SCOTOPIC["CIE 1951 Scotopic Standard Observer"]),
    ):
        eyes.append(TabulatedBands.from_table(sd.wavelengths, sd.values, names=[label]))
    grid = np.arange(360.0, 1000.5, 1.0)
    return TabulatedBands.concatenate(
        [tm, *eyes],
        grid,
        name="Nightsat (Elvidge 2010 reconstruction)",
        source_note="TM-like bands: super-Gaussian k = 6 on the edges; V(λ) "
        "(CIE 1924, 360-830 nm) and V'(λ) (CIE 1951, 380-780 nm) from "
        "colour-science, 0 beyond their tables; all tabulated at 1 nm, 360-1000 nm.",
    )


_ENTRIES = (
    ReferenceSensor(
        "viirs-dnb",
        "NPP VIIRS Day/Night Band",
        _edges("VIIRS DNB", [(500, 900)], ["DNB"]),
        (742.0,),
        14,
        None,
        ("Miller2013", "DeMeester2019"),
        f"{_EDGE_NOTE}; edges 500-900 nm (Miller 2013's 0.5-0.9 µm; the thesis "
        "Table 1.1 lists 505-890 nm, the tabulated response has its half-maximum "
        "points at 501.5 and 878.5 nm).",
        "Support reaches the 900 nm data limit: with k = 6 about 3.5 % of the area "
        "lies beyond 900 nm (see fraction_outside).",
    ),
    ReferenceSensor(
        "viirs-dnb-tabulated",
        "NPP VIIRS Day/Night Band (tabulated response)",
        _viirs_tabulated,
        (742.0,),
        14,
        None,
        ("Miller2013", "Aube2018"),
        "tabulated relative response (Illumina viirs.dat, 0.5 nm), linearly "
        "interpolated; 0 outside the table.",
        "The table stops at 899.5 nm while the response is still 0.147 of the "
        "peak; the true near-infrared tail (~0.3 % of the area by linear "
        "extrapolation) is missing. Vendored in bandopt/sensor/data (GPL-3.0).",
    ),
    ReferenceSensor(
        "dmsp-ols",
        "DMSP Operational Linescan System",
        _edges("DMSP-OLS", [(400, 1100)]),
        (2700.0,),
        6,
        None,
        ("DeMeester2019",),
        f"{_EDGE_NOTE}.",
        f"{_TABLE11} The band reaches 1100 nm: on the 380-900 nm grid about 31 % "
        "of its area is lost (clipped, reported by fraction_outside).",
    ),
    ReferenceSensor(
        "sac-c",
        "SAC-C HSTC",
        _edges("SAC-C", [(450, 850)]),
        (300.0,),
        8,
        None,
        ("DeMeester2019",),
        f"{_EDGE_NOTE}.",
        _TABLE11,
    ),
    ReferenceSensor(
        "sac-d",
        "SAC-D HSC",
        _edges("SAC-D", [(450, 900)]),
        (200.0, 300.0),
        10,
        None,
        ("DeMeester2019",),
        f"{_EDGE_NOTE}.",
        f"{_TABLE11} Support reaches the 900 nm data limit.",
    ),
    ReferenceSensor(
        "cumulos",
        "CUMULOS",
        _edges("CUMULOS", [(400, 900)]),
        (133.0,),
        10,
        None,
        ("DeMeester2019",),
        f"{_EDGE_NOTE}.",
        f"{_TABLE11} Support reaches the 900 nm data limit.",
    ),
    ReferenceSensor(
        "luojia-1-01",
        "Luojia 1-01",
        _edges("Luojia 1-01", [(460, 980)]),
        (130.0,),
        12,
        None,
        ("DeMeester2019",),
        f"{_EDGE_NOTE}.",
        f"{_TABLE11} The band reaches 980 nm: clipped at 900 nm on the library "
        "grid, about 15 % of its area lost (reported by fraction_outside).",
    ),
    ReferenceSensor(
        "aerocube",
        "AeroCube (RGB)",
        _edges(
            "AeroCube", [(400, 512), (480, 590), (560, 850)], ["blue", "green", "red"]
        ),
        (120.0,),
        10,
        None,
        ("DeMeester2019",),
        f"{_EDGE_NOTE}.",
        _TABLE11,
    ),
    ReferenceSensor(
        "iss-dslr",
        "ISS astronaut DSLR photographs",
        _edges(
            "ISS DSLR", [(420, 500), (490, 585), (580, 640)], ["blue", "green", "red"]
        ),
        (10.0, 200.0),
        14,
        None,
        ("DeMeester2019",),
        f"{_EDGE_NOTE} (a Bayer filter is smoother than this).",
        _TABLE11,
    ),
    ReferenceSensor(
        "jilin-1-03b",
        "Jilin-1 03B",
        _edges(
            "Jilin-1 03B",
            [(430, 512), (489, 585), (580, 720)],
            ["blue", "green", "red"],
        ),
        (0.92,),
        8,
        None,
        ("DeMeester2019",),
        f"{_EDGE_NOTE}.",
        _TABLE11,
    ),
    ReferenceSensor(
        "eros-b",
        "EROS-B",
        _edges("EROS-B", [(500, 900)]),
        (0.65,),
        10,
        None,
        ("DeMeester2019",),
        f"{_EDGE_NOTE}.",
        f"{_TABLE11} Support reaches the 900 nm data limit.",
    ),
    ReferenceSensor(
        "sdgsat-1",
        "SDGSAT-1 Glimmer imager",
        _edges(
            "SDGSAT-1 Glimmer",
            [(450, 900), (430, 520), (520, 615), (615, 900)],
            ["PAN", "blue", "green", "red"],
        ),
        (10.0, 40.0),
        None,
        None,
        ("Guo2023",),
        f"{_EDGE_NOTE}.",
        "GSD 10 m panchromatic, 40 m colour bands. PAN and red reach the 900 nm "
        "data limit.",
    ),
    ReferenceSensor(
        "nightsat",
        "Nightsat concept (Elvidge et al. 2010 reconstruction)",
        _nightsat,
        (50.0, 100.0),
        None,
        2.5e-7,
        ("Elvidge2007", "Elvidge2010", "Mansencal2025"),
        "TM-like bands 450-520, 520-600, 630-690, 760-900 nm: "
        f"{_EDGE_NOTE}; photopic V(λ) and scotopic V'(λ) tabulated (colour-science).",
        "A reconstruction, not a flown sensor: Nightsat's GSD (50-100 m) and "
        "detection limit (2.5e-8 W cm-2 sr-1 µm-1 = 2.5e-7 W m-2 sr-1 nm-1) from "
        "Elvidge 2007; the band set is the Landsat-TM-like plus eye-response set "
        "Elvidge 2010 tested.",
    ),
)

REFERENCE_SENSORS: CanonicalMapping[ReferenceSensor] = CanonicalMapping(
    {e.key: e for e in _ENTRIES}, what="reference sensor"
)
"""Registry keyed by canonical name (`viirs-dnb`, `dmsp-ols`, ...); lookups
ignore case and separators (`bandopt.names.CanonicalMapping`)."""


def resolve(name: str) -> ReferenceSensor:
    """The registry entry for `name` (case and separators ignored)."""
    return REFERENCE_SENSORS[REFERENCE_SENSORS.resolve(name)]


def reference_sensor(name: str) -> Bands:
    """The band set of a reference sensor (`BandSet` or `TabulatedBands`)."""
    return resolve(name).build()


@dataclasses.dataclass(frozen=True)
class BandSetSource:
    """A band set and where it came from: `entry` (a reference sensor) or
    `path` (a band-set JSON file); the other is None. `key`: the key of a
    recommendation file the bands were read from ("spectral"), else None."""

    bands: Bands
    entry: ReferenceSensor | None
    path: Path | None
    key: str | None = None

    @property
    def label(self) -> str:
        """The registry key, or the file's stem."""
        return self.entry.key if self.entry is not None else self.path.stem


def resolve_band_set(source: str | os.PathLike) -> BandSetSource:
    """The one band-set loader: `source` is a band-set JSON file
    (`BandSet.from_json`; a name ending in `.json`, or any existing file), a
    recommendation file (`results/recommendation.json`: a top-level
    "spectral" key and no "bands"; its "spectral" band set) or a
    reference sensor name (`REFERENCE_SENSORS`, case and separators ignored).
    A missing file or an unknown name raises `ValueError` saying which."""
    path = Path(source)
    if path.is_dir():
        raise ValueError(
            f"{source}: is a folder; a band set is a JSON file or one of "
            f"{list(REFERENCE_SENSORS)}."
        )
    if str(source).lower().endswith(".json") or path.is_file():
        if not path.is_file():
            raise ValueError(
                f"{source}: no such band-set file (a band set is a JSON file or "
                f"one of {list(REFERENCE_SENSORS)})."
            )
        if path.suffix.lower() == ".json":
            try:
                data = json.loads(path.read_text())
            except (ValueError, UnicodeDecodeError):
                data = None  # the band-set loader names the problem
            if isinstance(data, dict) and "spectral" in data and "bands" not in data:
                from ..results import recommended_band_set  # the one reader

                return BandSetSource(
                    recommended_band_set("spectral", path=path), None, path, "spectral"
                )
        return BandSetSource(BandSet.from_json(path), None, path)
    entry = resolve(str(source))
    return BandSetSource(entry.build(), entry, None)


def load_band_set(source: str | os.PathLike) -> Bands:
    """`resolve_band_set(source).bands`: a band set from a reference sensor
    name or a band-set JSON file."""
    return resolve_band_set(source).bands


__all__ = [
    "REFERENCE_SENSORS",
    "BandSetSource",
    "ReferenceSensor",
    "load_band_set",
    "reference_sensor",
    "resolve",
    "resolve_band_set",
]
