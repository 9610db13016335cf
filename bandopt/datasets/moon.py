"""Moonlight: ROLO lunar spectral irradiance at the top of the atmosphere.

The Moon's disk-equivalent reflectance `A_k` comes from the ROLO model of
Kieffer & Stone (2005, Eq. 10 and Table 4, `Kieffer2005`) at its 32 band
wavelengths (350-2383.6 nm); the spectral irradiance is their Eq. 8,

    E(λ) = A(λ) · Ω_M · E_sun(λ) / π · (384400 km / d_moon)² · (1 AU / d_sun)²,

with `Ω_M = 6.4177e-5 sr` and `E_sun` the ASTM G173-03 extraterrestrial solar
spectrum (`ASTMG173`, as shipped by pvlib, `Holmgren2018`).

How the pieces meet on a working grid (e.g. `GRID_1NM`):

- `ln A` is interpolated *linearly in wavelength* between the ROLO band
  centres. Wavelengths below 350 nm or above 2383.6 nm raise `ValueError`
  (no extrapolation). ROLO's band-to-band scatter passes through unchanged:
  e.g. at 414.4 nm `A` is about 7 % below its 412.3 and 441.6 nm neighbours,
  which shows as a small notch; no smoothing is applied.
- The solar spectrum is averaged over each grid cell: G173 (0.5 nm steps below
  400 nm, 1 nm steps to 1700 nm) is read as a piecewise-linear function and
  integrated exactly over `[λ_i - Δ/2, λ_i + Δ/2]` (cell edges halfway between
  grid points, half a step beyond the end points), so band integrals keep the
  solar energy. On the 1 nm grid this is a mild 3-point smoothing
  (weights 1/8, 3/4, 1/8 of the 1 nm table). A single wavelength is
  interpolated, not averaged.
- Phase angles outside ROLO's fitted range, 1.55-97° (`ROLO_PHASE_RANGE_DEG`),
  raise `ValueError` saying so: no value rather than an extrapolated one.
  A `MoonState` at exactly 180° (the named new Moon) returns zeros instead:
  the lit hemisphere faces wholly away, illuminated fraction (1 + cos g)/2 = 0.

Checks (tests/test_moon.py): at 550 nm and mean distances ROLO gives 4.2e-6,
2.1e-6, 0.98e-6 and 0.40e-6 W m⁻² nm⁻¹ at g = 5, 30, 60, 90°, within 3-11 % of
Miller & Turner 2009 (`Miller2009`); the illuminance outside the atmosphere is
within 7 % of Krisciunas & Schaefer 1991 (`Krisciunas1991`) at those phases.

Sign convention: selenographic longitudes are positive east (IAU; Mare Crisium
at +59°). Waxing (evening Moon, first quarter) puts the Sun east of the
observer's sub-point, `Φ_sun - φ_obs ≈ +g`; waning `≈ -g`. With ROLO's
`b1 > 0` the waxing Moon is brighter, by up to about 13 % near 90°
(more maria are lit at last quarter).

Geometry for a date and place comes from PyEphem (`Rhodes2011`), offline:
topocentric phase angle, zenith angle (geometric, no refraction) and
observer-Moon distance; Sun-Moon distance; the Sun's selenographic longitude
from ephem's colongitude (`90° - colong`); the observer's selenographic
latitude/longitude from ephem's libration, which is *geocentric* (the
topocentric libration differs by up to about 1°, which changes ROLO's
libration terms by about 0.1 %).

The solar spectrum and the illuminance live in `_solar`, the ephemeris
geometry and the date, time and place checks in `_moon_geometry`; every
name is importable from here.
"""

import dataclasses
import datetime as dt
import math
from importlib import resources

import numpy as np
from jaxtyping import ArrayLike, Float

from ..names import canonical_key
from ..photometry import K_M_LM_PER_W as K_M_LM_PER_W
from ..spectra import GRID_1NM as GRID_1NM
from ._moon_geometry import (
    _as_utc,
    _check_place,
    _finite,
    _parse_date,
    _wrap_deg,
    ephemeris_geometry,
    overpass_utc,
)
from ._solar import _grid, illuminance_lx as illuminance_lx, solar_irradiance_toa


ROLO_PHASE_RANGE_DEG: tuple[float, float] = (1.55, 97.0)
"""Absolute phase angles covered by the ROLO fit (Kieffer & Stone 2005). [deg]"""

ROLO_C: tuple[float, float, float, float] = (
    0.00034115,
    -0.0013425,
    0.00095906,
    0.00066229,
)
"""Libration coefficients c1..c4 of K&S 2005 Eq. 10 (per degree of θ, φ). [1]"""

ROLO_P_DEG: tuple[float, float, float, float] = (4.06054, 12.8802, -30.5858, 16.7498)
"""Non-linear phase constants p1..p4 of K&S 2005 Eq. 10. [deg]"""

MOON_SOLID_ANGLE_SR = 6.4177e-5
"""Solid angle of the Moon at the standard distance 384 400 km, Ω_M. [sr]"""

MEAN_MOON_DISTANCE_KM = 384400.0
"""ROLO's standard observer-Moon distance. [km]"""


_ROLO_CSV = "rolo_kieffer_stone_2005_table4.csv"


def _load_rolo_table() -> np.ndarray:
    path = resources.files(__package__).joinpath("data", "moon", _ROLO_CSV)
    with path.open("r") as fh:
        table = np.loadtxt(fh, delimiter=",", skiprows=1)
    if table.shape != (32, 11):
        raise ValueError(
            f"{_ROLO_CSV}: expected 32 rows x 11 columns, got {table.shape}."
        )
    return table


_TABLE = _load_rolo_table()
ROLO_WAVELENGTH_NM: np.ndarray = _TABLE[:, 0].copy()
"""Centre wavelengths of the 32 ROLO bands. [nm]"""
_A, _B, _D = _TABLE[:, 1:5], _TABLE[:, 5:8], _TABLE[:, 8:11]


def _check_phase(phase_angle_deg: float) -> float:
    g = _finite("phase_angle_deg", phase_angle_deg)
    lo, hi = ROLO_PHASE_RANGE_DEG
    if not lo <= g <= hi:
        raise ValueError(
            f"phase_angle_deg={g:g} is outside the ROLO model's fitted range "
            f"{lo:g}-{hi:g} deg (Kieffer & Stone 2005): no lunar irradiance is "
            "returned there (below it the opposition surge, beyond it the crescent "
            "Moon, were not fitted)."
        )
    return g


def rolo_ln_reflectance(
    phase_angle_deg: float,
    *,
    waxing: bool = True,
    sun_selenographic_lon_deg: float | None = None,
    observer_lat_deg: float = 0.0,
    observer_lon_deg: float = 0.0,
) -> Float[np.ndarray, " 32"]:
    """ln of the disk-equivalent reflectance at the 32 ROLO bands (K&S 2005 Eq. 10). [1]

    **Arguments:**

    - `phase_angle_deg`: absolute phase angle g (Sun-Moon-observer), within
      `ROLO_PHASE_RANGE_DEG`, else `ValueError`. It enters the polynomial in
      radians and the exponential and cosine terms in degrees. [deg]
    - `waxing`: used only when `sun_selenographic_lon_deg` is None, which is then
      taken as `observer_lon_deg ± g` (+ waxing, - waning). [bool]
    - `sun_selenographic_lon_deg`: selenographic longitude of the Sun Φ, east
      positive; enters in radians. [deg]
    - `observer_lat_deg`, `observer_lon_deg`: selenographic latitude θ and
      longitude φ of the observer (the libration); enter in degrees. [deg]

    Wavelengths are `ROLO_WAVELENGTH_NM`.
    """
    g_deg = _check_phase(phase_angle_deg)
    theta = _finite("observer_lat_deg", observer_lat_deg)
    phi = _finite("observer_lon_deg", observer_lon_deg)
    if sun_selenographic_lon_deg is None:
        sun_lon_deg = _wrap_deg(phi + (g_deg if waxing else -g_deg))
    else:
        sun_lon_deg = _wrap_deg(
            _finite("sun_selenographic_lon_deg", sun_selenographic_lon_deg)
        )
    g = math.radians(g_deg)
    sun_lon = math.radians(sun_lon_deg)
    c1, c2, c3, c4 = ROLO_C
    p1, p2, p3, p4 = ROLO_P_DEG
    polynomial = _A @ np.array([1.0, g, g**2, g**3])
    sun_terms = _B @ np.array([sun_lon, sun_lon**3, sun_lon**5])
    libration = c1 * theta + c2 * phi + c3 * sun_lon * theta + c4 * sun_lon * phi
    nonlinear = _D @ np.array(
        [math.exp(-g_deg / p1), math.exp(-g_deg / p2), math.cos((g_deg - p3) / p4)]
    )
    return polynomial + sun_terms + libration + nonlinear


def lunar_irradiance_toa(
    phase_angle_deg: float,
    wavelength_nm: ArrayLike = GRID_1NM,
    *,
    waxing: bool = True,
    sun_selenographic_lon_deg: float | None = None,
    observer_lat_deg: float = 0.0,
    observer_lon_deg: float = 0.0,
    moon_distance_km: float = MEAN_MOON_DISTANCE_KM,
    sun_distance_au: float = 1.0,
) -> Float[np.ndarray, " w"]:
    """Lunar spectral irradiance at the top of the atmosphere, ROLO model. [W m⁻² nm⁻¹]

    Irradiance on a plane normal to the Moon's direction (multiply by
    cos(zenith) for a horizontal surface). `E = A Ω_M E_sun / π ·
    (384400 km / moon_distance_km)² · (1 AU / sun_distance_au)²` (K&S 2005
    Eq. 8), `A` from `rolo_ln_reflectance` interpolated linearly in
    wavelength of ln A, `E_sun` from `solar_irradiance_toa`.

    **Arguments:**

    - `phase_angle_deg`: absolute phase angle, 1.55-97°, else `ValueError`. [deg]
    - `wavelength_nm`: strictly increasing grid within 350-2383.6 nm. [nm]
    - `waxing`, `sun_selenographic_lon_deg`, `observer_lat_deg`,
      `observer_lon_deg`: see `rolo_ln_reflectance`. [bool], [deg]
    - `moon_distance_km`: observer-Moon distance. [km]
    - `sun_distance_au`: Sun-Moon distance. [AU]

    References: `Kieffer2005`, `ASTMG173`.
    """
    w = _grid(wavelength_nm)
    lo, hi = ROLO_WAVELENGTH_NM[0], ROLO_WAVELENGTH_NM[-1]
    if w[0] < lo or w[-1] > hi:
        raise ValueError(
            f"`wavelength_nm` spans {w[0]:g}-{w[-1]:g} nm; the ROLO model covers "
            f"{lo:g}-{hi:g} nm and is not extrapolated."
        )
    for name, value in (
        ("moon_distance_km", moon_distance_km),
        ("sun_distance_au", sun_distance_au),
    ):
        if not (math.isfinite(float(value)) and float(value) > 0.0):
            raise ValueError(f"`{name}` must be finite and > 0, got {value}.")
    ln_a = rolo_ln_reflectance(
        phase_angle_deg,
        waxing=waxing,
        sun_selenographic_lon_deg=sun_selenographic_lon_deg,
        observer_lat_deg=observer_lat_deg,
        observer_lon_deg=observer_lon_deg,
    )
    reflectance = np.exp(np.interp(w, ROLO_WAVELENGTH_NM, ln_a))
    distance = (MEAN_MOON_DISTANCE_KM / float(moon_distance_km)) ** 2 / float(
        sun_distance_au
    ) ** 2
    return (
        reflectance
        * (MOON_SOLID_ANGLE_SR / math.pi)
        * solar_irradiance_toa(w)
        * distance
    )


# --- Moon states: named phases and real geometry ------------------------------------

NAMED_PHASES: tuple[str, ...] = (
    "new",
    "waxing_crescent",
    "first_quarter",
    "waxing_gibbous",
    "full",
    "waning_gibbous",
    "last_quarter",
    "waning_crescent",
)
"""Canonical named phases, in order over a lunation."""

_NAMED_GEOMETRY: dict[str, tuple[float, bool]] = {
    "new": (180.0, True),
    "waxing_crescent": (135.0, True),
    "first_quarter": (90.0, True),
    "waxing_gibbous": (45.0, True),
    "full": (5.0, True),
    "waning_gibbous": (45.0, False),
    "last_quarter": (90.0, False),
    "waning_crescent": (135.0, False),
}
"""Named phase -> (phase angle [deg], waxing). Crescents (135°, a quarter lit
hemisphere of 15 %) lie outside ROLO's range: their irradiance raises. "full"
is 5°: a full-Moon night rarely comes below ROLO's 1.55° (only near eclipses)
and the phase angle changes by about 0.5° per hour."""

PHASE_ALIASES: dict[str, str] = {
    "crescent": "waxing_crescent",
    "gibbous": "waxing_gibbous",
    "third_quarter": "last_quarter",
}
"""Extra accepted names (matched ignoring case and separators)."""


_PHASE_LOOKUP = {canonical_key(n): n for n in NAMED_PHASES} | {
    canonical_key(alias): target for alias, target in PHASE_ALIASES.items()
}


def phase_name(phase_angle_deg: float, waxing: bool) -> str:
    """The named phase whose 45°-wide phase-angle interval holds `phase_angle_deg`."""
    g = abs(float(phase_angle_deg))
    if g <= 22.5:
        return "full"
    if g > 157.5:
        return "new"
    stem = "gibbous" if g <= 67.5 else "quarter" if g <= 112.5 else "crescent"
    if stem == "quarter":
        return "first_quarter" if waxing else "last_quarter"
    return f"{'waxing' if waxing else 'waning'}_{stem}"


@dataclasses.dataclass(frozen=True)
class MoonState:
    """The Moon as seen from one place: phase, position and distances.

    **Attributes:**

    - `name`: named phase (`NAMED_PHASES`), from `named_phase` or `phase_name`.
    - `phase_angle_deg`: absolute Sun-Moon-observer angle. [deg]
    - `waxing`: True before full Moon (Sun east of the observer's sub-point). [bool]
    - `zenith_deg`: Moon zenith angle (geometric); > 90 is below the horizon. [deg]
    - `moon_distance_km`: observer-Moon distance. [km]
    - `sun_distance_au`: Sun-Moon distance. [AU]
    - `sun_selenographic_lon_deg`: Sun's selenographic longitude, east positive;
      None for named phases (then `observer_lon ± g`). [deg]
    - `observer_lat_deg`, `observer_lon_deg`: observer's selenographic latitude
      and longitude (libration). [deg]
    - `azimuth_deg`: Moon azimuth, from north through east; None if unknown. [deg]
    - `date_utc`: the moment (naive, UTC); None for named phases.
    """

    name: str
    phase_angle_deg: float
    waxing: bool
    zenith_deg: float = 30.0
    moon_distance_km: float = MEAN_MOON_DISTANCE_KM
    sun_distance_au: float = 1.0
    sun_selenographic_lon_deg: float | None = None
    observer_lat_deg: float = 0.0
    observer_lon_deg: float = 0.0
    azimuth_deg: float | None = None
    date_utc: dt.datetime | None = None

    @property
    def illuminated_fraction(self) -> float:
        """Fraction of the visible disk that is lit, (1 + cos g) / 2. [1]"""
        return 0.5 * (1.0 + math.cos(math.radians(self.phase_angle_deg)))

    @property
    def above_horizon(self) -> bool:
        return self.zenith_deg < 90.0

    @property
    def in_rolo_range(self) -> bool:
        """True when ROLO gives a value (or the phase angle is 180°, zeros). [bool]"""
        lo, hi = ROLO_PHASE_RANGE_DEG
        return lo <= self.phase_angle_deg <= hi or self.phase_angle_deg == 180.0

    def irradiance_toa(
        self, wavelength_nm: ArrayLike = GRID_1NM
    ) -> Float[np.ndarray, " w"]:
        """TOA spectral irradiance normal to the Moon (`lunar_irradiance_toa`);
        zeros at a phase angle of exactly 180° (new Moon). [W m⁻² nm⁻¹]"""
        if self.phase_angle_deg == 180.0:
            return np.zeros(_grid(wavelength_nm).shape)
        return lunar_irradiance_toa(
            self.phase_angle_deg,
            wavelength_nm,
            waxing=self.waxing,
            sun_selenographic_lon_deg=self.sun_selenographic_lon_deg,
            observer_lat_deg=self.observer_lat_deg,
            observer_lon_deg=self.observer_lon_deg,
            moon_distance_km=self.moon_distance_km,
            sun_distance_au=self.sun_distance_au,
        )


def named_phase(name: str, zenith_deg: float = 30.0) -> MoonState:
    """A `MoonState` for a named phase at mean distances, no libration. [MoonState]

    `name` is one of `NAMED_PHASES` or `PHASE_ALIASES`, matched ignoring case
    and separators (`"First Quarter"`, `"first-quarter"`). Phase angles:
    new 180° (no moonlight: zero irradiance), crescents 135° (outside ROLO:
    irradiance raises), quarters 90°, gibbous 45°, full 5°.
    `zenith_deg` is the Moon's zenith angle. [deg]
    """
    canonical = _PHASE_LOOKUP.get(canonical_key(str(name)))
    if canonical is None:
        raise ValueError(
            f"Unknown Moon phase {name!r}; expected one of {list(NAMED_PHASES)} "
            f"(or aliases {sorted(PHASE_ALIASES)})."
        )
    g, waxing = _NAMED_GEOMETRY[canonical]
    return MoonState(canonical, g, waxing, zenith_deg=_finite("zenith_deg", zenith_deg))


def moon_state(
    date_utc: dt.datetime, lat_deg: float, lon_deg: float, *, elevation_m: float = 0.0
) -> MoonState:
    """The Moon at a moment and place, from PyEphem (offline). [MoonState]

    - `date_utc`: the moment; a naive datetime is UTC, an aware one is converted.
    - `lat_deg`, `lon_deg`: geodetic latitude, longitude east positive. [deg]
    - `elevation_m`: height above sea level. [m]

    Phase angle g from the topocentric Sun-Moon elongation ε and distances,
    `g = atan2(r_sun sin ε, r_moon - r_sun cos ε)`; zenith from ephem's
    topocentric altitude without refraction; `moon_distance_km` topocentric
    (ephem's `earth_distance` includes the observer's offset); `sun_distance_au`
    the Moon's heliocentric distance; selenographic geometry as in the module
    docstring. References: `Rhodes2011`.
    """
    when = _as_utc(date_utc)
    lat, lon = _check_place(lat_deg, lon_deg)
    g = ephemeris_geometry(when, lat, lon, elevation_m)
    return MoonState(
        name=phase_name(g.phase_angle_deg, g.waxing),
        phase_angle_deg=g.phase_angle_deg,
        waxing=g.waxing,
        zenith_deg=g.zenith_deg,
        moon_distance_km=g.moon_distance_km,
        sun_distance_au=g.sun_distance_au,
        sun_selenographic_lon_deg=g.sun_selenographic_lon_deg,
        observer_lat_deg=g.observer_lat_deg,
        observer_lon_deg=g.observer_lon_deg,
        azimuth_deg=g.azimuth_deg,
        date_utc=when,
    )


def moon_at_overpass(
    date: str | dt.date,
    lat_deg: float,
    lon_deg: float,
    local_time: str | dt.time = "01:30",
    *,
    elevation_m: float = 0.0,
) -> MoonState:
    """The Moon at a satellite overpass at local mean solar time `local_time`
    ("01:30" for VIIRS on Suomi-NPP, "21:30" for an early-evening orbit) on local
    date `date` (see `overpass_utc`). [MoonState]"""
    lat, _ = _check_place(lat_deg, lon_deg)
    when = overpass_utc(date, lon_deg, local_time)
    return moon_state(when, lat, lon_deg, elevation_m=elevation_m)


def moon_over_nights(
    first_date: str | dt.date,
    lat_deg: float,
    lon_deg: float,
    local_time: str | dt.time = "01:30",
    nights: int = 30,
) -> tuple[MoonState, ...]:
    """`moon_at_overpass` on `nights` consecutive local dates from `first_date`
    (a lunation is 29.5 days: thesis Figure 3.3). [tuple of MoonState]"""
    if int(nights) != nights or nights < 1:
        raise ValueError(f"`nights` must be a positive integer, got {nights!r}.")
    day = _parse_date(first_date)
    return tuple(
        moon_at_overpass(day + dt.timedelta(days=k), lat_deg, lon_deg, local_time)
        for k in range(int(nights))
    )
