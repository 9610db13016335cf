"""Physical lamp models: fit quality and leave-one-lamp-out validation
against the measured lamps of each class.

Run:   python -m experiments.lamp_models [--classes hps lps ...] [--samples 200]
Writes results/library/ lamp_models.json (per-class summary, settings),
lamp_models.csv (one row per measured lamp), lamp_models.png, and
lamp_models_manifest.json.

Per class (`bandopt.lampmodels.FAMILY_OF_CLASS`), every measured, non-excluded
lamp is fitted once over its measured range (`lampmodels.fit_library_lamp`).
Leave-one-lamp-out: for each lamp, the class model is calibrated on the fits
of the OTHER measured lamps only (`calibrate_fits`), `--samples` modelled
spectra are drawn from it, and the held-out measured lamp is scored against
them:

- LER and CCT (Ohno 2013) of the held-out lamp against the samples' median
  (relative / absolute error) and its percentile among the samples (a 5-95 %
  interval that covers the lamp counts as covered);
- spectral distance (RMS of the unit-visible-power spectra over 380-780 nm
  divided by their mean) to the nearest modelled sample, beside the distance
  to the nearest other measured lamp of the class (the baseline a library of
  measured lamps alone gives).

With `--max-lamps` (default 16) a larger class is validated on a seeded random
subset of its measured lamps (calibration and scoring both within the subset):
the fits cost 1-15 s per lamp plus a compilation per family and sampling, on
2 shared cores. `measured_lamps_in_class` gives the full count.

Modelled spectra are used only as the calibrated model's samples; every score
is on a measured lamp, and no modelled lamp is ever scored (`modelled_lamps_
scored: false` in the outputs). A class with fewer than 2 measured lamps
cannot be validated leave-one-out (its held-out lamp has no calibration lamp
left) and says so.
"""

import argparse
import csv
import json
import time
from pathlib import Path

import numpy as np


ROOT = Path(__file__).resolve().parents[1]
OUT = ROOT / "results" / "library"


def _unit_visible(w: np.ndarray, s: np.ndarray) -> np.ndarray:
    vis = (w >= 380.0) & (w <= 780.0)
    return s[..., vis] / np.trapezoid(s[..., vis], w[vis], axis=-1)[..., None]


def _nrms(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """RMS difference of unit-visible-power spectra / mean of `b` (rows)."""
    return np.sqrt(np.mean((a - b) ** 2, axis=-1)) / np.mean(b, axis=-1)


def _photometry(w: np.ndarray, s: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    from bandopt.photometry import metrics

    vis = (w >= 380.0) & (w <= 780.0)
    m = metrics(np.asarray(s)[..., vis], w[vis])
    cct = np.where(np.asarray(m["CCT_flag"]), np.nan, np.asarray(m["CCT"]))
    return np.asarray(m["LER"]), cct


def validate_class(
    level2: str, lib, n_samples: int, seed: int, max_lamps: int | None = None
) -> dict:
    from bandopt import lampmodels as lm

    w = lib.wavelength_nm
    members = [
        (i, r)
        for i, r in enumerate(lib.records)
        if r.level2 == level2 and not r.modelled and r.excluded is None
    ]
    n_class = len(members)
    if max_lamps is not None and n_class > max_lamps:
        # a seeded random subset (time budget); calibration and scoring use it
        keep = np.sort(np.random.default_rng(seed).choice(n_class, max_lamps, False))
        members = [members[k] for k in keep]
    ids = [r.id for _, r in members]
    fits, ends, seconds = {}, {}, {}
    for lamp_id in ids:
        t0 = time.time()
        fits[lamp_id] = lm.fit_library_lamp(lamp_id)
        ends[lamp_id] = min(
            lib.records[lib.index(lamp_id)].measured_range_nm[1], float(w[-1])
        )
        seconds[lamp_id] = time.time() - t0
        print(
            f"  fit {lamp_id}: nrms {fits[lamp_id].nrms:.3f} "
            f"({seconds[lamp_id]:.1f} s)",
            flush=True,
        )
    measured = np.stack([lib.values[i] for i, _ in members])
    meas_u = _unit_visible(w, np.nan_to_num(measured))
    ler_m, cct_m = _photometry(w, np.nan_to_num(measured))
    model_u = _unit_visible(w, np.stack([fits[i].model for i in ids]))
    ler_f, cct_f = _photometry(w, np.stack([fits[i].model for i in ids]))
    family = lm.family_of(level2)
    rows = []
    for k, lamp_id in enumerate(ids):
        row = {
            "lamp": lamp_id,
            "level2": level2,
            "family": family.name,
            "measured_end_nm": ends[lamp_id],
            "source_step_nm": fits[lamp_id].step_nm,
            "fit_nrms": fits[lamp_id].nrms,
            "fit_converged": fits[lamp_id].converged,
            "fit_seconds": round(seconds[lamp_id], 2),
            "ler_measured": float(ler_m[k]),
            "ler_fit_rel_err": float(ler_f[k] / ler_m[k] - 1),
            "cct_measured_k": float(cct_m[k]),
            "cct_fit_err_k": float(cct_f[k] - cct_m[k]),
            "fit_vs_measured_nrms_visible": float(
                _nrms(model_u[k][None], meas_u[k][None])[0]
            ),
        }
        others = [i for i in ids if i != lamp_id]
        if not others:
            row["loo"] = "not possible: no other measured lamp in the class"
            rows.append(row)
            continue
        cal = lm.calibrate_fits(
            level2,
            {i: fits[i] for i in others},
            {i: ends[i] for i in others},
        )
        z = lm.sample_z(cal, n_samples, seed + k)
        samples = lm.model_spectra(family, z, w)
        ler_s, cct_s = _photometry(w, samples)
        samp_u = _unit_visible(w, samples)
        other_idx = [ids.index(i) for i in others]
        ok_c = np.isfinite(cct_s)
        row.update(
            {
                "loo": "ok",
                "loo_calibration_lamps": len(others),
                "loo_ler_median_rel_err": float(np.median(ler_s) / ler_m[k] - 1),
                "loo_ler_percentile": float(np.mean(ler_s < ler_m[k])),
                "loo_cct_median_err_k": float(np.median(cct_s[ok_c]) - cct_m[k])
                if ok_c.any() and np.isfinite(cct_m[k])
                else float("nan"),
                "loo_cct_percentile": float(np.mean(cct_s[ok_c] < cct_m[k]))
                if ok_c.any() and np.isfinite(cct_m[k])
                else float("nan"),
                "loo_nearest_sample_nrms": float(
                    np.min(_nrms(samp_u, meas_u[k][None]))
                ),
                "loo_nearest_measured_nrms": float(
                    np.min(_nrms(meas_u[other_idx], meas_u[k][None]))
                ),
            }
        )
        rows.append(row)
    return {
        "rows": rows,
        "example": _example(ids, fits, meas_u, model_u, w),
        "measured_lamps_in_class": n_class,
    }


def _example(ids, fits, meas_u, model_u, w) -> dict:
    """The lamp with the median fit error, for the figure."""
    nr = np.array([fits[i].nrms for i in ids])
    k = int(np.argsort(nr)[len(nr) // 2])
    vis = (w >= 380.0) & (w <= 780.0)
    return {
        "lamp": ids[k],
        "wavelength_nm": w[vis].tolist(),
        "measured": meas_u[k].tolist(),
        "model": model_u[k].tolist(),
    }


def _summary(rows: list[dict]) -> dict:
    def med(key, sub=None):
        v = np.array([r[key] for r in (sub or rows) if key in r], float)
        v = v[np.isfinite(v)]
        return float(np.median(v)) if v.size else None

    def med_abs(key, sub=None):
        v = np.array([r[key] for r in (sub or rows) if key in r], float)
        v = v[np.isfinite(v)]
        return float(np.median(np.abs(v))) if v.size else None

    loo = [r for r in rows if r.get("loo") == "ok"]

    def cover(key):
        v = np.array([r[key] for r in loo], float)
        v = v[np.isfinite(v)]
        return float(np.mean((v > 0.05) & (v < 0.95))) if v.size else None

    out = {
        "measured_lamps": len(rows),
        "fit_converged": int(sum(r["fit_converged"] for r in rows)),
        "fit_nrms_median": med("fit_nrms"),
        "fit_ler_abs_rel_err_median": med_abs("ler_fit_rel_err"),
        "fit_cct_abs_err_k_median": med_abs("cct_fit_err_k"),
        "loo_lamps": len(loo),
    }
    if loo:
        out |= {
            "loo_ler_abs_rel_err_median": med_abs("loo_ler_median_rel_err", loo),
            "loo_ler_90pc_interval_coverage": cover("loo_ler_percentile"),
            "loo_cct_abs_err_k_median": med_abs("loo_cct_median_err_k", loo),
            "loo_cct_90pc_interval_coverage": cover("loo_cct_percentile"),
            "loo_nearest_sample_nrms_median": med("loo_nearest_sample_nrms", loo),
            "loo_nearest_measured_nrms_median": med("loo_nearest_measured_nrms", loo),
        }
    else:
        out["loo"] = "not possible: fewer than 2 measured lamps"
    return out


def _figure(examples: dict, summary: dict, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    classes = list(examples)
    fig, axes = plt.subplots(2, len(classes), figsize=(2.6 * len(classes), 5.2))
    axes = np.atleast_2d(axes).reshape(2, len(classes))
    for j, c in enumerate(classes):
        ex = examples[c]
        ax = axes[0, j]
        ax.plot(ex["wavelength_nm"], ex["measured"], lw=0.8, label="measured")
        ax.plot(ex["wavelength_nm"], ex["model"], lw=0.8, label="model fit")
        ax.set_title(f"{c}\n{ex['lamp'][:28]}", fontsize=7)
        ax.set_xlabel("nm", fontsize=7)
        ax.tick_params(labelsize=6)
        if j == 0:
            ax.legend(fontsize=6)
            ax.set_ylabel("unit visible power [nm⁻¹]", fontsize=7)
        s = summary[c]
        ax = axes[1, j]
        ax.axis("off")
        lines = [
            f"lamps {s['measured_lamps']}",
            f"fit nRMS {s['fit_nrms_median']:.3f}",
            f"fit |ΔLER| {100 * s['fit_ler_abs_rel_err_median']:.1f} %",
        ]
        if s["loo_lamps"]:
            lines += [
                "leave-one-out:",
                f" |ΔLER| {100 * s['loo_ler_abs_rel_err_median']:.1f} %",
                f" LER 90% cover {100 * s['loo_ler_90pc_interval_coverage']:.0f} %",
                f" nearest model {s['loo_nearest_sample_nrms_median']:.3f}",
                f" nearest lamp {s['loo_nearest_measured_nrms_median']:.3f}",
            ]
        else:
            lines.append("no leave-one-out (1 lamp)")
        ax.text(0, 1, "\n".join(lines), va="top", fontsize=7, family="monospace")
    fig.suptitle(
        "Physical lamp models: fit and leave-one-lamp-out validation "
        "(scored on measured lamps only)",
        fontsize=8,
    )
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def main(argv: list[str] | None = None) -> int:
    import jax

    jax.config.update("jax_enable_x64", True)
    from bandopt import lampmodels as lm
    from bandopt.datasets.lamps import library
    from bandopt.provenance import manifest

    p = argparse.ArgumentParser(prog="python -m experiments.lamp_models")
    p.add_argument("--classes", nargs="*", default=None)
    p.add_argument("--samples", type=int, default=200)
    p.add_argument("--seed", type=int, default=0)
    p.add_argument(
        "--max-lamps",
        type=int,
        default=16,
        help="validate at most this many measured lamps per class (seeded random "
        "subset; 0: all)",
    )
    p.add_argument("--out", type=Path, default=OUT)
    args = p.parse_args(argv)
    classes = args.classes or sorted(lm.FAMILY_OF_CLASS)
    args.max_lamps = args.max_lamps or None
    lib = library()
    args.out.mkdir(parents=True, exist_ok=True)
    t0 = time.time()
    rows, examples, summary = [], {}, {}
    for c in classes:
        print(f"{c}:", flush=True)
        res = validate_class(c, lib, args.samples, args.seed, args.max_lamps)
        rows += res["rows"]
        examples[c] = res["example"]
        summary[c] = _summary(res["rows"])
        summary[c]["measured_lamps_in_class"] = res["measured_lamps_in_class"]
        print(f"  {summary[c]}", flush=True)
    config = {
        "classes": classes,
        "samples_per_held_out_lamp": args.samples,
        "seed": args.seed,
        "max_lamps_per_class": args.max_lamps,
        "n_starts": lm.N_STARTS,
        "max_steps": lm.MAX_STEPS,
        "ridge": lm.RIDGE,
        "shrinkage": lm.SHRINKAGE,
    }
    out = {
        "what": "physical lamp models (bandopt.lampmodels): fit to each measured "
        "lamp over its measured range, and leave-one-lamp-out validation (model "
        "calibrated on the other measured lamps of the class, samples scored "
        "against the held-out measured lamp)",
        "modelled_lamps_used": "as calibrated-model samples only",
        "modelled_lamps_scored": False,
        "metrics": {
            "fit_nrms": "RMS residual / mean measured value over the fit range, at "
            "the instrument's samples, unit visible power",
            "ler_fit_rel_err": "LER of the fitted model / measured - 1 (380-780 nm)",
            "loo_ler_median_rel_err": "median LER of the samples / measured - 1",
            "loo_*_percentile": "fraction of samples below the measured value; "
            "coverage = share of held-out lamps inside the samples' 5-95 %",
            "loo_nearest_sample_nrms": "distance to the nearest modelled sample "
            "(unit visible power, 380-780 nm, RMS / mean of the measured lamp)",
            "loo_nearest_measured_nrms": "the same to the nearest other measured "
            "lamp of the class (baseline)",
        },
        "config": config,
        "summary": summary,
        "seconds": round(time.time() - t0, 1),
    }
    (args.out / "lamp_models.json").write_text(json.dumps(out, indent=1) + "\n")
    keys = list(dict.fromkeys(k for r in rows for k in r))
    with open(args.out / "lamp_models.csv", "w", newline="") as fh:
        wr = csv.DictWriter(fh, fieldnames=keys)
        wr.writeheader()
        wr.writerows(rows)
    _figure(examples, summary, args.out / "lamp_models.png")
    # beside lamp_library's manifest.json in the same folder, under its own name
    (args.out / "lamp_models_manifest.json").write_text(
        json.dumps(manifest(seed=args.seed, config=config), indent=2, default=str)
        + "\n"
    )
    print(f"wrote {args.out}/lamp_models.json, .csv, .png", flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
