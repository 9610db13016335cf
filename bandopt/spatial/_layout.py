"""Road-lighting layouts: where the lamps are, what they are, what lies around.

Coordinates: x along the road [m] (0 .. `length_m`), y across it [m] with the
road centre at y = 0 and the road between `-road_width_m/2` and
`+road_width_m/2`; a sidewalk strip of `sidewalk_width_m` on each side, then
the verge up to `±width_m/2`. A lamp's rotation turns its C0 plane from +x
towards +y: a lamp on the y < 0 side has rotation 0 (its C90 plane, the street
side of the optic, points across the road), on the y > 0 side 180.

Arrangements (thesis Figure 4.11): `single` (one lamp), `row` (one row at the
road edge = `single-sided`), `staggered` (both edges, shifted by half a
spacing), `opposite` (both edges, facing each other), `central-twin` (two
lamps back to back on a median pole at y = 0).

Layout files are TOML or JSON (same fields, see `bandopt/spatial/layouts/`):

    name = "single-sided"
    road_width_m = 7.0          # optional, defaults below
    length_m = 400.0
    width_m = 100.0
    [surfaces]                  # optional: road / sidewalk / verge types
    road = "asphalt"
    [arrangement]               # either an arrangement ...
    kind = "single-sided"
    spacing_m = 30.0
    mounting_height_m = 8.0
    luminaire = "road-optic"    # name or .ldt/.ies/.lop path (relative to file)
    lamps = ["nist_traditional_hps"]   # cycled along the arrangement
    flux_lm = 10000.0           # or lighting_class = "M3"
    [[lamp]]                    # ... and/or explicit lamps
    x_m = 10.0
    y_m = -3.0
    mounting_height_m = 8.0
    luminaire = "lambertian"
    lamp = "cie_led_b3"
    flux_lm = 5000.0
    rotation_deg = 0.0

Errors name the file and the field.
"""

import dataclasses
import json
import re
import tomllib
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from ..datasets.surfaces import resolve_surface
from ..names import canonical_key
from ..scene import class_illuminance_lx


ARRANGEMENTS = ("single", "single-sided", "staggered", "opposite", "central-twin")
LAYOUT_DIR = Path(__file__).parent / "layouts"
DEFAULT_LAMP = "nist_traditional_hps"


@dataclasses.dataclass(frozen=True)
class LampPlacement:
    """One luminaire in a layout.

    - `x_m`, `y_m`: position of the luminaire. [m]
    - `mounting_height_m`: height above the ground. [m]
    - `luminaire`: luminaire name or file path (see `bandopt.spatial.luminaire`).
    - `lamp`: lamp library id (spectrum).
    - `flux_lm`: luminaire output, or None to set from the lighting class. [lm]
    - `rotation_deg`: azimuth of the luminaire's C0 plane from +x. [deg]
    """

    x_m: float
    y_m: float
    mounting_height_m: float
    luminaire: str
    lamp: str
    flux_lm: float | None
    rotation_deg: float = 0.0


@dataclasses.dataclass(frozen=True)
class Layout:
    """A scene: road geometry, surfaces and lamps.

    - `lamps`: the placements.
    - `road_width_m`, `sidewalk_width_m`: widths. [m]
    - `length_m`, `width_m`: scene extent along (x from 0) and across (y centred). [m]
    - `surfaces`: surface types for `road`, `sidewalk`, `verge`.
    - `lighting_class`: EN 13201 class that sets the flux of lamps without
      `flux_lm` (average road illuminance, `bandopt.scene.class_illuminance_lx`).
    - `base_dir`: where relative luminaire paths are resolved.
    - `meta`: the arrangement parameters (for tables).
    """

    name: str
    lamps: tuple[LampPlacement, ...]
    road_width_m: float = 7.0
    sidewalk_width_m: float = 2.0
    length_m: float = 400.0
    width_m: float = 100.0
    surfaces: tuple[tuple[str, str], ...] = (
        ("road", "asphalt"),
        ("sidewalk", "sidewalk"),
        ("verge", "grass"),
    )
    lighting_class: str | None = None
    base_dir: str | None = None
    meta: tuple[tuple[str, object], ...] = ()

    def __post_init__(self):
        for f in ("road_width_m", "length_m", "width_m"):
            v = getattr(self, f)
            if not (isinstance(v, int | float) and v > 0):
                raise ValueError(f"Layout {self.name!r}: {f} must be > 0, got {v!r}.")
        if self.sidewalk_width_m < 0:
            raise ValueError(f"Layout {self.name!r}: sidewalk_width_m must be >= 0.")
        if not self.lamps:
            raise ValueError(f"Layout {self.name!r}: no lamps.")
        if any(p.flux_lm is None for p in self.lamps) and self.lighting_class is None:
            raise ValueError(
                f"Layout {self.name!r}: lamps without flux_lm need a lighting_class."
            )

    @property
    def surface_map(self) -> dict[str, str]:
        return dict(self.surfaces)

    @property
    def positions_m(self) -> np.ndarray:
        """(l, 2) lamp positions (x, y). [m]"""
        return np.array([(p.x_m, p.y_m) for p in self.lamps], float)

    def describe(self) -> dict:
        return {
            "name": self.name,
            "n_lamps": len(self.lamps),
            "road_width_m": self.road_width_m,
            "length_m": self.length_m,
            "width_m": self.width_m,
            "surfaces": self.surface_map,
            "lighting_class": self.lighting_class,
            **dict(self.meta),
        }


def _canon(kind: str) -> str:
    k = canonical_key(kind)
    table = {canonical_key(a): a for a in ARRANGEMENTS}
    table["row"] = "single-sided"
    table["singlesidedrow"] = "single-sided"
    table["twincentral"] = "central-twin"
    if k not in table:
        raise ValueError(
            f"Unknown arrangement {kind!r}; expected one of "
            f"{list(ARRANGEMENTS)} or 'row'."
        )
    return table[k]


def arrangement(
    kind: str,
    *,
    spacing_m: float = 30.0,
    mounting_height_m: float = 8.0,
    road_width_m: float = 7.0,
    overhang_m: float = 1.0,
    length_m: float = 400.0,
    width_m: float = 100.0,
    luminaire: str = "road-optic",
    lamps: Sequence[str] = (DEFAULT_LAMP,),
    flux_lm: float | None = 10000.0,
    lighting_class: str | None = None,
    sidewalk_width_m: float = 2.0,
    surfaces: dict | None = None,
    name: str | None = None,
) -> Layout:
    """A layout of one arrangement (thesis Fig. 4.11) centred along the road.

    Lamps stand `overhang_m` inside the road edge(s) every `spacing_m`,
    symmetric about the scene centre, over its central half (at least one
    spacing either side of the centre; about a quarter of `length_m` stays dark
    at each end, so the scene shows where the row ends). Lamp types cycle
    through `lamps`.
    `single` puts one lamp at the centre of the scene on the y < 0 edge.
    """
    kind = _canon(kind)
    if not spacing_m > 0 or not mounting_height_m > 0:
        raise ValueError("spacing_m and mounting_height_m must be > 0.")
    if not lamps:
        raise ValueError("`lamps` must name at least one lamp id.")
    edge = road_width_m / 2 - overhang_m
    xc = length_m / 2
    if kind == "single":
        xs = np.array([xc])
    else:
        n_half = max(int((length_m / 4) // spacing_m), 1)
        xs = xc + spacing_m * (np.arange(-n_half, n_half + 1))
    spots: list[tuple[float, float, float]] = []  # x, y, rotation
    if kind in ("single", "single-sided"):
        spots = [(x, -edge, 0.0) for x in xs]
    elif kind == "opposite":
        spots = [s for x in xs for s in ((x, -edge, 0.0), (x, edge, 180.0))]
    elif kind == "staggered":
        spots = [(x, -edge, 0.0) for x in xs] + [
            (x + spacing_m / 2, edge, 180.0) for x in xs[:-1]
        ]
    elif kind == "central-twin":
        spots = [s for x in xs for s in ((x, 0.5, 0.0), (x, -0.5, 180.0))]
    spots.sort(key=lambda s: (s[0], s[1]))
    placements = tuple(
        LampPlacement(
            float(x),
            float(y),
            float(mounting_height_m),
            luminaire,
            lamps[i % len(lamps)],
            flux_lm,
            rot,
        )
        for i, (x, y, rot) in enumerate(spots)
    )
    surf = {
        "road": "asphalt",
        "sidewalk": "sidewalk",
        "verge": "grass",
        **(surfaces or {}),
    }
    meta = (
        ("arrangement", kind),
        ("spacing_m", spacing_m),
        ("mounting_height_m", mounting_height_m),
        ("luminaire", luminaire),
        ("lamps", list(lamps)),
    )
    return Layout(
        name or kind,
        placements,
        road_width_m,
        sidewalk_width_m,
        length_m,
        width_m,
        tuple(surf.items()),
        lighting_class,
        None,
        meta,
    )


# -- files ---------------------------------------------------------------------


def _field(data: dict, key: str, label: str, kind, default=None, required=False):
    if key not in data:
        if required:
            raise ValueError(f"{label}: field {key!r} is missing.")
        return default
    v = data[key]
    if kind is float:
        if isinstance(v, bool) or not isinstance(v, int | float) or not np.isfinite(v):
            raise ValueError(f"{label}: field {key!r} must be a number, got {v!r}.")
        return float(v)
    if kind is str:
        if not isinstance(v, str):
            raise ValueError(f"{label}: field {key!r} must be a string, got {v!r}.")
        return v
    if kind is list:
        if isinstance(v, str):
            return [v]
        if not isinstance(v, list) or not all(isinstance(s, str) for s in v):
            raise ValueError(f"{label}: field {key!r} must be a list of strings.")
        return v
    if kind is dict:
        if not isinstance(v, dict):
            raise ValueError(f"{label}: field {key!r} must be a table.")
        return v
    raise TypeError(kind)


_TOP = {
    "name",
    "road_width_m",
    "sidewalk_width_m",
    "length_m",
    "width_m",
    "surfaces",
    "arrangement",
    "lamp",
    "lighting_class",
    "description",
}
_ARR = {
    "kind",
    "spacing_m",
    "mounting_height_m",
    "overhang_m",
    "luminaire",
    "lamps",
    "flux_lm",
    "lighting_class",
}
_LAMP = {
    "x_m",
    "y_m",
    "mounting_height_m",
    "luminaire",
    "lamp",
    "flux_lm",
    "rotation_deg",
}


def _unknown(data: dict, allowed: set, label: str):
    extra = sorted(set(data) - allowed)
    if extra:
        raise ValueError(
            f"{label}: unknown field(s) {extra}; allowed: {sorted(allowed)}."
        )


def layout_from_dict(data: dict, *, label: str = "<dict>", base_dir=None) -> Layout:
    """A layout from a parsed TOML/JSON object; errors name `label` and the field."""
    if not isinstance(data, dict):
        raise ValueError(f"{label}: the layout must be a table/object.")
    _unknown(data, _TOP, label)
    name = _field(data, "name", label, str, default=Path(label).stem)
    common = {
        k: _field(data, k, label, float, default=d)
        for k, d in (
            ("road_width_m", 7.0),
            ("sidewalk_width_m", 2.0),
            ("length_m", 400.0),
            ("width_m", 100.0),
        )
    }
    for k, v in common.items():
        if v < 0 or (v == 0 and k != "sidewalk_width_m"):
            raise ValueError(f"{label}: field {k!r} must be > 0, got {v!r}.")
    surfaces = _field(data, "surfaces", label, dict, default={})
    _unknown(surfaces, {"road", "sidewalk", "verge"}, f"{label}: surfaces")
    surf = {"road": "asphalt", "sidewalk": "sidewalk", "verge": "grass"}
    for k in surfaces:
        try:
            surf[k] = resolve_surface(_field(surfaces, k, f"{label}: surfaces", str))
        except ValueError as err:
            raise ValueError(f"{label}: surfaces.{k}: {err}") from None
    lclass = _field(data, "lighting_class", label, str)
    lamps: list[LampPlacement] = []
    meta: tuple = ()
    if "arrangement" in data:
        a = _field(data, "arrangement", label, dict)
        lab = f"{label}: arrangement"
        _unknown(a, _ARR, lab)
        kind = _field(a, "kind", lab, str, required=True)
        try:
            kind = _canon(kind)
        except ValueError as err:
            raise ValueError(f"{lab}: field 'kind': {err}") from None
        lclass = _field(a, "lighting_class", lab, str, default=lclass)
        flux = _field(a, "flux_lm", lab, float)
        if flux is None and lclass is None:
            raise ValueError(f"{lab}: give 'flux_lm' or 'lighting_class'.")
        built = arrangement(
            kind,
            spacing_m=_field(a, "spacing_m", lab, float, default=30.0),
            mounting_height_m=_field(a, "mounting_height_m", lab, float, default=8.0),
            overhang_m=_field(a, "overhang_m", lab, float, default=1.0),
            luminaire=_field(a, "luminaire", lab, str, default="road-optic"),
            lamps=_field(a, "lamps", lab, list, default=[DEFAULT_LAMP]),
            flux_lm=flux,
            lighting_class=lclass,
            road_width_m=common["road_width_m"],
            length_m=common["length_m"],
            width_m=common["width_m"],
        )
        lamps.extend(built.lamps)
        meta = built.meta
    for k, lamp in enumerate(data.get("lamp", [])):
        lab = f"{label}: lamp[{k}]"
        if not isinstance(lamp, dict):
            raise ValueError(f"{lab}: must be a table.")
        _unknown(lamp, _LAMP, lab)
        flux = _field(lamp, "flux_lm", lab, float)
        h = _field(lamp, "mounting_height_m", lab, float, required=True)
        if not h > 0:
            raise ValueError(
                f"{lab}: field 'mounting_height_m' must be > 0, got {h!r}."
            )
        if flux is not None and not flux > 0:
            raise ValueError(f"{lab}: field 'flux_lm' must be > 0, got {flux!r}.")
        lamps.append(
            LampPlacement(
                _field(lamp, "x_m", lab, float, required=True),
                _field(lamp, "y_m", lab, float, required=True),
                h,
                _field(lamp, "luminaire", lab, str, default="road-optic"),
                _field(lamp, "lamp", lab, str, default=DEFAULT_LAMP),
                flux,
                _field(lamp, "rotation_deg", lab, float, default=0.0),
            )
        )
    if not lamps:
        raise ValueError(
            f"{label}: no lamps: give an [arrangement] or [[lamp]] entries."
        )
    if any(p.flux_lm is None for p in lamps) and lclass is None:
        raise ValueError(f"{label}: lamps without 'flux_lm' need 'lighting_class'.")
    if lclass is not None:
        try:
            class_illuminance_lx(lclass)
        except ValueError as err:
            raise ValueError(f"{label}: field 'lighting_class': {err}") from None
    return Layout(
        name,
        tuple(lamps),
        common["road_width_m"],
        common["sidewalk_width_m"],
        common["length_m"],
        common["width_m"],
        tuple(surf.items()),
        lclass,
        None if base_dir is None else str(base_dir),
        meta,
    )


def read_layout(path) -> Layout:
    """Read a `.toml` or `.json` layout file (errors name the file and field)."""
    path = Path(path)
    label = str(path)
    try:
        raw = path.read_bytes()
    except OSError as err:
        raise ValueError(f"{label}: cannot read layout file ({err}).") from err
    try:
        if path.suffix.lower() == ".json":
            data = json.loads(raw)
        elif path.suffix.lower() == ".toml":
            data = tomllib.loads(raw.decode("utf-8"))
        else:
            raise ValueError(f"{label}: layout files must end in .toml or .json.")
    except (json.JSONDecodeError, tomllib.TOMLDecodeError, UnicodeDecodeError) as err:
        raise ValueError(f"{label}: cannot parse ({err}).") from err
    return layout_from_dict(data, label=label, base_dir=path.parent)


def layout_names() -> list[str]:
    """Names of the layouts shipped in `bandopt/spatial/layouts/`."""
    return sorted(p.stem for p in LAYOUT_DIR.glob("*.toml"))


def load_layout(name_or_path: str) -> Layout:
    """A shipped layout by name (ignoring case and separators) or a file path."""
    p = Path(name_or_path)
    if p.suffix.lower() in (".toml", ".json"):
        if not p.exists():
            raise ValueError(f"{p}: layout file not found.")
        return read_layout(p)
    key = re.sub(r"[\s_\-]+", "", name_or_path.lower())
    for stem in layout_names():
        if re.sub(r"[\s_\-]+", "", stem.lower()) == key:
            return read_layout(LAYOUT_DIR / f"{stem}.toml")
    raise ValueError(
        f"Unknown layout {name_or_path!r}; expected one of {layout_names()} or a "
        ".toml/.json file."
    )
