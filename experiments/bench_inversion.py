"""Benchmark of the physics-based inversion: time per pixel, batched.

Run:   python -m experiments.bench_inversion [--quick]
Writes results/bench/inversion.json (+ inversion_manifest/manifest.json).

Inverts `N` pixels of the search scenario set (recommended bands when
`results/search/recommended_bands.json` exists, else 5 fixed bands) with the
inversion (prior: every scored and always-in-prior measured lamp; surface
unknown; 2 atmospheres + Moon when the 6S tables are installed) and with the
ridge baseline on the same pixels in the same run; reports seconds per pixel
and their ratio, and the same for the inversion whose prior also holds
same-class blends of its lamps (`mixture_lamps`, `MIX_PAIRS` pairs per class:
the default of `bandopt evaluate`), each with the Moon fitted and told (as
`bandopt evaluate` tells it), and that last one with each metric at its own
`σ_rel` (`metric_sigma`, `bandopt evaluate`'s default) against one `σ_rel`,
and the whole prior of `bandopt evaluate` (also the library's Planck
spectra, blends of two lamp types and shifted copies of its direct-emission
LEDs, `--planck on`, `--cross-mixtures 3`, `--peak-shifts on`) without and
with its `unexplained` test (each pixel also scored under every inner fold's
prior); and the library-free direct estimate (`bandopt
evaluate --estimator direct`, 26 contiguous bands, surface known) against
the ridge on the same bands and pixels. Compilation is excluded (a warm-up
call first).

Image scale (`image_scale`, sizes `--sizes`, default 1e3, 1e4 and 1e5
pixels): the estimator `bandopt evaluate` fits by default
(`estimators.InversionConfig`, surface unknown, told moonless) predicts each
size in a fresh process (its `Estimates`, in chunks of
`Inversion.predict_chunk_pixels()`), timed once after a warm-up on one
chunk plus the last chunk's size, with the ridge baseline on the same pixels
in the same process; peak resident memory is that process's `VmHWM` (forked
from a fresh forkserver) after the imports, after the warm-up and at the
end. `resource.getrusage`'s `ru_maxrss` is recorded too but is not this
run's: Linux keeps it across fork and exec, so it starts at the high-water
mark of the process that started the server (this one, after fitting).
The same pixels are then predicted with float32 scoring (`Inversion.predict(
dtype='float32')`, after its own warm-up; `peak_rss_mb_float64` is the peak
before it), then with pruned scoring (`prune=PRUNE_TOLERANCE`) in float64
and float32, each with its largest differences from the unpruned float64
prediction. The `exp`
floor is the time of the `exp` calls the scoring makes per pixel (counted
from the prior's, surface candidates' and atmospheres' sizes, the band-error
models and the flag's inner folds) done alone, in the same process.
"""

import argparse
import dataclasses
import json
import multiprocessing
import os
import pickle
import resource
import tempfile
import time
from pathlib import Path

import numpy as np

from bandopt.strict_json import strict_dumps
from bandopt.timing import best_time


METRIC_NOISE = ((0.01, 0.03), (0.03, 0.001), (0.03, 0.01))
"""(σ_rel, floor) of LER, G and CCT in the per-metric timing (typical
choices of the per-metric inversion on our bands' folds, `make study
NAME=estimate-noise`)."""
TYPES_NOISE = (0.03, 0.003)
"""(σ_rel, floor) of the types and flag in the per-metric timing."""


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--out", default="results/bench")
    ap.add_argument(
        "--sizes",
        default="1000,10000,100000",
        help="pixel counts of the image-scale runs, comma-separated ('' none)",
    )
    ap.add_argument(
        "--image-scale-only",
        action="store_true",
        help="run only the image-scale runs and replace that entry of an "
        "existing inversion.json (the other entries keep their run's numbers)",
    )
    args = ap.parse_args(argv)

    from bandopt import configure

    configure()
    import jax.numpy as jnp

    from bandopt import inversion as inv_mod
    from bandopt.estimate import fit_estimator
    from bandopt.provenance import write_manifest
    from bandopt.search import get_context
    from bandopt.sensor import BandSet

    rec = Path("results/search/recommended_bands.json")
    bands = (
        BandSet.from_json(rec)
        if rec.is_file()
        else BandSet.from_physical([450, 530, 600, 680, 820], [60, 60, 50, 60, 80])
    )
    ctx = get_context("quick" if args.quick else "search", None, 0, "auto")
    dest = Path(args.out)
    if args.image_scale_only:
        old = json.loads((dest / "inversion.json").read_text())
        old["image_scale"] = image_scale(
            ctx, bands, [int(float(x)) for x in args.sizes.split(",") if x]
        )
        old["image_scale"]["note"] = (
            "run alone (--image-scale-only); the other entries are from the "
            "previous full run"
        )
        (dest / "inversion.json").write_text(strict_dumps(old) + "\n")
        write_manifest(
            dest / "inversion_manifest",
            seed=0,
            config={"bench": "inversion", **vars(args)},
        )
        print(json.dumps(old["image_scale"], indent=2))
        return 0
    rad = ctx.radiance(bands)
    s = ctx.splits[0]
    t0 = time.perf_counter()
    inv = inv_mod.fit_for_context(ctx, bands, rad, s.train, s.inner)
    t_fit = time.perf_counter() - t0
    t0 = time.perf_counter()
    ridge = fit_estimator(rad, ctx.table, s.train, s.inner)
    t_fit_ridge = time.perf_counter() - t0
    n = min(rad.shape[0], 512 if args.quick else 4096)
    pix = rad[:n]
    t_inv = best_time(lambda: inv.predict(pix))
    x = jnp.asarray(pix)
    t_ridge = best_time(lambda: np.asarray(ridge.predict(x)))
    # the same inversion with same-class blends in its prior (`mixture_lamps`,
    # the default of `bandopt evaluate`): time grows with the prior's size
    lamps, always, _, _ = inv_mod.context_setup(ctx)
    pset = lamps.take(s.train) if always is None else lamps.take(s.train) + always
    inv_mix = inv_mod.build_inversion(
        pset + inv_mod.mixture_lamps(pset),
        inv.weights,
        inv.conditions,
        inv.basis,
        inv.surface_mode,
        inv.sigma_rel,
    )
    t_mix = best_time(lambda: inv_mix.predict(pix))
    # told each pixel's Moon brightness, as `bandopt evaluate` is
    moon = inv_mod.context_moon(ctx)[:n]
    t_told = best_time(lambda: inv.predict(pix, moon=moon))
    t_mix_told = best_time(lambda: inv_mix.predict(pix, moon=moon))
    # each metric under its own band-error model (`bandopt evaluate --sigma
    # per-metric`): three distinct (σ_rel, floor) models and the types' one,
    # as chosen on the folds of `make study NAME=estimate-noise` (METRIC_NOISE); one
    # scoring per distinct model
    inv_metric = dataclasses.replace(
        inv_mix,
        sigma_rel=TYPES_NOISE[0],
        sigma_floor=TYPES_NOISE[1],
        metric_sigma=tuple(x[0] for x in METRIC_NOISE),
        metric_floor=tuple(x[1] for x in METRIC_NOISE),
    )
    inv_joint = dataclasses.replace(inv_mix, sigma_rel=0.03)
    t_joint_told = best_time(lambda: inv_joint.predict(pix, moon=moon))
    t_metric_told = best_time(lambda: inv_metric.predict(pix, moon=moon))
    # `bandopt evaluate`'s whole prior: also the library's modelled
    # incandescent spectra (`--planck on`) and shifted copies of the direct
    # LEDs (`--peak-shifts on`)
    full = inv_mod.with_planck_lamps(pset, ctx.wavelength_nm)
    full = (
        full
        + inv_mod.mixture_lamps(full)
        + inv_mod.cross_mixture_lamps(full, inv_mod.CROSS_MIX_PAIRS)
        + inv_mod.shifted_lamps(full, ctx.wavelength_nm)
    )
    built = inv_mod.build_inversion(
        full, inv.weights, inv.conditions, inv.basis, inv.surface_mode
    )
    inv_default = dataclasses.replace(
        inv_metric, prior=built.prior, design=built.design
    )
    t_default = best_time(lambda: inv_default.predict(pix, moon=moon))
    # and its `unexplained` test: each pixel's misfit under every inner fold's
    # prior too (`Inversion.known_type_p_value`; the folds of the fit above)
    inv_flagged = dataclasses.replace(
        inv_default, flag_folds=inv.flag_folds, flag_noise=inv.flag_noise
    )
    t_flagged = best_time(lambda: inv_flagged.predict(pix, moon=moon))
    # the library-free direct estimate (`bandopt evaluate --estimator direct`)
    # needs contiguous bands: 26 x 20 nm, surface known, against the ridge on
    # the same bands and pixels (its JSON-ready rows, as evaluate makes them)
    from bandopt.direct import context_reflectance, fit_direct

    c26 = BandSet.contiguous(26)
    rad26 = ctx.radiance(c26)
    direct = fit_direct(ctx, c26, "class")
    refl = context_reflectance(ctx, "class")[:n]
    t_direct = best_time(lambda: direct.rows(rad26[:n], inv.conditions, refl, moon))
    ridge26 = fit_estimator(rad26, ctx.table, s.train, s.inner)
    x26 = jnp.asarray(rad26[:n])
    t_ridge26 = best_time(lambda: np.asarray(ridge26.predict(x26)))
    out = {
        "bands": bands.name,
        "n_bands": len(bands.names),
        "pixels": int(n),
        "prior_lamps": len(inv.prior.ids),
        "surface_candidates": int(inv.basis.type_coords.shape[0]),
        "atmospheres": len(inv.conditions.labels),
        "moon_term": inv.conditions.moon is not None,
        "inversion_s_per_pixel": t_inv / n,
        "ridge_s_per_pixel": t_ridge / n,
        "ratio_inversion_to_ridge": t_inv / t_ridge,
        "mixture_prior_lamps": len(inv_mix.prior.ids),
        "inversion_mix_s_per_pixel": t_mix / n,
        "ratio_mix_to_inversion": t_mix / t_inv,
        "ratio_mix_to_ridge": t_mix / t_ridge,
        "inversion_moon_told_s_per_pixel": t_told / n,
        "inversion_mix_moon_told_s_per_pixel": t_mix_told / n,
        "ratio_mix_moon_told_to_ridge": t_mix_told / t_ridge,
        "inversion_mix_metric_moon_told_s_per_pixel": t_metric_told / n,
        "ratio_metric_to_one_sigma": t_metric_told / t_joint_told,
        "metric_noise": {
            **dict(zip(("LER", "G", "CCT"), METRIC_NOISE, strict=True)),
            "types": TYPES_NOISE,
        },
        "distinct_noise_models": len({*METRIC_NOISE, TYPES_NOISE}),
        "ratio_mix_metric_moon_told_to_ridge": t_metric_told / t_ridge,
        "default_prior_lamps": len(inv_default.prior.ids),
        "inversion_evaluate_default_s_per_pixel": t_default / n,
        "ratio_evaluate_default_to_ridge": t_default / t_ridge,
        "inversion_evaluate_default_flag_s_per_pixel": t_flagged / n,
        "ratio_flag_to_no_flag": t_flagged / t_default,
        "flag_inner_folds": len(inv.flag_folds),
        "evaluate_configuration": "inversion_evaluate_default_flag_s_per_pixel "
        "(same-class and cross-type blends, Planck spectra and shifted direct "
        "LEDs in the prior, the Moon told, each metric at its own sigma_rel, "
        "and the cross-conformal unexplained test over the inner folds)",
        "direct_bands": c26.name,
        "direct_s_per_pixel": t_direct / n,
        "ridge_contiguous_s_per_pixel": t_ridge26 / n,
        "ratio_direct_to_ridge_same_bands": t_direct / t_ridge26,
        "inversion_fit_s": t_fit,
        "load_average_1_5_15min": list(os.getloadavg()),
        "cpu_count": os.cpu_count(),
        "ridge_fit_s": t_fit_ridge,
        "image_scale": image_scale(
            ctx, bands, [int(float(x)) for x in args.sizes.split(",") if x]
        ),
        "note": "best of 3 after a warm-up call; measured while other jobs shared "
        "the machine (see load_average): compare the ratio, not absolute times; "
        "predict includes intervals, class "
        "probabilities and the reject test; fit includes the inner-fold choice of "
        "sigma_rel and the conformal calibration",
    }
    dest.mkdir(parents=True, exist_ok=True)
    (dest / "inversion.json").write_text(strict_dumps(out, indent=2) + "\n")
    write_manifest(
        dest / "inversion_manifest", seed=0, config={"bench": "inversion", **vars(args)}
    )
    print(json.dumps(out, indent=2))
    return 0


def image_scale(ctx, bands, sizes) -> dict:
    """Pixels per second and peak memory of `bandopt evaluate`'s default
    inversion against the ridge and the `exp` floor, per pixel count of
    `sizes`, each in a fresh process (see the module docstring)."""
    if not sizes:
        return {}
    from bandopt import inversion as inv_mod
    from bandopt.estimate import fit_estimator
    from bandopt.estimators import InversionConfig

    t0 = time.perf_counter()
    fitted = InversionConfig().fit(ctx, bands, surface_mode="unknown")
    t_fit = time.perf_counter() - t0
    s = ctx.splits[0]
    rad = ctx.radiance(bands)
    ridge = fit_estimator(rad, ctx.table, s.train, s.inner)
    moon = inv_mod.context_moon(ctx)
    pool = rad[moon == 0] if np.any(moon == 0) else rad  # evaluate: moonless
    runs = []
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "fitted.pkl"
        path.write_bytes(pickle.dumps((fitted, ridge, pool)))
        # each run forks from a small fresh server process; its peak memory
        # is `VmHWM`, the high-water mark of its own address space
        spawn = multiprocessing.get_context("forkserver")
        for n in sizes:
            with spawn.Pool(1) as pool_proc:
                runs.append(pool_proc.apply(_scale_run, (str(path), n)))
            print(json.dumps(runs[-1]), flush=True)
    m = fitted.model
    return {
        "estimator": "estimators.InversionConfig() (bandopt evaluate's default), "
        "surface unknown, told moonless",
        "prior_lamps": len(m.prior.ids),
        "noise_models": len(m._predict_noise()),
        "flag_inner_folds": len(m.flag_folds),
        "chunk_pixels": m.predict_chunk_pixels(),
        "chunk_budget_bytes": inv_mod.PREDICT_MEMORY_BYTES,
        "fit_s": t_fit,
        "runs": runs,
        "goal": ">= 10000 pixels/s on 2 cores; peak RSS <= 1 GB at any size",
        "load_average_1_5_15min": list(os.getloadavg()),
    }


def _exp_count(inv) -> int:
    """`exp` calls per pixel of `inv.predict` (surface unknown, Moon told):
    one per lamp (padded), surface candidate and atmosphere per band-error
    model in the scoring, the same per inner fold's prior for the flag, and
    two per lamp and model in the normalisation."""
    from bandopt import inversion as inv_mod

    def pad(k):
        return -(-k // inv_mod.K_BUCKET) * inv_mod.K_BUCKET

    sa = inv.basis.type_coords.shape[0] * len(inv.conditions.labels)
    k, n_noise = len(inv.prior.ids), len(inv._predict_noise())
    folds = [len(f.model.prior.ids) for f in inv.flag_folds]
    return (
        n_noise * (pad(k) * sa + 2 * k)
        + sum(pad(kf) * sa for kf in folds)
        + 2 * sum(folds)
    )


def _scale_run(path: str, n: int) -> dict:
    """One image-scale run in this (fresh) process: `n` pixels tiled from
    the pool in `path`, predicted by the pickled default inversion (as
    `Estimates`) and the ridge; times, peak RSS and the `exp` floor."""
    from bandopt import configure

    configure()
    import jax
    import jax.numpy as jnp

    from bandopt import inversion as inv_mod
    from bandopt.estimators import Surface
    from bandopt.spectra import GRID_1NM

    rss_start = _vm_hwm_kb()
    fitted, ridge, pool = pickle.loads(Path(path).read_bytes())
    pix = np.resize(pool, (n, pool.shape[1]))
    surface = Surface("unknown", None, np.zeros(len(GRID_1NM)))
    step = fitted.model.predict_chunk_pixels()
    warm = pix[: min(n, step + n % step)]  # a whole chunk and the last one's size
    fitted.predict(warm, surface)
    np.asarray(ridge.predict(jnp.asarray(warm)))
    rss_warm = _vm_hwm_kb()
    t0 = time.perf_counter()
    est = fitted.predict(pix, surface)
    t_inv = time.perf_counter() - t0
    assert len(est) == n
    rss_f64 = _vm_hwm_kb()
    # the same inversion scoring in float32 (`Inversion.predict(dtype=)`,
    # called directly: the `Estimates` rows are the same cost either way)
    zero = np.zeros(n)
    fitted.model.predict(warm, None, zero[: len(warm)], dtype="float32")
    t0 = time.perf_counter()
    fitted.model.predict(pix, None, zero, dtype="float32")
    t_f32 = time.perf_counter() - t0
    # pruned scoring (`Inversion.predict(prune=)`), float64 and float32, each
    # after its own warm-up, with its largest differences from the unpruned
    # float64 prediction
    tol = inv_mod.PRUNE_TOLERANCE
    full = fitted.model.predict(pix, None, zero)
    pruned = {}
    for name, dt in (("float64", None), ("float32", "float32")):
        fitted.model.predict(warm, None, zero[: len(warm)], dtype=dt, prune=tol)
        t0 = time.perf_counter()
        got = fitted.model.predict(pix, None, zero, dtype=dt, prune=tol)
        t_p = time.perf_counter() - t0
        pruned[name] = {
            "pixels_per_s": n / t_p,
            "ratio_unpruned_float64_to_this": t_inv / t_p,
            "max_abs_diff_vs_unpruned_float64": _max_diffs(got, full),
        }
    x = jnp.asarray(pix)
    t_ridge = best_time(lambda: ridge.predict(x))  # compiled for n first
    n_exp = _exp_count(fitted.model)
    # 4 pixels' worth, summed as the scoring sums them (no array written)
    block = jnp.asarray(np.random.default_rng(0).normal(size=n_exp * 4))
    exp_sum = jax.jit(lambda x: jnp.sum(jnp.exp(x)))
    t_exp = best_time(lambda: exp_sum(block), repeat=5) / 4
    return {
        "pixels": n,
        "inversion_pixels_per_s": n / t_inv,
        "ridge_pixels_per_s": n / t_ridge,
        "ratio_inversion_to_ridge": t_inv / t_ridge,
        "inversion_float32_pixels_per_s": n / t_f32,
        "ratio_float64_to_float32": t_inv / t_f32,
        "prune_tolerance": tol,
        "inversion_pruned_float64_pixels_per_s": pruned["float64"]["pixels_per_s"],
        "inversion_pruned_float32_pixels_per_s": pruned["float32"]["pixels_per_s"],
        "pruned": pruned,
        "exp_per_pixel": n_exp,
        "exp_floor_pixels_per_s": 1.0 / t_exp,
        "ratio_inversion_to_exp_floor": (t_inv / n) / t_exp,
        "peak_rss_mb_after_imports": rss_start / 1024,
        "peak_rss_mb_after_warmup": rss_warm / 1024,
        "peak_rss_mb_float64": rss_f64 / 1024,
        "peak_rss_mb": _vm_hwm_kb() / 1024,
        "ru_maxrss_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024,
    }


def _max_diffs(got, want) -> dict:
    """Largest absolute difference of each float output of two
    `InversionResult`s (NaN where both are NaN counts as equal), and the
    number of pixels whose type calls or flag differ."""
    out = {}
    for name in (
        "estimate",
        "interval90",
        "cct_probability",
        "misfit",
        "level1_probabilities",
        "level2_probabilities",
        "known_type_p",
    ):
        g, w = getattr(got, name), getattr(want, name)
        same_nan = np.isnan(g) == np.isnan(w)
        d = np.where(np.isnan(g) & np.isnan(w), 0.0, np.abs(g - w))
        out[name] = float(np.max(d)) if same_nan.all() else float("inf")
    out["calls_or_flags_differ"] = int(
        sum(
            a != b or c != d or e != f
            for a, b, c, d, e, f in zip(
                got.level1, want.level1, got.level2, want.level2,
                got.unexplained, want.unexplained, strict=True,
            )
        )
    )  # fmt: skip
    return out


def _vm_hwm_kb() -> float:
    """This process's peak resident memory [kB] as the kernel counts it for
    its own address space (`VmHWM`; NaN where /proc is missing)."""
    status = Path("/proc/self/status")
    if not status.is_file():
        return float("nan")
    for line in status.read_text().splitlines():
        if line.startswith("VmHWM:"):
            return float(line.split()[1])
    return float("nan")


if __name__ == "__main__":
    raise SystemExit(main())
