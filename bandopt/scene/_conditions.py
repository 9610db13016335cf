"""What a scene is seen under besides lamp and surface: the EN 13201 lighting
classes and their illuminance (`class_illuminance_lx`), an atmosphere of the
6S tables (`AtmosphereSpec`) and the neighbourhood the diffuse transmittance
sees (`Neighbourhood`, the named `NEIGHBOURHOODS`, `DEFAULT_NEIGHBOURHOOD`).
Apart from the radiance model because the CLI, the spatial renderer and the
experiments use these without building a scenario set.
"""

import dataclasses
import math
from collections.abc import Mapping
from types import MappingProxyType

from ..names import CanonicalMapping


LIGHTING_CLASSES: Mapping[str, tuple[str, float]] = MappingProxyType(
    {
        **{
            f"P{i + 1}": ("illuminance_lx", v)
            for i, v in enumerate((15.0, 10.0, 7.5, 5.0, 3.0, 2.0))
        },
        **{
            f"C{i}": ("illuminance_lx", v)
            for i, v in enumerate((50.0, 30.0, 20.0, 15.0, 10.0, 7.5))
        },
        **{
            f"M{i + 1}": ("luminance_cd_m2", v)
            for i, v in enumerate((2.0, 1.5, 1.0, 0.75, 0.5, 0.3))
        },
    }
)
"""EN 13201-2:2015 lighting classes: P and C classes are average horizontal
illuminances [lx]; M classes are average road luminances seen by a driver
[cd m⁻²]. Reference `CEN2015`."""

Q0_DRY_R3_PER_SR = 0.07
"""Average luminance coefficient Q0 of the standard dry road surfaces R3/C2
[sr⁻¹]; 0.10 for R1/C1 (`CIE2001`)."""


def class_illuminance_lx(name: str, *, q0_per_sr: float = Q0_DRY_R3_PER_SR) -> float:
    """Average horizontal illuminance of an EN 13201 class; M classes via
    `E = L / Q0`. [lx]"""
    key = name.strip().upper()
    if key not in LIGHTING_CLASSES:
        raise ValueError(
            f"Unknown lighting class {name!r}; expected one of "
            f"{list(LIGHTING_CLASSES)}."
        )
    if not q0_per_sr > 0:
        raise ValueError(f"q0_per_sr must be > 0, got {q0_per_sr!r}.")
    kind, value = LIGHTING_CLASSES[key]
    return value if kind == "illuminance_lx" else value / q0_per_sr


@dataclasses.dataclass(frozen=True)
class AtmosphereSpec:
    """An atmosphere of the 6S tables, or `None` fields for no atmosphere."""

    atmosphere: str
    aerosol: str
    visibility_km: float

    @property
    def label(self) -> str:
        return f"{self.atmosphere}/{self.aerosol}/{self.visibility_km:g}km"


NO_ATMOSPHERE = "none"


@dataclasses.dataclass(frozen=True)
class Neighbourhood:
    """The ground around a pixel that the diffuse upward transmittance sees
    (the adjacency footprint: about 1 km for aerosol scattering, tens of km
    for Rayleigh; `Vermote1997`).

    - `lit_fraction`: fraction of its area lit by lamps like the pixel's;
      the rest is lit by the Moon only. [1]
    - `relative_illuminance`: mean illuminance of the lit part relative to the
      pixel's lighting class (1: lit to the same class). [1]
    - `surface`: its ground (a surface type), or None for the pixel's own.
    - `name`: a label for configs and reports.

    Only `k = lit_fraction x relative_illuminance` enters the lamp terms.
    `lit_fraction = relative_illuminance = 1` with the pixel's surface is the
    uniform neighbourhood (`NEIGHBOURHOODS["uniform"]`): total transmittance,
    the direct part is not computed at all.
    """

    lit_fraction: float = 1.0
    relative_illuminance: float = 1.0
    surface: str | None = None
    name: str = "custom"

    def __post_init__(self):
        if not 0.0 <= self.lit_fraction <= 1.0:
            raise ValueError(
                f"Neighbourhood lit_fraction must lie in [0, 1], got "
                f"{self.lit_fraction!r}."
            )
        if not (
            math.isfinite(self.relative_illuminance) and self.relative_illuminance >= 0
        ):
            raise ValueError(
                "Neighbourhood relative_illuminance must be finite and >= 0, got "
                f"{self.relative_illuminance!r}."
            )

    @property
    def lamp_factor(self) -> float:
        """`k`: the neighbourhood's mean lamp light relative to the pixel's. [1]"""
        return self.lit_fraction * self.relative_illuminance

    @property
    def is_uniform(self) -> bool:
        """Looks like the pixel: total transmittance, no direct part needed."""
        return (
            self.lit_fraction == 1.0
            and self.relative_illuminance == 1.0
            and self.surface is None
        )

    def to_dict(self) -> dict:
        return dataclasses.asdict(self)


NEIGHBOURHOODS: Mapping[str, Neighbourhood] = MappingProxyType(
    {
        "uniform": Neighbourhood(1.0, 1.0, None, "uniform"),
        "lit_street_dark_district": Neighbourhood(
            0.1, 1.0, None, "lit_street_dark_district"
        ),
        "isolated": Neighbourhood(0.0, 1.0, None, "isolated"),
    }
)
"""Named neighbourhoods. `uniform`: the total-transmittance model (coarse
pixels, a uniformly lit city; thesis section 2.4). `lit_street_dark_district`
: a street pixel at ~10 m GSD whose adjacency footprint is lit over 10 % of
its area at the same class, e.g. lit streets (10-20 m lit width) every
100-200 m with dark blocks between; a stated modelling choice, not a
measurement. Its lamp radiance is the `isolated` one times
`1 + 0.1 T_dif/T_dir`: +3.3 / +2.0 / +0.9 % at 450 / 550 / 800 nm
(mid-latitude summer, urban, 23 km; 6S total/direct 1.33 / 1.20 / 1.09) and
+9 / +6 / +3 % (tropical, urban, 5 km), against +33 / +20 / +9 % and
+91 / +61 / +29 % for `uniform`, so the choice of k in 0-0.1 matters little
and `uniform` a lot. `isolated`: nothing lit around the pixel (direct
transmittance only for lamp light)."""

DEFAULT_NEIGHBOURHOOD = "lit_street_dark_district"
"""Neighbourhood of `build_scenarios` by default: a lit street at the ~10 m
GSD this project recommends, in a dark district (k = 0.1). The thesis's
total-transmittance model (``neighbourhood="uniform"``) is right for coarse
pixels (VIIRS, 750 m) over a uniformly lit city; at 10-100 m GSD it
over-states lamp radiance by 9-91 % (6S total/direct), so it is not the
default."""


def resolve_neighbourhood(neighbourhood: "str | Neighbourhood") -> Neighbourhood:
    """A `Neighbourhood` from a name of `NEIGHBOURHOODS` (case and separators
    ignored) or itself."""
    if isinstance(neighbourhood, Neighbourhood):
        return neighbourhood
    names = CanonicalMapping(NEIGHBOURHOODS)  # the `bandopt.names` rule
    if neighbourhood not in names:
        raise ValueError(
            f"Unknown neighbourhood {neighbourhood!r}; expected one of "
            f"{list(NEIGHBOURHOODS)} or a `Neighbourhood`."
        )
    return names[neighbourhood]
