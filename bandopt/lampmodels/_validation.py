"""How well the physical lamp models describe the measured lamps of each class:
fit quality, and leave-one-lamp-out validation of the calibrated class model.

Per class (`FAMILY_OF_CLASS`), every measured, non-excluded lamp is fitted
once over its measured range (`fit_library_lamp`). Leave-one-lamp-out: for
each lamp, the class model is calibrated on the fits of the *other* measured
lamps only (`calibrate_fits`), `n_samples` modelled spectra are drawn from it,
and the held-out measured lamp is scored against them:

- LER and CCT (Ohno 2013) of the held-out lamp against the samples' median
  (relative / absolute error) and its percentile among the samples (a 5-95 %
  interval that covers the lamp counts as covered);
- spectral distance (RMS of the unit-visible-power spectra over 380-780 nm
  divided by their mean) to the nearest modelled sample, beside the distance
  to the nearest other measured lamp of the class (the baseline a library of
  measured lamps alone gives).

With `max_lamps` a larger class is validated on a seeded random subset of its
measured lamps (calibration and scoring both within the subset): the fits cost
1-15 s per lamp plus a compilation per family and sampling.
`measured_lamps_in_class` gives the full count.

Modelled spectra are used only as the calibrated model's samples; every score
is on a measured lamp, and no modelled lamp is ever scored
(`modelled_lamps_scored: false` in the outputs). A class with fewer than 2
measured lamps cannot be validated leave-one-out (its held-out lamp has no
calibration lamp left) and says so.

`write_validation(out, ...)` runs the classes and writes `lamp_models.json`
(per-class summary, settings), `lamp_models.csv` (one row per measured lamp),
`lamp_models.png` and `lamp_models_manifest.json` into `out`.
"""

import csv
import time
from pathlib import Path

import numpy as np

from ..datasets.lamps import library
from ..photometry import metrics
from ..provenance import check_clean_tree, manifest
from ..strict_json import strict_dumps
from ._calibrate import (
    SHRINKAGE,
    calibrate_fits,
    fit_library_lamp,
    model_spectra,
    sample_z,
)
from ._families import FAMILY_OF_CLASS, family_of
from ._fit import MAX_STEPS, N_STARTS, RIDGE


VISIBLE_NM = (380.0, 780.0)
"""The range of the spectral distances and of LER and CCT [nm]."""


def _visible(w: np.ndarray) -> np.ndarray:
    return (w >= VISIBLE_NM[0]) & (w <= VISIBLE_NM[1])


def unit_visible(w: np.ndarray, s: np.ndarray) -> np.ndarray:
    """Spectra `s` (rows) over 380-780 nm, scaled to unit visible power."""
    vis = _visible(w)
    return s[..., vis] / np.trapezoid(s[..., vis], w[vis], axis=-1)[..., None]


def nrms(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """RMS difference of unit-visible-power spectra / mean of `b` (rows)."""
    return np.sqrt(np.mean((a - b) ** 2, axis=-1)) / np.mean(b, axis=-1)


def _photometry(w: np.ndarray, s: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """LER [lm/W] and CCT [K] (NaN where Ohno 2013 flags it) over 380-780 nm."""
    vis = _visible(w)
    m = metrics(np.asarray(s)[..., vis], w[vis])
    cct = np.where(np.asarray(m["CCT_flag"]), np.nan, np.asarray(m["CCT"]))
    return np.asarray(m["LER"]), cct


def validate_class(
    level2: str, lib, n_samples: int, seed: int, max_lamps: int | None = None
) -> dict:
    """Fit and leave-one-lamp-out rows of class `level2` of library `lib`
    (`rows`, one per validated measured lamp), the figure's `example` and
    `measured_lamps_in_class`."""
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
        fits[lamp_id] = fit_library_lamp(lamp_id)
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
    meas_u = unit_visible(w, np.nan_to_num(measured))
    ler_m, cct_m = _photometry(w, np.nan_to_num(measured))
    model_u = unit_visible(w, np.stack([fits[i].model for i in ids]))
    ler_f, cct_f = _photometry(w, np.stack([fits[i].model for i in ids]))
    family = family_of(level2)
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
                nrms(model_u[k][None], meas_u[k][None])[0]
            ),
        }
        others = [i for i in ids if i != lamp_id]
        if not others:
            row["loo"] = "not possible: no other measured lamp in the class"
            rows.append(row)
            continue
        cal = calibrate_fits(
            level2,
            {i: fits[i] for i in others},
            {i: ends[i] for i in others},
        )
        z = sample_z(cal, n_samples, seed + k)
        samples = model_spectra(family, z, w)
        ler_s, cct_s = _photometry(w, samples)
        samp_u = unit_visible(w, samples)
        other_idx = [ids.index(i) for i in others]
        ok_c = np.isfinite(cct_s)
        cct_ok = ok_c.any() and np.isfinite(cct_m[k])
        row.update(
            {
                "loo": "ok",
                "loo_calibration_lamps": len(others),
                "loo_ler_median_rel_err": float(np.median(ler_s) / ler_m[k] - 1),
                "loo_ler_percentile": float(np.mean(ler_s < ler_m[k])),
                "loo_cct_median_err_k": float(np.median(cct_s[ok_c]) - cct_m[k])
                if cct_ok
                else float("nan"),
                "loo_cct_percentile": float(np.mean(cct_s[ok_c] < cct_m[k]))
                if cct_ok
                else float("nan"),
                "loo_nearest_sample_nrms": float(np.min(nrms(samp_u, meas_u[k][None]))),
                "loo_nearest_measured_nrms": float(
                    np.min(nrms(meas_u[other_idx], meas_u[k][None]))
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
    return {
        "lamp": ids[k],
        "wavelength_nm": w[_visible(w)].tolist(),
        "measured": meas_u[k].tolist(),
        "model": model_u[k].tolist(),
    }


def _finite(rows: list[dict], key: str) -> np.ndarray:
    v = np.array([r[key] for r in rows if key in r], float)
    return v[np.isfinite(v)]


def _median(rows: list[dict], key: str, absolute: bool = False) -> float | None:
    v = _finite(rows, key)
    return float(np.median(np.abs(v) if absolute else v)) if v.size else None


def summarise_validation(rows: list[dict]) -> dict:
    """One class's summary of its `validate_class` rows: medians of the fit
    and leave-one-out errors, and the 5-95 % interval coverage."""
    loo = [r for r in rows if r.get("loo") == "ok"]

    def cover(key):
        v = _finite(loo, key)
        return float(np.mean((v > 0.05) & (v < 0.95))) if v.size else None

    out = {
        "measured_lamps": len(rows),
        "fit_converged": int(sum(r["fit_converged"] for r in rows)),
        "fit_nrms_median": _median(rows, "fit_nrms"),
        "fit_ler_abs_rel_err_median": _median(rows, "ler_fit_rel_err", True),
        "fit_cct_abs_err_k_median": _median(rows, "cct_fit_err_k", True),
        "loo_lamps": len(loo),
    }
    if loo:
        out |= {
            "loo_ler_abs_rel_err_median": _median(loo, "loo_ler_median_rel_err", True),
            "loo_ler_90pc_interval_coverage": cover("loo_ler_percentile"),
            "loo_cct_abs_err_k_median": _median(loo, "loo_cct_median_err_k", True),
            "loo_cct_90pc_interval_coverage": cover("loo_cct_percentile"),
            "loo_nearest_sample_nrms_median": _median(loo, "loo_nearest_sample_nrms"),
            "loo_nearest_measured_nrms_median": _median(
                loo, "loo_nearest_measured_nrms"
            ),
        }
    else:
        out["loo"] = "not possible: fewer than 2 measured lamps"
    return out


FIGURE_TITLE = (
    "Physical lamp models: fit and leave-one-lamp-out validation "
    "(scored on measured lamps only)"
)


def validation_figure(examples: dict, summary: dict, path: Path) -> None:
    """Per class: the example lamp measured and fitted (unit visible power),
    and its summary in words."""
    import matplotlib  # plotting only: start-up time

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt  # after matplotlib.use("Agg")

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
    fig.suptitle(FIGURE_TITLE, fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


VALIDATION_COLUMNS = {
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
}
"""What each column of `lamp_models.csv` measures (written into the JSON)."""


def write_validation(
    out: Path,
    classes=None,
    samples: int = 200,
    seed: int = 0,
    max_lamps: int | None = 16,
) -> dict:
    """Validate `classes` (default: every class with a family) with `samples`
    modelled spectra per held-out lamp, at most `max_lamps` measured lamps per
    class (None: all), and write the outputs into `out`; returns the JSON's
    content."""
    out = Path(out)
    classes = classes or sorted(FAMILY_OF_CLASS)
    lib = library()
    out.mkdir(parents=True, exist_ok=True)
    t0 = time.time()
    rows, examples, summary = [], {}, {}
    for c in classes:
        print(f"{c}:", flush=True)
        res = validate_class(c, lib, samples, seed, max_lamps)
        rows += res["rows"]
        examples[c] = res["example"]
        summary[c] = summarise_validation(res["rows"])
        summary[c]["measured_lamps_in_class"] = res["measured_lamps_in_class"]
        print(f"  {summary[c]}", flush=True)
    config = {
        "classes": classes,
        "samples_per_held_out_lamp": samples,
        "seed": seed,
        "max_lamps_per_class": max_lamps,
        "n_starts": N_STARTS,
        "max_steps": MAX_STEPS,
        "ridge": RIDGE,
        "shrinkage": SHRINKAGE,
    }
    result = {
        "what": "physical lamp models (bandopt.lampmodels): fit to each measured "
        "lamp over its measured range, and leave-one-lamp-out validation (model "
        "calibrated on the other measured lamps of the class, samples scored "
        "against the held-out measured lamp)",
        "modelled_lamps_used": "as calibrated-model samples only",
        "modelled_lamps_scored": False,
        "metrics": VALIDATION_COLUMNS,
        "config": config,
        "summary": summary,
        "seconds": round(time.time() - t0, 1),
    }
    (out / "lamp_models.json").write_text(strict_dumps(result, indent=1) + "\n")
    keys = list(dict.fromkeys(k for r in rows for k in r))
    with open(out / "lamp_models.csv", "w", newline="") as fh:
        wr = csv.DictWriter(fh, fieldnames=keys)
        wr.writeheader()
        wr.writerows(rows)
    validation_figure(examples, summary, out / "lamp_models.png")
    # beside the lamp-library report's manifest.json in the same folder, under
    # its own name
    check_clean_tree(out)
    (out / "lamp_models_manifest.json").write_text(
        strict_dumps(manifest(seed=seed, config=config), indent=2) + "\n"
    )
    print(f"wrote {out}/lamp_models.json, .csv, .png", flush=True)
    return result
