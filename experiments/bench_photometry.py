"""Benchmark: bandopt.photometry.metrics against a plain-NumPy baseline of the
same algorithm, a per-spectrum colour-science loop and luxpy (if installed).

Run:    python -m experiments.bench_photometry [--n-spectra 20000] [--n-colour 300]
Writes: results/bench/photometry.json

Workload, the same for all: for each spectrum LER (380-780 nm), LER over the
measured range, the G index and CCT/Duv by Ohno 2013. Spectra are random
mixtures of two lamps of the lamp library (or, without it, colour's NIST and
CIE 015 lamps at 1 nm), `a L_i + b L_j` with a, b ~ U(0, 1), times a scale
10^U(-3, 3) (seeded).

- bandopt, jitted: `jax.jit(lambda s: metrics(s, wl))` on all spectra at once,
  already on the device; compile time reported separately.
- bandopt, eager: `metrics(spectra, wl)` on the NumPy array, as users call it
  (host integrals, checks, transfer of the integrals, jitted rest).
- NumPy baseline (`_numpy_baseline`, written here): the same algorithm in plain
  vectorised NumPy, in chunks: one product with stacked trapezoid weights, the
  ratios, CIE 1960 (u, v) and Ohno's two-level nearest-row search (every 32nd
  row of colour's Planckian table, then ±32 rows) with the triangular or
  parabolic refinement. No NaN or scale handling (the spectra have none).
- colour-science (the reference implementation): a Python loop over a random
  subsample, caches cleared first (`colour.utilities.CACHE_REGISTRY`):
  `luminous_efficacy` twice, `sd_to_XYZ(method="Integration")` with the CMFs
  trimmed to 380-780 nm, `uv_to_CCT(method="Ohno 2013")`, and the G index as
  two `np.trapezoid` sums (colour has no G index). Extrapolated per spectrum.
- luxpy: timed only if importable; it is not a dependency of bandopt.

Every time is the best of `--repeats` rounds after a warm-up, all in one process,
the three batch methods interleaved within each round;
the ratios (baseline time / bandopt time) are the result, not the absolute times.
"""

import argparse
import dataclasses
import os
import platform
import subprocess
import sys
import time
import warnings
from pathlib import Path

import numpy as np

import bandopt
from bandopt.strict_json import strict_dumps


@dataclasses.dataclass(frozen=True)
class Config:
    n_spectra: int = 20_000
    n_colour: int = 300
    repeats: int = 3
    seed: int = 0
    output: str = "results/bench/photometry.json"


def _base_spectra() -> tuple[np.ndarray, np.ndarray, str]:
    try:
        from bandopt.datasets.lamps import library

        with warnings.catch_warnings():
            warnings.simplefilter("ignore", UserWarning)  # LI-1800 noise notes
            lib = library()
        return np.asarray(lib.wavelength_nm), np.asarray(lib.values), "lamp library"
    except ImportError:
        import colour
        from colour.colorimetry.datasets.light_sources import sds

        shape = colour.SpectralShape(380, 780, 1)
        sets = [
            sds.SDS_LIGHT_SOURCES_NIST_TRADITIONAL,
            sds.SDS_LIGHT_SOURCES_NIST_PHILIPS,
            sds.SDS_LIGHT_SOURCES_NIST_LED,
            {
                k: v
                for k, v in colour.SDS_ILLUMINANTS.items()
                if k.startswith(("FL", "HP", "LED-"))
            },
        ]
        values = [sd.copy().align(shape).values for d in sets for sd in d.values()]
        return np.arange(380.0, 781.0), np.stack(values), "colour NIST + CIE 015"


def _mixtures(base: np.ndarray, n: int, seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    i, j = rng.integers(0, base.shape[0], (2, n))
    a, b = rng.uniform(0.0, 1.0, (2, n, 1))
    scale = 10.0 ** rng.uniform(-3.0, 3.0, (n, 1))
    return scale * (a * base[i] + b * base[j])


def _interleaved(fns: dict, repeats: int) -> tuple[dict, dict]:
    """Every function once as a warm-up, then `repeats` rounds timing each
    once per round, so that a change of machine load hits them all alike.
    Returns the timings per name [s] and each function's last output."""
    outputs = {name: fn() for name, fn in fns.items()}
    runs = {name: [] for name in fns}
    for _ in range(repeats):
        for name, fn in fns.items():
            t0 = time.perf_counter()
            outputs[name] = fn()
            runs[name].append(time.perf_counter() - t0)
    return runs, outputs


def _numpy_baseline(wavelength_nm: np.ndarray, spectra: np.ndarray) -> dict:
    """THE BASELINE: bandopt's algorithm in plain NumPy (see the module doc)."""
    import colour  # the tables only: CIE V(λ) and CMFs, colour's Planckian table
    from colour.temperature.ohno2013 import planckian_table

    lef = colour.SDS_LEFS["CIE 1924 Photopic Standard Observer"]
    cmfs = colour.MSDS_CMFS["CIE 1931 2 Degree Standard Observer"]
    obs_nm, v_obs, cmf_obs = lef.wavelengths, lef.values, cmfs.values
    # colour's defaults, as bandopt: CMFs on 360-780 nm, 1000-100000 K, x1.001
    shape = colour.SpectralShape(360, 780, 1)
    planck = planckian_table(cmfs.copy().trim(shape), 1000.0, 100000.0, 1.001)
    wl = wavelength_nm

    def trapezoid(mask):
        q = mask.astype(float)
        q[np.flatnonzero(mask)[[0, -1]]] = 0.5
        return q

    v = np.interp(wl, obs_nm, v_obs, left=0.0, right=0.0)
    x, y, z = (
        np.interp(wl, cmfs.wavelengths, c, left=0.0, right=0.0) for c in cmf_obs.T
    )
    q_vis = trapezoid((wl >= 380) & (wl <= 780))
    q_blue = trapezoid((wl >= 380) & (wl <= 500))
    q_all = trapezoid(np.ones(wl.size, bool))
    columns = [q_vis, q_vis * v, q_vis * x, q_vis * y, q_vis * z, q_blue]
    w_t = np.stack([*columns, q_all, q_all * v])  # (8, w)
    t_k, t_u, t_v = planck.T
    coarse_u, coarse_v = t_u[::32], t_v[::32]
    last = t_k.size - 1

    def one_chunk(s):
        sums = (w_t @ s.T).T  # the faster operand order for BLAS
        ler, ler_full = 683.0 * sums[:, 1] / sums[:, 0], 683.0 * sums[:, 7] / sums[:, 6]
        ratio = sums[:, 5] / sums[:, 1]
        capped = ratio <= 1e-4
        g = np.where(capped, 10.0, -2.5 * np.log10(np.where(capped, 1.0, ratio)))
        den = sums[:, 2] + 15.0 * sums[:, 3] + 3.0 * sums[:, 4]
        u, vv = 4.0 * sums[:, 2] / den, 6.0 * sums[:, 3] / den
        near = np.argmin(
            (u[:, None] - coarse_u) ** 2 + (vv[:, None] - coarse_v) ** 2, axis=1
        )
        lo = np.clip(32 * near - 32, 0, last - 64)
        win = lo[:, None] + np.arange(65)
        near = lo + np.argmin(
            (u[:, None] - t_u[win]) ** 2 + (vv[:, None] - t_v[win]) ** 2, 1
        )
        mid = np.clip(near, 1, last - 1)
        k = np.stack([mid - 1, mid, mid + 1])  # previous, nearest, next row
        d = np.hypot(u - t_u[k], vv - t_v[k])
        span = np.hypot(t_u[k[2]] - t_u[k[0]], t_v[k[2]] - t_v[k[0]])
        along = (d[0] ** 2 - d[2] ** 2 + span**2) / (2.0 * span)
        frac = along / span
        cct_tri = t_k[k[0]] + (t_k[k[2]] - t_k[k[0]]) * frac
        side = np.sign(vv - (t_v[k[0]] + (t_v[k[2]] - t_v[k[0]]) * frac))
        duv_tri = np.sqrt(np.maximum(d[0] ** 2 - along**2, 0.0)) * side
        h_prev, h_next = t_k[k[0]] - t_k[k[1]], t_k[k[2]] - t_k[k[1]]
        slope_prev, slope_next = (d[0] - d[1]) / h_prev, (d[2] - d[1]) / h_next
        curv = (slope_next - slope_prev) / (h_next - h_prev)
        lin = slope_prev - curv * h_prev
        cct_par = t_k[k[1]] - lin / (2.0 * curv)
        duv_par = (d[1] - lin**2 / (4.0 * curv)) * side
        par = np.abs(duv_tri) >= 0.002
        cct = np.where(par, cct_par, cct_tri)
        duv = np.where(par, duv_par, duv_tri)
        flag = (
            (near == 0)
            | (near == last)
            | (np.abs(duv) > 0.05)
            | (cct < 1000.0)
            | (cct > 25000.0)
        )
        return ler, ler_full, g, capped, cct, duv, flag

    keys = ("LER", "LER_full_range", "G", "G_flag", "CCT", "Duv", "CCT_flag")
    parts = [one_chunk(s) for s in np.array_split(spectra, -(-len(spectra) // 2048))]
    return {k: np.concatenate([p[i] for p in parts]) for i, k in enumerate(keys)}


def _luxpy_loop(wavelength_nm: np.ndarray, spectra: np.ndarray) -> dict | None:
    """luxpy's LER and CCT/Duv (Ohno 2013) per spectrum, or None if absent."""
    try:
        import luxpy
    except ImportError:
        return None
    vis = (wavelength_nm >= 380) & (wavelength_nm <= 780)
    start = time.perf_counter()
    for s in spectra:
        spd = np.vstack([wavelength_nm[vis], s[vis]])
        luxpy.spd_to_ler(spd)
        luxpy.xyz_to_cct(luxpy.spd_to_xyz(spd), mode="ohno2014", out="cct,duv")
    return {"seconds": time.perf_counter() - start}


def _colour_loop(wavelength_nm: np.ndarray, spectra: np.ndarray) -> dict:
    import colour
    from colour.utilities import CACHE_REGISTRY, ColourRuntimeWarning

    vis = (wavelength_nm >= 380) & (wavelength_nm <= 780)
    blue = vis & (wavelength_nm <= 500)
    shape = colour.SpectralShape(380, 780, 1)
    cmfs = colour.MSDS_CMFS["CIE 1931 2 Degree Standard Observer"].copy().trim(shape)
    v_vis = colour.SDS_LEFS["CIE 1924 Photopic Standard Observer"][wavelength_nm[vis]]
    out = {k: [] for k in ("LER", "LER_full_range", "G", "CCT", "Duv")}
    CACHE_REGISTRY.clear_all_caches()
    start = time.perf_counter()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ColourRuntimeWarning)  # CCT < 1000 K
        for s in spectra:
            sd = colour.SpectralDistribution(s[vis], wavelength_nm[vis])
            measured = np.isfinite(s)
            sd_full = colour.SpectralDistribution(s[measured], wavelength_nm[measured])
            out["LER"].append(colour.luminous_efficacy(sd))
            out["LER_full_range"].append(colour.luminous_efficacy(sd_full))
            num = np.trapezoid(s[blue], wavelength_nm[blue])
            den = np.trapezoid(s[vis] * v_vis, wavelength_nm[vis])
            out["G"].append(-2.5 * np.log10(num / den) if num > 0 else np.inf)
            xyz = colour.sd_to_XYZ(sd, cmfs=cmfs, method="Integration")
            uv = colour.UCS_to_uv(colour.XYZ_to_UCS(xyz))
            cct, duv = colour.temperature.uv_to_CCT(uv, method="Ohno 2013")
            out["CCT"].append(cct)
            out["Duv"].append(duv)
    elapsed = time.perf_counter() - start
    return {"seconds": elapsed, **{k: np.asarray(v) for k, v in out.items()}}


def _machine() -> dict:
    import colour
    import jax

    cpu = platform.processor()
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    commit = subprocess.run(
        ["git", "rev-parse", "HEAD"], capture_output=True, text=True, check=False
    ).stdout.strip()
    return {
        "cpu": cpu,
        "cores": os.cpu_count(),
        "load_average_1_5_15": list(os.getloadavg()),
        "platform": platform.platform(),
        "python": sys.version.split()[0],
        "numpy": np.__version__,
        "jax": jax.__version__,
        "jax_backend": jax.default_backend(),
        "jax_x64": bool(jax.config.jax_enable_x64),
        "colour_science": colour.__version__,
        "bandopt": bandopt.__version__,
        "git_commit": commit or None,
    }


def main(config: Config) -> dict:
    bandopt.configure()
    import jax

    from bandopt.photometry import metrics

    wavelength_nm, base, base_name = _base_spectra()
    spectra = _mixtures(base, config.n_spectra, config.seed)

    n = config.n_spectra
    fn = jax.jit(lambda s: metrics(s, wavelength_nm))
    t0 = time.perf_counter()
    compiled = fn.lower(spectra).compile()
    compile_s = time.perf_counter() - t0
    device_spectra = jax.device_put(spectra)
    runs, outputs = _interleaved(
        {
            "bandopt_jit": lambda: jax.block_until_ready(compiled(device_spectra)),
            "bandopt_eager": lambda: jax.block_until_ready(
                metrics(spectra, wavelength_nm)
            ),
            "numpy_baseline": lambda: _numpy_baseline(wavelength_nm, spectra),
        },
        config.repeats,
    )
    result, base_out = outputs["bandopt_jit"], outputs["numpy_baseline"]
    jit_runs, eager_runs, numpy_runs = runs.values()
    jit_s, eager_s, numpy_s = (min(r) for r in runs.values())

    rng = np.random.default_rng(config.seed + 1)
    sub = rng.choice(n, config.n_colour, replace=False)
    ref = _colour_loop(wavelength_nm, spectra[sub])
    lux = _luxpy_loop(wavelength_nm, spectra[sub])

    per = {
        "bandopt_jit": jit_s / n,
        "bandopt_eager": eager_s / n,
        "numpy_baseline": numpy_s / n,
        "colour_science": ref["seconds"] / config.n_colour,
    }
    if lux is not None:
        per["luxpy"] = lux["seconds"] / config.n_colour
    ours_all = {k: np.asarray(v) for k, v in result.items()}
    ours = {k: v[sub] for k, v in ours_all.items()}
    ok = ~ours["CCT_flag"]
    ok_all = ~ours_all["CCT_flag"]

    def max_rel(key, mask=slice(None)):
        a, b = ours_all[key][mask], base_out[key][mask]
        return float(np.max(np.abs(a - b) / np.abs(b), initial=0.0))

    numpy_agreement = {
        **{f"{k}_max_rel": max_rel(k) for k in ("LER", "LER_full_range", "G")},
        "CCT_max_rel_meaningful": max_rel("CCT", ok_all),
        "Duv_max_abs_meaningful": float(
            np.max(np.abs(ours_all["Duv"] - base_out["Duv"])[ok_all], initial=0.0)
        ),
        "flags_equal": bool(
            np.array_equal(ours_all["CCT_flag"], base_out["CCT_flag"])
            and np.array_equal(ours_all["G_flag"], base_out["G_flag"])
        ),
    }
    agreement = {
        "LER_max_rel": float(np.max(np.abs(ours["LER"] / ref["LER"] - 1))),
        "LER_full_range_max_rel": float(
            np.max(np.abs(ours["LER_full_range"] / ref["LER_full_range"] - 1))
        ),
        "G_max_abs_unflagged": float(
            np.max(np.abs(ours["G"] - ref["G"])[~ours["G_flag"]], initial=0.0)
        ),
        "CCT_max_abs_K_meaningful": float(
            np.max(np.abs(ours["CCT"] - ref["CCT"])[ok], initial=0.0)
        ),
        "Duv_max_abs_meaningful": float(
            np.max(np.abs(ours["Duv"] - ref["Duv"])[ok], initial=0.0)
        ),
        "n_meaningful_CCT": int(ok.sum()),
        "note": "colour integrates XYZ with a rectangle sum, bandopt with the "
        "trapezoid: CCT differs by the half weight of the 380 and 780 nm samples",
    }
    return {
        "config": dataclasses.asdict(config),
        "workload": "LER (380-780 nm), LER over the measured range, G index, "
        "CCT and Duv (Ohno 2013) per spectrum",
        "spectra": {
            "base": base_name,
            "n_base": int(base.shape[0]),
            "n_wavelengths": int(wavelength_nm.size),
            "grid_nm": [float(wavelength_nm[0]), float(wavelength_nm[-1]), 1.0],
            "mixing": "scale * (a L_i + b L_j), a, b ~ U(0, 1), scale ~ 10^U(-3, 3)",
            "dtype": str(spectra.dtype),
        },
        "bandopt_jit": {
            "compile_s": compile_s,
            "run_s_all": jit_runs,
            "per_spectrum_s": per["bandopt_jit"],
            "n_spectra": n,
        },
        "bandopt_eager": {
            "run_s_all": eager_runs,
            "per_spectrum_s": per["bandopt_eager"],
            "n_spectra": n,
        },
        "numpy_baseline": {
            "run_s_all": numpy_runs,
            "per_spectrum_s": per["numpy_baseline"],
            "n_spectra": n,
            "chunk": 2048,
            "agreement_with_bandopt": numpy_agreement,
        },
        "colour_science": {
            "loop_s": ref["seconds"],
            "per_spectrum_s": per["colour_science"],
            "n_spectra": config.n_colour,
            "caches_cleared": "colour.utilities.CACHE_REGISTRY.clear_all_caches()",
        },
        "luxpy": (
            {"per_spectrum_s": per["luxpy"], "n_spectra": config.n_colour}
            if lux is not None
            else "not installed (not a dependency): not timed"
        ),
        "ratios_time_over_bandopt": {
            f"{other}_over_{mode}": per[other] / per[mode]
            for mode in ("bandopt_jit", "bandopt_eager")
            for other in per
            if not other.startswith("bandopt")
        },
        "goals": {
            "numpy_baseline_over_bandopt_at_least": 1.0,
            "bandopt_per_spectrum_s_target": 1e-6,
        },
        "agreement_with_colour_on_subsample": agreement,
        "machine": _machine(),
    }


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    for field in dataclasses.fields(Config):
        parser.add_argument(
            "--" + field.name.replace("_", "-"),
            type=type(field.default),
            default=field.default,
        )
    config = Config(**vars(parser.parse_args()))
    report = main(config)
    path = Path(config.output)
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(strict_dumps(report, indent=2) + "\n")
    per = {
        k: v["per_spectrum_s"]
        for k, v in report.items()
        if isinstance(v, dict) and "per_spectrum_s" in v
    }
    print(", ".join(f"{k} {v * 1e6:.2f} µs" for k, v in per.items()))
    print(report["ratios_time_over_bandopt"], f"Wrote {path}")
