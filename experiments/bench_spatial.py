"""Benchmark the spatial renderer: analytic vs Monte Carlo at equal error, and
tile culling vs none.

Run:   python -m experiments.bench_spatial [--quick]
Writes results/bench/spatial.json.

1. **Analytic vs Monte Carlo (Mitsuba 3, `scalar_rgb`, CPU)** on one flat
   scene (an isotropic point light 8 m above a 40 m x 40 m Lambertian plane,
   40 x 40 pixels, box pixel filter). The reference is the closed form averaged
   over 32 x 32 points per pixel. The analytic renderer is timed with s x s
   supersampling (its error falls as 1/s²), Mitsuba with n samples per pixel
   (its error falls as 1/sqrt(n)); errors are RMS relative errors against the
   reference, and the Monte Carlo time needed to reach each analytic error is
   read off a fitted `error = a n^(-1/2)` law (time ∝ n). Timings exclude
   compilation (one warm-up call each). If Mitsuba is missing, this part
   records that and is skipped.
2. **Culling**: a staggered road of growing length (more lamps, same lamps per
   area) rendered with `cull_fraction` 1e-4 and 1e-3 and with none: the culled
   time grows with the area once the road is longer than the cut-off
   diameter, the unculled one with lamps x pixels (quadratically).
"""

import argparse
import json
import math
import time
from pathlib import Path

import numpy as np

from bandopt.strict_json import strict_dumps
from bandopt.timing import best_time


def analytic_vs_mc(quick: bool) -> dict:
    import bandopt.spatial as sp
    from bandopt.spatial import montecarlo

    h, flux, rho, ext, n = 8.0, 1000.0, 0.2, 40.0, 40
    intensity = flux / (2 * math.pi)
    kw = dict(
        intensity_cd=intensity, height_m=h, reflectance=rho, extent_m=ext, pixels=n
    )
    ref = montecarlo.analytic_point_light(supersample=32, **kw)
    lay = sp.Layout(
        "bench",
        (sp.LampPlacement(ext / 2, 0.0, h, "uniform", "cie_led_b3", flux),),
        length_m=ext,
        width_m=ext,
    )
    lamps = sp.lamp_arrays(lay)
    # the uniform table is normalised by the trapezoid rule; remove that 6e-6
    # constant so only the pixel-sampling error is measured
    norm = (
        float(np.asarray(lamps.luminaires[0].intensity_cd_per_lm)[0, 0]) * 2 * math.pi
    )

    analytic = []
    for s in (1, 2, 4, 8):
        grid = sp.scene_grid(lay, ext / n / s)

        def run(grid=grid, s=s):
            e = sp.illuminance_images(lamps, grid, cull_fraction=0.0)
            return sp.block_mean(np.asarray(e)[0], s) * rho / math.pi / norm

        t = best_time(run)
        err = float(np.sqrt(np.mean(((run() - ref) / ref) ** 2)))
        analytic.append({"supersample": s, "seconds": t, "rms_rel_error": err})

    out = {
        "scene": "isotropic point light, h = 8 m, 40 m x 40 m, 40 x 40 px",
        "analytic": analytic,
    }
    if not montecarlo.available():
        out["monte_carlo"] = "mitsuba not installed or no scalar_rgb variant: skipped"
        return out
    import mitsuba

    mc = []
    for spp in (4, 16, 64) if quick else (4, 16, 64, 256, 1024):
        t0 = time.perf_counter()
        img = montecarlo.render_point_light(spp=spp, seed=7, **kw)
        t = time.perf_counter() - t0  # includes scene loading (small)
        err = float(np.sqrt(np.mean(((img - ref) / ref) ** 2)))
        mc.append({"spp": spp, "seconds": t, "rms_rel_error": err})
    spp = np.array([m["spp"] for m in mc], float)
    errs = np.array([m["rms_rel_error"] for m in mc])
    secs = np.array([m["seconds"] for m in mc])
    a = float(np.exp(np.mean(np.log(errs * np.sqrt(spp)))))  # error = a spp^-1/2
    sec_per_spp = float(np.median(secs / spp))
    equal = []
    for r in analytic:
        need = (a / r["rms_rel_error"]) ** 2
        t_mc = need * sec_per_spp
        equal.append(
            {
                "rms_rel_error": r["rms_rel_error"],
                "analytic_s": r["seconds"],
                "mc_spp_needed": need,
                "mc_s_estimated": t_mc,
                "speedup": t_mc / r["seconds"],
            }
        )
    out.update(
        {
            "monte_carlo": mc,
            "mitsuba_version": mitsuba.__version__,
            "variant": "scalar_rgb",
            "mc_error_law": f"{a:.3g} / sqrt(spp)",
            "equal_error": equal,
        }
    )
    return out


def culling(quick: bool) -> dict:
    import bandopt.spatial as sp

    rows = []
    spacing, h = 30.0, 8.0
    for length in (250.0, 500.0, 1000.0) if quick else (250.0, 500.0, 1000.0, 2000.0):
        # a staggered road with lamps along its whole length (constant lamps per area)
        xs = np.arange(spacing / 4, length, spacing / 2)
        lamps_ = tuple(
            sp.LampPlacement(
                float(x),
                -2.5 if k % 2 == 0 else 2.5,
                h,
                "road-optic",
                "nist_traditional_hps",
                10000.0,
                0.0 if k % 2 == 0 else 180.0,
            )
            for k, x in enumerate(xs)
        )
        lay = sp.Layout("bench", lamps_, length_m=length, width_m=60.0)
        lamps = sp.lamp_arrays(lay)
        grid = sp.scene_grid(lay, 0.5)
        row = {"length_m": length, "n_lamps": len(lamps), "pixels": grid.nx * grid.ny}
        ref = None
        for label, f in (("unculled", 0.0), ("cull_1e-4", 1e-4), ("cull_1e-3", 1e-3)):

            def run(f=f, lamps=lamps, grid=grid):
                return sp.illuminance_images(
                    lamps, grid, cull_fraction=f
                ).block_until_ready()

            row[f"{label}_s"] = best_time(run, repeat=2)
            img = np.asarray(run()).sum(0)
            if ref is None:
                ref = img
            else:
                row[f"{label}_max_rel_error"] = float(
                    np.max(np.abs(img - ref)) / ref.max()
                )
        row["cull_radius_m"] = {
            "1e-4": float(sp.cull_radius_m(h, 1e-4)),
            "1e-3": float(sp.cull_radius_m(h, 1e-3)),
        }
        rows.append(row)
    return {
        "scene": "staggered road along its whole length, 15 m between lamps, "
        "road optic, h = 8 m, 0.5 m grid, 60 m wide",
        "rows": rows,
    }


def main(argv=None) -> int:
    import bandopt

    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--quick", action="store_true")
    p.add_argument("--out", default="results/bench/spatial.json")
    args = p.parse_args(argv)
    bandopt.configure()
    res = {
        "analytic_vs_monte_carlo": analytic_vs_mc(args.quick),
        "culling": culling(args.quick),
    }
    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(strict_dumps(res, indent=2) + "\n")
    print(json.dumps(res, indent=2))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
