"""Assembly of the cached 6S runs into the shipped atmosphere tables.

`_assemble` reads every finished job of the work dir, builds the fast-run
tables (transmittances, their direct part, path reflectances, optical
depths), the off-nadir scattering reflectance and the reciprocity, direct
transmittance and atmosphere-type checks, and writes `TABLE_FILE` and
`META_FILE`. Apart from the 6S runs (`_atmosphere_sixs`) and the job plan and
command line (`_atmosphere_build`) so that no module of the build is over
~500 lines; it runs no 6S itself.
"""

import datetime
from pathlib import Path

import numpy as np

from ..strict_json import strict_dumps
from ._atmosphere_sixs import (
    DAY,
    GROUND_REFLECTANCE,
    MONTH,
    OFFNADIR_ATMOSPHERE,
    OFFNADIR_RELATIVE_AZIMUTH_DEG,
    OFFNADIR_VIEW_ZENITH_DEG,
    _job_name,
)


DATA_DIR = Path(__file__).resolve().parent / "data" / "atmosphere"
TABLE_FILE = "sixs_tables.npz"
META_FILE = "sixs_tables.json"


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
    (out / META_FILE).write_text(strict_dumps(meta, indent=1) + "\n")
