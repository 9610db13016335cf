"""The stability study's section of a README (`<!-- search -->` markers),
written from the study's own results: band count, alpha sweep, recommended
design with its intervals, optimiser outcomes, tolerances, comparison with the
reference sensors."""

import json
from pathlib import Path


BENCH = Path("results") / "bench" / "search.json"
"""`make bench`'s search benchmark, quoted for the loss evaluation rate."""


def _per_metric(intervals) -> str:
    """`[lo, hi] / [lo, hi] / [lo, hi]` of a per-metric interval dict
    ("not computed" when the tolerance file lacks it)."""
    if not intervals:
        return "not computed"
    return " / ".join(str(intervals[m]) for m in ("LER", "G", "CCT"))


def _reductions(r) -> str:
    """`a% [lo%, hi%] / ...` of one comparison's LER, G and CCT reductions."""
    return " / ".join(
        f"{r[m]['reduction']:.0%} [{r[m]['ci95'][0]:.0%}, {r[m]['ci95'][1]:.0%}]"
        for m in ("LER", "G", "CCT")
    )


def _eval_rate() -> str:
    """Loss evaluations per second before and after the batched search,
    from `BENCH` when `make bench` has written it."""
    if not BENCH.is_file():
        return "not measured (`make bench`)"
    rows = json.loads(BENCH.read_text()).get("eval_rate", {}).get("rows", [])
    if not rows:
        return "not measured (`make bench`)"
    return "; ".join(
        f"n = {r['n_free_bands']}: {r['before_evals_per_s']:.0f} -> "
        f"{r['after_evals_per_s_float64']:.0f} evaluations/s "
        f"({r['ratio_float64']:.1f}x; float32 {r['ratio_float32']:.1f}x, "
        f"max relative loss difference {r['float32_max_rel_loss_diff']:.0e})"
        for r in rows
    )


def study_readme_text(s, stab, tol, rec_key, wall, out, *, shipped, reuse) -> str:
    """The section's text (without markers): `s` the study's `compare.json`,
    `stab` the recommended design's intervals, `tol` its tolerance summary,
    `wall` the run time [s], `reuse` `(tasks reused, tasks)` per sweep."""
    ch = s["band_count"]
    lines = ["n (+pan) | norm. MAE mean +/- SD | LER lm/W | G | CCT K | F1 | SNR"]
    for k, v in s["designs"].items():
        if not k.endswith("a=0"):
            continue
        lines.append(
            f"{k:12s} | {v['norm_mae_mean']:.3f} +/- {v['norm_mae_sd']:.3f} | "
            f"{v['mae_mean']['LER']:.1f} +/- {v['mae_sd']['LER']:.1f} | "
            f"{v['mae_mean']['G']:.3f} +/- {v['mae_sd']['G']:.3f} | "
            f"{v['mae_mean']['CCT']:.0f} +/- {v['mae_sd']['CCT']:.0f} | "
            f"{v['f1_mean']:.2f} | {v['snr_median']:.1f}"
        )
    pair = "; ".join(
        f"{k}: {v['mean']:+.3f} +/- {v['sd']:.3f} ({v['partitions_better']}/"
        f"{v['partitions']} partitions better)"
        for k, v in ch["paired_difference_to_next_n"].items()
    )
    alines = [
        f"{k}: norm. MAE {v['norm_mae_mean']:.3f} +/- {v['norm_mae_sd']:.3f}, "
        f"F1 {v['f1_mean']:.2f} +/- {v['f1_sd']:.2f}, SNR {v['snr_median']:.1f}"
        f"{' (Pareto)' if v.get('pareto') else ''}"
        for k, v in s["designs"].items()
        if k.startswith(f"n{ch['chosen_n']}+pan")
    ]
    rlines = [
        "sensor | bands | LER | G | CCT | F1 | reduction LER / G / CCT "
        "[95 % CI] (recommended) | at equal band count"
    ]
    for k, v in s["references"].items():
        red = s["reductions"][k]["recommended"]
        eq = s["reductions"][k]["equal_band_count"]
        rlines.append(
            f"{k} | {v['n_bands']} | {v['mae_mean']['LER']:.1f} | "
            f"{v['mae_mean']['G']:.3f} | "
            f"{v['mae_mean']['CCT']:.0f} | {v['f1_mean']:.2f} | {_reductions(red)} | "
            f"{_reductions(eq) + ' (' + eq['ours'] + ')' if eq else 'n/a'}"
        )
    blines = [
        f"{n}: {c:.0f} nm [{ci[0]:.0f}, {ci[1]:.0f}], "
        f"FWHM {f:.0f} nm [{fi[0]:.0f}, {fi[1]:.0f}]"
        for n, c, ci, f, fi in zip(
            [f"B{i + 1}" for i in range(len(stab["centre_nm"]))],
            stab["centre_nm"],
            stab["centre_interval_nm"],
            stab["fwhm_nm"],
            stab["fwhm_interval_nm"],
            strict=True,
        )
    ]
    tl = [
        f"{b}: centre shift {v['centre_shift_interval_nm']} nm (calibrated "
        f"{v['centre_shift_interval_calibrated_nm']}), FWHM factor "
        f"{v['fwhm_factor_interval']} (calibrated "
        f"{v['fwhm_factor_interval_calibrated']})"
        for b, v in tol["per_band"].items()
    ]
    conv = "; ".join(
        f"n = {v['n_bands']}: {v['convergence']['designs_converged']}/"
        f"{v['convergence']['designs']}"
        for k, v in s["designs"].items()
        if k.endswith("a=0") and "convergence" in v
    )
    opt = stab["optimiser"]
    n_re, n_all = (sum(v) for v in zip(*reuse, strict=True)) if reuse else (0, 0)
    reused = (
        f"{n_re} of {n_all} tasks reused from the cache" if n_re else "all recomputed"
    )
    freq = ", ".join(f"{k} {v:.0%}" for k, v in stab["region_frequency"].items())
    how = "`make run`" if shipped else f"preset `{s['context']['preset']}`"
    return f"""## Spectral band search: stability study (`{out}`, {how})

Estimator judging every design and reference sensor on the outer folds:
{s["estimator"]["note"]} (scorer `{s["estimator"]["scorer"]}`); search surrogate:
{s["estimator"]["search_surrogate"]}. {s["noise"]}. {s["partitions"]} lamp
partitions x 3 outer folds = {s["resamples"]} resamples (lamp-grouped,
class-stratified); bands searched on each outer training set (global:
{opt["global"]}; local: optimistix BFGS from each start, all resamples and
starts in one compiled function), scored on its test lamps. Multispectral
bands: FWHM >= 20 nm, pairwise overlap <= 0.25, supports inside the data
(380-900 nm), fixed PAN 400-880 nm. {s["normalisation"]}.
Wall time of this run: {wall:.0f} s ({reused}). Loss evaluations (value and gradient of
one design on one resample; the batched loss also carries the classification
term) of the single-split search -> the batched search, `results/bench/search.json`:
{_eval_rate()}.

Band count ({ch["rule"]}): best n = {ch["best_n"]}, chosen n = {ch["chosen_n"]}.
Paired difference of normalised MAE to the next n (mean +/- SD over partitions): {pair}.

```
{chr(10).join(lines)}
```

Objective weight alpha (0: estimation only, 1: classification surrogate only)
at n = {ch["chosen_n"]}: {"; ".join(alines)}. Rule: {s["pareto"]["rule"]}.
Recommended: **{rec_key}**, design = {stab["rule"]}:

```
{chr(10).join(blines)}
```

Region frequency over resamples: {freq}. Local fits: {opt["local"]}; designs
(best fit of each resample) that converged, per band count at alpha 0: {conv};
recommended set: {opt["designs_converged"]}/{opt["designs"]} designs converged,
fits {opt["fits"]}; {opt["parameters_on_a_bound"]} of {opt["parameters"]}
unit-box parameters of the per-resample designs on a bound (within 1e-3).

Tolerance ({tol["rule"]}): {"; ".join(tl)};
leakage interval {tol["leakage_interval"]}
(1 % met: {tol["meets_leakage_1pct"]}), calibrated
{tol["leakage_interval_calibrated"]}
(1 % met: {tol["meets_leakage_1pct_calibrated"]});
angle of incidence {tol["aoi_interval_deg"]} deg, calibrated
{tol["aoi_interval_calibrated_deg"]} deg. Per metric (LER / G / CCT), leakage
{_per_metric(tol.get("leakage_interval_by_metric"))}, calibrated
{_per_metric(tol.get("leakage_interval_by_metric_calibrated"))}.

Comparison (same estimator, same partitions; reductions with 95 % paired CIs):

```
{chr(10).join(rlines)}
```

Files: `compare.json`/`.csv`, `pareto.json`/`.png`, `stability.json`/`.png`,
`tolerance.csv`/`.json`, `recommended_bands.json`, `manifest.json`. Task
results are cached in `tasks/` (not committed); a rerun with the identical
configuration says it reuses them, `--force` recomputes."""
