"""The stability study (`make run`): `run_study`.

Band counts (`STUDY`) at alpha 0 and every reference sensor are searched and
judged on the same lamp resamples (phase 1); the band count follows the
one-SD rule; objective weights alpha at that count (phase 2) give a Pareto
front of estimation error, level-2 F1 and SNR whose knee is recommended, as
the medoid of its per-resample designs with min-max intervals; then its
tolerance analysis and the paired comparison with every reference sensor.
Writes `compare.json`/`.csv`, `pareto.json`/`.png`, `stability.json`/`.png`,
`tolerance.csv`/`.json`, `recommended_bands.json`, the manifest, the
"spectral" recommendation and the README section (see `DEFAULT_OUT` for
where the last two go).
"""

import csv
import sys
import time
from pathlib import Path

import numpy as np

from ..estimate import METRICS, UNITS
from ..provenance import write_manifest
from ..results import update_readme_section, update_recommendation
from ..strict_json import strict_dumps
from ._analysis import (
    NORMALISATION_NOTE,
    PARETO_RULE,
    band_count_choice,
    design_intervals,
    knee,
    lamp_mean_errors,
    pareto_mask,
    partition_summary,
    truth_sd,
)
from ._figures import plot_pareto, plot_stability
from ._options import DEFAULT_OUT, STUDY, SearchOptions
from ._report import paired_reduction
from ._study import SCORER_NOTES, study_space, task_resamples
from ._study_readme import study_readme_text
from ._study_sweep import study_sweep, study_tasks
from ._tolerance import tolerance_analysis


COMPARE_COLUMNS = (
    "set kind n_bands_total partitions metric mae_mean mae_sd f1_mean f1_sd".split()
)
"""Columns of `compare.csv`: one row per design or reference sensor and metric."""


def _convergence(run) -> dict:
    """How the local fits of a search task ended: optimistix's results over
    all fits, and how many of the per-resample designs (the best fit of each
    resample) converged."""
    conv = run["design_converged"]
    return {
        "fits": run["fit_results"],
        "designs_converged": int(sum(conv)),
        "designs": len(conv),
    }


def _design_summary(n, alpha, scores, run) -> dict:
    """One design's row: band count, alpha, outer-fold `scores` summary,
    median SNR, largest band overlap."""
    return {
        "n_bands": n,
        "alpha": alpha,
        **scores,
        "snr_median": float(np.median(run["snr"])),
        "max_overlap": float(np.max(run["max_overlap"])),
    }


def _reductions(refs_raw, count, rec_run, rec_key, classes) -> dict:
    """Paired MAE reductions against each reference sensor: of the
    recommended design, and of the alpha-0 design with the reference's total
    band count (None when that count was not searched)."""
    ours_idx, ours_err = lamp_mean_errors(rec_run["scores"])
    reductions = {}
    for k, r in refs_raw.items():
        ridx, rerr = lamp_mean_errors(r["scores"])
        red = {
            "ours": rec_key,
            **paired_reduction(ours_err, rerr, ours_idx, ridx, classes),
        }
        nb = r["n_bands_total"] - 1
        eq = None
        if nb in count:
            eidx, eerr = lamp_mean_errors(count[nb]["scores"])
            eq = {
                "ours": f"n{nb}+pan a=0",
                **paired_reduction(eerr, rerr, eidx, ridx, classes),
            }
        reductions[k] = {"recommended": red, "equal_band_count": eq}
    return reductions


def _write_compare_csv(path: Path, designs, ref_sum) -> None:
    """One row per design or reference sensor and metric."""
    with path.open("w", newline="") as fh:
        w = csv.writer(fh)
        header = (
            "set kind n_bands_total partitions metric mae_mean mae_sd f1_mean f1_sd"
        )
        w.writerow(header.split())
        for kind, group in (("ours", designs), ("reference", ref_sum)):
            for k, v in group.items():
                nbt = v["n_bands"] + (1 if kind == "ours" else 0)
                for m in METRICS:
                    w.writerow(
                        [
                            k,
                            kind,
                            nbt,
                            v["partitions"],
                            m,
                            v["mae_mean"][m],
                            v["mae_sd"][m],
                            v["f1_mean"],
                            v["f1_sd"],
                        ]
                    )


def _band_rows(bands, stab, tol) -> list[dict]:
    """Per recommended band: centre and FWHM, their ranges over resamples
    and their tolerances (nominal and calibrated estimator)."""
    rows = []
    c_int, f_int = stab["centre_interval_nm"], stab["fwhm_interval_nm"]
    for i, name in enumerate(bands.names):
        c, f = float(bands.centre_nm[i]), float(bands.fwhm_nm[i])
        per = tol["per_band"][name]
        rows.append(
            {
                "name": name,
                "centre_nm": c,
                "fwhm_nm": f,
                "centre_interval_nm": c_int[i] if i < len(c_int) else [c, c],
                "fwhm_interval_nm": f_int[i] if i < len(f_int) else [f, f],
                "centre_tolerance_nm": per["centre_shift_interval_nm"],
                "fwhm_tolerance_factor": per["fwhm_factor_interval"],
                "centre_tolerance_calibrated_nm": per[
                    "centre_shift_interval_calibrated_nm"
                ],
                "fwhm_tolerance_calibrated_factor": per[
                    "fwhm_factor_interval_calibrated"
                ],
            }
        )
    return rows


def run_study(options: SearchOptions) -> dict:
    """The stability study (see `STUDY`): band count, Pareto, recommendation,
    tolerance and comparison, written to `options.out`. Returns the summary
    (`compare.json`)."""
    t_start = time.perf_counter()
    out = Path(options.out)
    reused: list[tuple[int, int]] = []
    # phase 1: band counts (alpha = 0) and reference sensors
    p1 = study_tasks(options, ns=options.bands, alphas=(0.0,), refs=True)
    r1 = study_sweep(p1, options, "phase 1 (band counts, reference sensors)", reused)
    ctx, res = task_resamples(p1[0])
    classes = ctx.table.classes
    sd = truth_sd(ctx.table)
    count = {r["task"]["n_bands"]: r for r in r1 if not r["task"].get("sensor")}
    refs_raw = {r["task"]["sensor"]: r for r in r1 if r["task"].get("sensor")}
    count_sum = {
        n: partition_summary(r["scores"], classes, sd) for n, r in count.items()
    }
    choice = band_count_choice(
        {n: s["per_partition"]["norm_mae"] for n, s in count_sum.items()}
    )
    n_star = choice["chosen_n"]
    print(
        f"band count: best n = {choice['best_n']}, chosen n = {n_star} (one-SD rule)",
        file=sys.stderr,
        flush=True,
    )
    # phase 2: objective weights at the chosen n
    alphas = [a for a in STUDY["alphas"] if a != 0.0]
    p2 = study_tasks(options, ns=[n_star], alphas=alphas)
    r2 = study_sweep(p2, options, f"phase 2 (alpha sweep at n = {n_star})", reused)
    by_alpha = {0.0: count[n_star], **{r["task"]["alpha"]: r for r in r2}}
    cands = {}
    for a, r in sorted(by_alpha.items()):
        s = partition_summary(r["scores"], classes, sd)
        cands[f"n{n_star}+pan a={a:g}"] = {
            **_design_summary(n_star, a, s, r),
            "convergence": _convergence(r),
        }
    keys = list(cands)
    pts = np.array(
        [
            [
                cands[k]["norm_mae_mean"],
                1 - cands[k]["f1_mean"],
                -np.log10(max(cands[k]["snr_median"], 1e-9)),
            ]
            for k in keys
        ]
    )
    mask = pareto_mask(pts)
    for k, m in zip(keys, mask, strict=True):
        cands[k]["pareto"] = bool(m)
    rec_key = keys[knee(pts, mask)]
    rec = cands[rec_key]
    rec_run = by_alpha[rec["alpha"]]
    stab = design_intervals(rec_run["designs"])
    space = study_space(rec_run["task"], ctx)
    bands = space.band_set(
        stab["centre_nm"], stab["fwhm_nm"], name="bandopt-recommended"
    )
    # reference sensors and our designs: same partitions, same estimator
    ref_sum = {
        k: {
            "n_bands": r["n_bands_total"],
            **partition_summary(r["scores"], classes, sd),
            "snr_median": r["snr"],
        }
        for k, r in refs_raw.items()
    }
    designs = {
        f"n{n}+pan a=0": {
            **_design_summary(n, 0.0, count_sum[n], r),
            "stability": design_intervals(r["designs"]),
            "convergence": _convergence(r),
        }
        for n, r in sorted(count.items())
    }
    for k, v in cands.items():
        designs.setdefault(k, v)
    reductions = _reductions(refs_raw, count, rec_run, rec_key, classes)
    scorer_note = SCORER_NOTES[options.scorer]
    summary_json = {
        "estimator": {
            "scorer": options.scorer,
            "note": scorer_note,
            "search_surrogate": "closed-form ridge on centred log ratios "
            "inside the inner-CV loss (bandopt.estimate.cv_loss)",
        },
        "partitions": options.partitions,
        "resamples": len(res),
        "noise": f"Photon noise at EN 13201 class {STUDY['noise']} (thesis Table "
        "2.3 sensor, shot noise); evaluation draws differ from search draws",
        "normalisation": NORMALISATION_NOTE,
        "truth_sd": dict(zip(METRICS, map(float, sd), strict=True)),
        "metric_units": UNITS,
        "band_count": choice,
        "pareto": {"rule": PARETO_RULE, "recommended": rec_key},
        "designs": designs,
        "references": ref_sum,
        "reductions": {
            "note": "relative MAE reduction 1 - MAE_ours / MAE_ref, per-lamp "
            "errors averaged over partitions, 95 % paired lamp bootstrap "
            "stratified by class; equal_band_count: ours with the "
            "reference's total band count (n free + pan) at alpha 0",
            **reductions,
        },
        "context": ctx.config,
    }
    (out / "compare.json").write_text(
        strict_dumps(summary_json, indent=1) + "\n"
    )
    _write_compare_csv(out / "compare.csv", designs, ref_sum)
    # Pareto and stability outputs
    (out / "pareto.json").write_text(
        strict_dumps(
            {"rule": PARETO_RULE, "recommended": rec_key, "candidates": cands},
            indent=1,
        )
        + "\n"
    )
    sat = np.asarray(rec_run["saturated"], bool)
    stab["optimiser"] = {
        **rec_run["optimiser"],
        "parameters_on_a_bound": int(sat.sum()),
        "parameters": int(sat.size),
        **_convergence(rec_run),
    }
    stab_json = {
        "set": rec_key,
        **stab,
        "per_resample": [
            {**d, "partition": s["partition"], "fold": s["fold"], "inner_loss": l}
            for d, s, l in zip(
                rec_run["designs"],
                rec_run["scores"],
                rec_run["inner_loss"],
                strict=True,
            )
        ],
    }
    (out / "stability.json").write_text(strict_dumps(stab_json, indent=1) + "\n")
    plot_stability(
        stab_json["per_resample"],
        stab,
        out / "stability.png",
        f"Designs of {rec_key} on {len(res)} lamp resamples "
        f"({options.partitions} partitions x 3 folds); bottom: recommended (medoid)",
    )
    plot_pareto(
        cands, ref_sum, rec_key, out / "pareto.png", PARETO_RULE, others=designs
    )
    # tolerance
    print("tolerance analysis of the recommended set", file=sys.stderr, flush=True)
    analysis = tolerance_analysis(
        ctx, bands, res, scorer=options.tolerance_scorer, seed=options.seed
    )
    tol = analysis.summary
    with (out / "tolerance.csv").open("w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=list(analysis.rows[0]))
        w.writeheader()
        w.writerows(analysis.rows)
    (out / "tolerance.json").write_text(strict_dumps(tol, indent=1) + "\n")
    # recommendation
    shipped = out.resolve() == DEFAULT_OUT.resolve()
    update_recommendation(
        "spectral",
        {
            "set": rec_key,
            "bands": _band_rows(bands, stab, tol),
            "band_set": bands.to_dict(),
            "intervals": "centre/fwhm_interval_nm: range (min-max) over the "
            f"{len(res)} lamp resamples (stability); the PAN band is fixed",
            "tolerances": "centre_tolerance_nm / fwhm_tolerance_factor: deviation "
            "within which all errors stay within 10 % (tolerance.json), "
            "estimator fitted to the nominal bands; *_calibrated_*: estimator "
            "coefficients refitted on the perturbed (as-built) responses, "
            "hyper-parameters fixed at the nominal fit",
            "rules": {
                "band_count": choice["rule"],
                "pareto": PARETO_RULE,
                "design": stab["rule"],
            },
            "test_mae": {
                "partitions": rec["partitions"],
                "mae_mean": rec["mae_mean"],
                "mae_sd": rec["mae_sd"],
                "f1_mean": rec["f1_mean"],
                "unit": UNITS,
            },
            "estimator": scorer_note,
            "search": {
                "global": stab["optimiser"]["global"],
                "local": stab["optimiser"]["local"],
                "designs_converged": stab["optimiser"]["designs_converged"],
                "designs": stab["optimiser"]["designs"],
            },
            "source": str(out / "compare.json"),
        },
        path=None if shipped else out / "recommendation.json",
    )
    bands.to_json(out / "recommended_bands.json")
    wall = time.perf_counter() - t_start
    write_manifest(
        out,
        seed=options.seed,
        config={
            "study": {
                k: list(v) if isinstance(v, tuple) else v for k, v in STUDY.items()
            },
            "partitions": options.partitions,
            "max_steps": options.max_steps,
            "scorer": options.scorer,
            "bands": options.bands_text,
            "context": ctx.config,
            "wall_s": wall,
            "tasks_reused_per_phase": [list(v) for v in reused],
            "modelled_spectra_scored": "see context (library selection scored_only)",
        },
    )
    update_readme_section(
        "search",
        study_readme_text(
            summary_json, stab, tol, rec_key, wall, out, shipped=shipped, reuse=reused
        ),
        results_dir=Path("results") if shipped else out,
    )
    print(f"study wall time {wall:.0f} s", file=sys.stderr)
    return summary_json
