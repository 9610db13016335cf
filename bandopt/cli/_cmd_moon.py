"""`bandopt moon`: the Moon's phase, position and ROLO spectral irradiance."""

import re

from ._options import add_place_options, bounded


FIELD_OPTIONS = {
    "lat_deg": "--lat",
    "lon_deg": "--lon",
    "local_time": "--overpass",
    "nights": "--nights",
    "first_date": "--date",
}
"""Library argument names in error messages and the options that set them."""


_REPORT_NM = (450.0, 550.0, 650.0, 850.0)


def register(subparsers):
    p = subparsers.add_parser(
        "moon",
        help="Moon phase, zenith, distances and ROLO irradiance for a date and place",
        description=(
            "Moon geometry from PyEphem (offline) and the ROLO lunar spectral "
            "irradiance at the top of the atmosphere (Kieffer & Stone 2005, ASTM G173 "
            "solar spectrum). --date YYYY-MM-DDTHH:MM is a UTC moment; --date "
            "YYYY-MM-DD is a local date and the Moon is taken at the satellite "
            "overpass time --overpass (local mean solar time, default 01:30). Phase "
            "angles outside ROLO's fitted 1.55-97 deg give no irradiance. Thesis "
            "Figure 3.3 (lunation 1194, Munich): "
            "bandopt moon --date 2019-07-02 --lat 48.14 --lon 11.58 --nights 30 "
            "--plot moon.png"
        ),
    )
    add_place_options(
        p,
        required=True,
        date_help="YYYY-MM-DD (local date, Moon at --overpass) or "
        "YYYY-MM-DDTHH:MM (UTC)",
        overpass_help="overpass local mean solar time for a date without time "
        "(default 01:30)",
    )
    p.add_argument(
        "--nights",
        type=bounded(int, lo=1, why="(nights)"),
        default=1,
        help="report/plot this many consecutive nights from --date (30: a lunation)",
    )
    p.add_argument("--json", action="store_true", help="print JSON instead of text")
    p.add_argument(
        "--plot", default=None, metavar="FILE", help="plot the spectra to FILE"
    )
    p.set_defaults(func=run, field_options=FIELD_OPTIONS)


def _check_last_night(first, nights: int) -> None:
    """Refuse, before any night is computed, a run whose last night lies
    beyond the calendar (`datetime.date.max`, 9999-12-31)."""
    import datetime as dt

    room = (dt.date.max - first).days + 1
    if nights > room:
        raise ValueError(
            f"--nights {nights}: from {first.isoformat()} the calendar ends after "
            f"{room} nights (on {dt.date.max.isoformat()}); give at most {room}."
        )


def _states(args):
    import datetime as dt

    from ..datasets import moon

    text = args.date.strip()
    if re.fullmatch(r"\d{4}-\d{2}-\d{2}", text):
        try:
            day = dt.date.fromisoformat(text)
        except ValueError:
            raise ValueError(f"--date {text!r} is not a valid calendar date.") from None
        _check_last_night(day, args.nights)
        return moon.moon_over_nights(
            day, args.lat, args.lon, args.overpass or "01:30", args.nights
        )
    if re.fullmatch(r"\d{4}-\d{2}-\d{2}[T ]\d{2}:\d{2}(:\d{2})?", text):
        if args.overpass is not None:
            raise ValueError(
                "--overpass applies to a date without time; --date already has a time."
            )
        try:
            when = dt.datetime.fromisoformat(text.replace(" ", "T"))
        except ValueError:
            raise ValueError(f"--date {text!r} is not a valid date and time.") from None
        _check_last_night(when.date(), args.nights)
        return tuple(
            moon.moon_state(when + dt.timedelta(days=k), args.lat, args.lon)
            for k in range(args.nights)
        )
    raise ValueError(f"--date must be YYYY-MM-DD or YYYY-MM-DDTHH:MM, got {text!r}.")


def _summary(state) -> dict:
    import math

    import numpy as np

    from ..datasets import moon
    from ..spectra import trapezoid_weights

    out = {
        "date_utc": state.date_utc.isoformat(timespec="minutes"),
        "phase": state.name,
        "phase_angle_deg": state.phase_angle_deg,
        "waxing": state.waxing,
        "illuminated_fraction": state.illuminated_fraction,
        "zenith_deg": state.zenith_deg,
        "azimuth_deg": state.azimuth_deg,
        "above_horizon": state.above_horizon,
        "moon_distance_km": state.moon_distance_km,
        "sun_distance_au": state.sun_distance_au,
        "sun_selenographic_lon_deg": state.sun_selenographic_lon_deg,
        "observer_selenographic_lat_deg": state.observer_lat_deg,
        "observer_selenographic_lon_deg": state.observer_lon_deg,
        "irradiance": None,
        "reason": None,
    }
    try:
        e = state.irradiance_toa(moon.GRID_1NM)
    except ValueError as err:
        out["reason"] = str(err)
        return out
    cos_z = max(math.cos(math.radians(state.zenith_deg)), 0.0)
    lx = float(moon.illuminance_lx(e, moon.GRID_1NM))
    q = np.asarray(trapezoid_weights(moon.GRID_1NM))
    out["irradiance"] = {
        "illuminance_toa_normal_lx": lx,
        "illuminance_toa_horizontal_lx": lx * cos_z,
        "irradiance_380_900nm_w_m2": float(e @ q),
        "spectral_w_m2_nm": {
            f"{w:g}": float(np.interp(w, moon.GRID_1NM, e)) for w in _REPORT_NM
        },
    }
    return out


def _print_text(s: dict, lat: float, lon: float) -> None:
    print(
        f"Moon {s['date_utc'].replace('T', ' ')} UTC at {lat:.3f}, {lon:.3f} (lat, lon)"
    )
    sense = "waxing" if s["waxing"] else "waning"
    print(
        f"  phase        {s['phase']} ({sense}), phase angle "
        f"{s['phase_angle_deg']:.2f} deg, {100 * s['illuminated_fraction']:.1f} % lit"
    )
    horizon = "above" if s["above_horizon"] else "below"
    print(
        f"  position     zenith {s['zenith_deg']:.2f} deg ({horizon} the horizon), "
        f"azimuth {s['azimuth_deg']:.1f} deg"
    )
    print(
        f"  distances    observer-Moon {s['moon_distance_km']:,.0f} km, "
        f"Sun-Moon {s['sun_distance_au']:.5f} AU"
    )
    print(
        f"  selenographic Sun lon {s['sun_selenographic_lon_deg']:.2f} deg, observer "
        f"lat {s['observer_selenographic_lat_deg']:.2f} lon "
        f"{s['observer_selenographic_lon_deg']:.2f} deg"
    )
    irr = s["irradiance"]
    if irr is None:
        print(f"  irradiance   none: {s['reason']}")
        return
    print(
        f"  TOA illuminance {irr['illuminance_toa_normal_lx']:.4g} lx normal to the "
        f"Moon, {irr['illuminance_toa_horizontal_lx']:.4g} lx horizontal"
    )
    spectral = ", ".join(f"{k} nm {v:.3g}" for k, v in irr["spectral_w_m2_nm"].items())
    print(f"  TOA spectral irradiance [W m-2 nm-1]: {spectral}")
    print(f"  TOA irradiance 380-900 nm {irr['irradiance_380_900nm_w_m2']:.4g} W m-2")


def _plot(states, path: str) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np

    from ..datasets import moon

    usable = [s for s in states if s.in_rolo_range and s.phase_angle_deg != 180.0]
    if not usable:
        raise ValueError(
            "--plot: no night has a phase angle within ROLO's fitted range "
            f"{moon.ROLO_PHASE_RANGE_DEG[0]:g}-{moon.ROLO_PHASE_RANGE_DEG[1]:g} deg: "
            "nothing to plot."
        )
    fig, ax = plt.subplots(figsize=(7.5, 4.5), layout="constrained")
    cmap = plt.get_cmap("viridis")
    for s in usable:
        colour = cmap(s.phase_angle_deg / moon.ROLO_PHASE_RANGE_DEG[1])
        label = (
            f"{s.date_utc:%Y-%m-%d %H:%M}, g={s.phase_angle_deg:.0f}° "
            f"{'wax' if s.waxing else 'wan'}"
        )
        ax.plot(
            moon.GRID_1NM,
            s.irradiance_toa(moon.GRID_1NM),
            color=colour,
            lw=1.0,
            label=label,
        )
    skipped = len(states) - len(usable)
    title = "ROLO lunar spectral irradiance at the top of the atmosphere"
    if skipped:
        title += (
            f"\n({skipped} of {len(states)} nights outside ROLO's 1.55-97° skipped)"
        )
    ax.set_title(title, fontsize=10)
    ax.set_xlabel("wavelength [nm]")
    ax.set_ylabel("irradiance [W m$^{-2}$ nm$^{-1}$]")
    ax.set_xlim(float(np.min(moon.GRID_1NM)), float(np.max(moon.GRID_1NM)))
    ax.set_ylim(bottom=0.0)
    if len(usable) <= 16:
        ax.legend(fontsize=7, ncols=2)
    else:
        sm = plt.cm.ScalarMappable(
            cmap=cmap, norm=plt.Normalize(0.0, moon.ROLO_PHASE_RANGE_DEG[1])
        )
        fig.colorbar(sm, ax=ax, label="phase angle [deg]")
    fig.savefig(path, dpi=150)
    plt.close(fig)


def run(args) -> int:
    from ._output import atomic_path, prepare_file, print_json

    if args.plot:
        prepare_file(args.plot, "--plot")
    states = _states(args)
    summaries = [_summary(s) for s in states]
    if args.json:
        print_json(summaries[0] if len(summaries) == 1 else summaries)
    else:
        for k, s in enumerate(summaries):
            if k:
                print()
            _print_text(s, args.lat, args.lon)
    if args.plot:
        with atomic_path(args.plot) as tmp:
            _plot(states, tmp)
        if not args.json:
            print(f"wrote {args.plot}")
    return 0
