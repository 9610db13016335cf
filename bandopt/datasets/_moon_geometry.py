"""Where the Moon is, for a moment and place: angle, date and place checks,
the UTC moment of a local overpass time, and the Moon's topocentric
geometry from PyEphem (`Rhodes2011`, offline): phase angle [deg], zenith
[deg], azimuth [deg], distances [km], [AU] and the selenographic longitudes
and latitude [deg] ROLO needs (conventions in `bandopt.datasets.moon`).

Apart from `moon` (the ROLO irradiance and `MoonState`) because none of this
is photometry: it turns calendars and coordinates into angles, and `moon`
turns those angles into moonlight.
"""

import dataclasses
import datetime as dt
import math
import re

import ephem


def _wrap_deg(angle_deg: float) -> float:
    """Wrap an angle to (-180, 180]. [deg]"""
    wrapped = math.fmod(angle_deg + 180.0, 360.0)
    wrapped = wrapped + 360.0 if wrapped <= 0.0 else wrapped
    return wrapped - 180.0


def _finite(name: str, value: float) -> float:
    value = float(value)
    if not math.isfinite(value):
        raise ValueError(f"`{name}` must be finite, got {value}.")
    return value


def _as_utc(date_utc: dt.datetime) -> dt.datetime:
    if not isinstance(date_utc, dt.datetime):
        raise ValueError(
            f"`date_utc` must be a datetime, got {type(date_utc).__name__}."
        )
    if date_utc.tzinfo is not None:
        date_utc = date_utc.astimezone(dt.UTC).replace(tzinfo=None)
    return date_utc


def _check_place(lat_deg: float, lon_deg: float) -> tuple[float, float]:
    lat, lon = _finite("lat_deg", lat_deg), _finite("lon_deg", lon_deg)
    if not -90.0 <= lat <= 90.0:
        raise ValueError(f"`lat_deg` must be within -90..90, got {lat:g}.")
    if not -180.0 <= lon <= 360.0:
        raise ValueError(
            f"`lon_deg` must be within -180..360 (east positive), got {lon:g}."
        )
    return lat, _wrap_deg(lon)


@dataclasses.dataclass(frozen=True)
class EphemerisGeometry:
    """The Moon seen from one place at one moment, as `ephemeris_geometry`
    computes it (the fields of `moon.MoonState` of the same names; angles
    [deg], `moon_distance_km` [km], `sun_distance_au` [AU])."""

    phase_angle_deg: float
    waxing: bool
    zenith_deg: float
    moon_distance_km: float
    sun_distance_au: float
    sun_selenographic_lon_deg: float
    observer_lat_deg: float
    observer_lon_deg: float
    azimuth_deg: float


def ephemeris_geometry(
    when: dt.datetime, lat: float, lon: float, elevation_m: float
) -> EphemerisGeometry:
    """The Moon's geometry at UTC moment `when` (naive, from `_as_utc`) seen
    from geodetic `lat`, `lon` [deg] (from `_check_place`) at `elevation_m`
    [m], from PyEphem; the formulas are those `moon.moon_state` states."""
    observer = ephem.Observer()
    observer.lat, observer.lon = math.radians(lat), math.radians(lon)
    observer.elevation = _finite("elevation_m", elevation_m)
    observer.pressure = 0.0  # geometric altitude: no refraction
    observer.date = ephem.Date(when)
    moon, sun = ephem.Moon(observer), ephem.Sun(observer)

    km_per_au = ephem.meters_per_au / 1e3
    r_moon_km = float(moon.earth_distance) * km_per_au
    r_sun_km = float(sun.earth_distance) * km_per_au
    elongation = float(ephem.separation((moon.ra, moon.dec), (sun.ra, sun.dec)))
    phase = math.degrees(
        math.atan2(
            r_sun_km * math.sin(elongation), r_moon_km - r_sun_km * math.cos(elongation)
        )
    )
    sun_lon = _wrap_deg(90.0 - math.degrees(float(moon.colong)))
    obs_lat = math.degrees(float(moon.libration_lat))
    obs_lon = _wrap_deg(math.degrees(float(moon.libration_long)))
    waxing = _wrap_deg(sun_lon - obs_lon) > 0.0
    return EphemerisGeometry(
        phase_angle_deg=phase,
        waxing=waxing,
        zenith_deg=90.0 - math.degrees(float(moon.alt)),
        moon_distance_km=r_moon_km,
        sun_distance_au=float(moon.sun_distance),
        sun_selenographic_lon_deg=sun_lon,
        observer_lat_deg=obs_lat,
        observer_lon_deg=obs_lon,
        azimuth_deg=math.degrees(float(moon.az)),
    )


def _parse_local_time(local_time: str | dt.time) -> dt.time:
    if isinstance(local_time, dt.time):
        return local_time
    match = re.fullmatch(r"\s*(\d{1,2}):(\d{2})\s*", str(local_time))
    if not match or int(match[1]) > 23 or int(match[2]) > 59:
        raise ValueError(
            f"`local_time` must be 'HH:MM' (00:00-23:59), got {local_time!r}."
        )
    return dt.time(int(match[1]), int(match[2]))


def _parse_date(date: str | dt.date) -> dt.date:
    if isinstance(date, dt.datetime):
        raise ValueError(
            "`date` is a local calendar date; give a date, not a datetime."
        )
    if isinstance(date, dt.date):
        return date
    try:
        return dt.date.fromisoformat(str(date).strip())
    except ValueError:
        raise ValueError(f"`date` must be YYYY-MM-DD, got {date!r}.") from None


def overpass_utc(
    date: str | dt.date, lon_deg: float, local_time: str | dt.time = "01:30"
) -> dt.datetime:
    """UTC moment of `local_time` (local *mean* solar time) on local `date`. [datetime]

    `UTC = date + local_time - lon_deg / 15 h`: the mean-Sun clock that
    sun-synchronous orbits keep (the equation of time, up to ±16 min, is ignored).
    "01:30" on 2019-07-03 is the small hours after the evening of 2019-07-02.
    """
    day = _parse_date(date)
    clock = _parse_local_time(local_time)
    lon = _wrap_deg(_finite("lon_deg", lon_deg))
    return dt.datetime.combine(day, clock) - dt.timedelta(hours=lon / 15.0)
