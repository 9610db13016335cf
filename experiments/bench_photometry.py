"""Benchmark: bandopt.photometry.metrics vs a per-spectrum colour-science loop.

Run:    python -m experiments.bench_photometry [--n-spectra 100000] [--n-colour 300]
Writes: results/bench/photometry.json

Workload, the same for both: for each spectrum LER (380-780 nm), LER over the
measured range, the G index and CCT/Duv by Ohno 2013. Spectra are random
mixtures of two lamps of the lamp library (or, without it, colour's NIST and
CIE 015 lamps at 1 nm), `a L_i + b L_j` with a, b ~ U(0, 1), times a scale
10^U(-3, 3) (seeded).

- bandopt: `jax.jit(lambda s: metrics(s, wl))` on all spectra at once; compile
  time reported separately; best of `--repeats` runs after a warm-up.
- colour-science (the reference implementation): a Python loop over a random
  subsample, caches cleared first (`colour.utilities.CACHE_REGISTRY`):
  `luminous_efficacy` twice, `sd_to_XYZ(method="Integration")` with the CMFs
  trimmed to 380-780 nm, `uv_to_CCT(method="Ohno 2013")`, and the G index as
  two `np.trapezoid` sums (colour has no G index). Extrapolated per spectrum.
"""

import argparse
import dataclasses
import json
import os
import platform
import subprocess
import sys
import time
import warnings
from pathlib import Path

import numpy as np

import bandopt


@dataclasses.dataclass(frozen=True)
class Config:
    n_spectra: int = 100_000
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

    fn = jax.jit(lambda s: metrics(s, wavelength_nm))
    t0 = time.perf_counter()
    compiled = fn.lower(spectra).compile()
    compile_s = time.perf_counter() - t0
    device_spectra = jax.device_put(spectra)
    result = jax.block_until_ready(compiled(device_spectra))  # warm-up
    runs = []
    for _ in range(config.repeats):
        t0 = time.perf_counter()
        result = jax.block_until_ready(compiled(device_spectra))
        runs.append(time.perf_counter() - t0)
    bandopt_s = min(runs)

    rng = np.random.default_rng(config.seed + 1)
    sub = rng.choice(config.n_spectra, config.n_colour, replace=False)
    ref = _colour_loop(wavelength_nm, spectra[sub])

    per_bandopt = bandopt_s / config.n_spectra
    per_colour = ref["seconds"] / config.n_colour
    ours = {k: np.asarray(v)[sub] for k, v in result.items()}
    ok = ~ours["CCT_flag"]
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
        "bandopt": {
            "compile_s": compile_s,
            "run_s_best": bandopt_s,
            "run_s_all": runs,
            "per_spectrum_s": per_bandopt,
            "n_spectra": config.n_spectra,
        },
        "colour_science": {
            "loop_s": ref["seconds"],
            "per_spectrum_s": per_colour,
            "n_spectra": config.n_colour,
            "caches_cleared": "colour.utilities.CACHE_REGISTRY.clear_all_caches()",
        },
        "speedup_per_spectrum": per_colour / per_bandopt,
        "goal_speedup": 100.0,
        "agreement_on_subsample": agreement,
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
    path.write_text(json.dumps(report, indent=2) + "\n")
    print(
        f"bandopt {report['bandopt']['per_spectrum_s'] * 1e6:.2f} µs/spectrum "
        f"(compile {report['bandopt']['compile_s']:.2f} s), colour-science "
        f"{report['colour_science']['per_spectrum_s'] * 1e3:.2f} ms/spectrum: "
        f"{report['speedup_per_spectrum']:.0f}x faster. Wrote {path}"
    )
