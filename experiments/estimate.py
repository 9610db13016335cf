"""Estimators of LER, G and CCT on lamps the estimator has never seen.

For each band set (our recommended design and reference sensors), each lamp
partition (fold seeds; the same nested, lamp-grouped, class-stratified folds
for every row) and each estimator — the physics-based inversion with the
surface unknown, its class known, or measured in daytime by Sentinel-2, and
the bounded ridge and kernel-ridge baselines; the inversion three times:
with its band-error scale chosen on the inner folds by metric error, by log
evidence (`inversion-evidence`), and told each scene's Moon brightness
instead of fitting it (`inversion-moon`: known from the acquisition's time
and place; `bandopt evaluate` tells it) — score the held-out measured
lamps. Then hold out every scored lamp class in turn (unseen types), with
the Moon fitted and told (`unseen_types.json` entries `<band set>` and
`<band set>+moon`).

    python -m experiments.estimate [--partitions 4] [--quick] [--out DIR]
        [--modelled-per-class N]

Writes `records.jsonl` (one line per test lamp; recomputed from scratch unless
`--resume`, which keeps finished (partition, band set) units of an interrupted
run and skips them), `summary.json/.csv`,
`paired.json` (band sets), `estimator_paired.json` (modelled training lamps
and the evidence rule against their base estimator), `unseen_types.json`,
figures and `manifest.json`. Training uses
measured lamps only (the NIR extension of lamps ending at 780 nm is modelled:
`bandopt.datasets.nir`; counts in the manifest); scoring uses measured lamps
only.

`--modelled-per-class N` (default 0: none, and every output exactly as
without the option) adds rows trained on N modelled lamps per rare class
(`bandopt.inversion.MODELLED_CLASSES`) too, on the same partitions and folds,
surface unknown, each model calibrated on its fit's measured training lamps
only: `inversion+models` (recommended bands; modelled lamps in the prior,
`bandopt.inversion.fit_inversion`; also in the unseen-types study,
`unseen_types.json` entry `recommended+models`), and `ridge+models` /
`kernel+models` for every band set (modelled lamps' scenes among the training
rows, `bandopt.inversion.augment_with_modelled`). Test lamps stay measured
lamps only. Every record of such a run, the summary
rows, the README section and the manifest say `modelled_per_class`. The
first use fits the models to their measured lamps: 6-11 min per process
on a busy 2-core machine (`bandopt.inversion.modelled_lamps`).
"""

import argparse
import csv
import json
import sys
import time
from pathlib import Path

import numpy as np

from bandopt.studies import (
    band_set,
    diff_cells,
    fmt_cell,
    held_out_by_class,
    held_out_overall,
    load_records,
    where_lines,
)


DEFAULT_BAND_SETS = ("recommended", "sdgsat-1", "nightsat", "viirs-dnb")
MODELS = "inversion+models"
"""Estimator label of the inversion with modelled lamps in its prior."""
EVIDENCE = "inversion-evidence"
"""Estimator label of the inversion with `σ_rel` chosen by held-out log
evidence (`bandopt.inversion.EVIDENCE_ESTIMATOR`); "inversion" chooses it by
held-out metric error."""
MOON = "inversion-moon"
"""Estimator label of the inversion told the Moon's brightness
(`bandopt.inversion.MOON_ESTIMATOR`)."""
INVERSIONS = ("inversion", EVIDENCE, MODELS, MOON)
FULL_SURFACE_SETS = ("recommended", "sdgsat-1")


def log(msg: str) -> None:
    print(f"[estimate {time.strftime('%H:%M:%S')}] {msg}", file=sys.stderr, flush=True)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument(
        "--partitions", type=int, default=4, help="lamp partitions (fold seeds 0..P-1)"
    )
    ap.add_argument("--band-sets", nargs="+", default=list(DEFAULT_BAND_SETS))
    ap.add_argument("--quick", action="store_true", help="preset 'tiny', 1 partition")
    ap.add_argument(
        "--out", default=None, help="output folder (default results/estimate)"
    )
    ap.add_argument(
        "--no-unseen", action="store_true", help="skip the held-out-class study"
    )
    ap.add_argument(
        "--resume",
        action="store_true",
        help="keep finished (partition, band set) units of records.jsonl "
        "(default: start afresh)",
    )
    ap.add_argument(
        "--modelled-per-class",
        type=int,
        default=0,
        metavar="N",
        help="also score the inversion with N modelled lamps per rare class in "
        "its prior (estimator 'inversion+models'; recommended bands, surface "
        "unknown, and in the unseen-types study), models calibrated on each "
        "fit's training lamps only, scored on measured lamps only (default 0: "
        "no modelled lamps, no such rows)",
    )
    ap.add_argument(
        "--summarise-only",
        action="store_true",
        help="recompute summaries, figures, the README section and the "
        "recommendation.json part from records.jsonl / unseen_types.json",
    )
    args = ap.parse_args(argv)
    if args.modelled_per_class < 0:
        ap.error("--modelled-per-class must be >= 0.")

    from bandopt import configure

    configure()
    from bandopt import inversion as inv_mod
    from bandopt.provenance import write_manifest
    from bandopt.search import get_context

    out = Path(
        args.out or ("results/estimate_quick" if args.quick else "results/estimate")
    )
    out.mkdir(parents=True, exist_ok=True)
    preset = "tiny" if args.quick else "search"
    parts = 1 if args.quick else args.partitions
    rec_path = out / "records.jsonl"
    records, done = load_records(rec_path, keep=args.resume or args.summarise_only)
    n_model = args.modelled_per_class
    if args.summarise_only:
        n_model = modelled_per_class_of(records)
    elif records and modelled_per_class_of(records) != n_model:
        raise SystemExit(
            f"{rec_path}: records of a run with --modelled-per-class "
            f"{modelled_per_class_of(records)}, not {n_model}; start afresh "
            "(without --resume) or give the same option."
        )
    units = [(p, b) for p in range(parts) for b in args.band_sets]
    if args.summarise_only:
        units = []
    for j, (p, name) in enumerate(units):
        if (p, name) in done:
            continue
        ctx = get_context(preset, None, p, "auto")
        bands = band_set(name)
        modes = (
            ("unknown", "class", "measured")
            if name in FULL_SURFACE_SETS
            else ("unknown",)
        )
        ests = (
            ("inversion", EVIDENCE, MOON, "ridge", "kernel")
            if len(bands.names) > 1
            else ("inversion", EVIDENCE, MOON, "ridge")
        )
        t0 = time.time()
        recs = inv_mod.cross_validate(
            ctx, bands, estimators=ests, surface_modes=modes, seed=p
        )
        if n_model:
            for r in recs:
                r["modelled_per_class"] = 0
            recs += inv_mod.cross_validate(
                ctx,
                bands,
                estimators=modelled_estimators(name, len(bands.names)),
                surface_modes=("unknown",),
                seed=p,
                modelled_per_class=n_model,
            )
        for r in recs:
            r.update(partition=p, band_set=name)
        with rec_path.open("a") as fh:
            for r in recs:
                fh.write(json.dumps(r) + "\n")
        records.extend(recs)
        left = (len(units) - j - 1) * (time.time() - t0)
        log(
            f"partition {p} {name}: {time.time() - t0:.0f} s "
            f"({j + 1}/{len(units)}; ~{left / 60:.0f} min left)"
        )
    summary = inv_mod.summarise(records)
    paired = []
    for name in args.band_sets:
        if name != "recommended" and "recommended" in args.band_sets:
            paired += inv_mod.paired_differences(summary, "recommended", name)
    (out / "summary.json").write_text(json.dumps(summary, indent=2) + "\n")
    (out / "paired.json").write_text(json.dumps(paired, indent=2) + "\n")
    variants = inv_mod.estimator_differences(summary)
    (out / "estimator_paired.json").write_text(json.dumps(variants, indent=2) + "\n")
    cols = ["band_set", "estimator", "surface", "partitions", "out_of_range"]
    for c in inv_mod.SUMMARY_COLUMNS:
        cols += [c, f"{c}_sd"]
    with (out / "summary.csv").open("w", newline="") as fh:
        wr = csv.DictWriter(fh, fieldnames=cols, extrasaction="ignore")
        wr.writeheader()
        wr.writerows(summary)
    unseen = None
    if args.summarise_only and (out / "unseen_types.json").is_file():
        unseen = json.loads((out / "unseen_types.json").read_text())
    elif not args.no_unseen:
        ctx = get_context(preset, None, 0, "auto")
        unseen = {}
        for name in [b for b in ("recommended", "sdgsat-1") if b in args.band_sets]:
            log(f"unseen types: {name}")
            recs = inv_mod.leave_one_class_out(ctx, band_set(name))
            unseen[name] = {
                "records": recs,
                "by_class": held_out_by_class(recs),
                "overall": held_out_overall(recs),
            }
            if n_model:
                unseen[name]["modelled_per_class"] = 0
            log(f"unseen types: {name}, the Moon told")
            recs = inv_mod.leave_one_class_out(ctx, band_set(name), moon_known=True)
            unseen[f"{name}+moon"] = {
                "records": recs,
                "by_class": held_out_by_class(recs),
                "overall": held_out_overall(recs),
                "moon": "known per pixel",
            }
            if n_model:
                unseen[f"{name}+moon"]["modelled_per_class"] = 0
        if n_model and "recommended" in args.band_sets:
            log("unseen types: recommended, inversion with modelled lamps")
            recs = inv_mod.leave_one_class_out(
                ctx, band_set("recommended"), modelled_per_class=n_model
            )
            unseen["recommended+models"] = {
                "records": recs,
                "by_class": held_out_by_class(recs),
                "overall": held_out_overall(recs),
                "modelled_per_class": n_model,
            }
        (out / "unseen_types.json").write_text(json.dumps(unseen, indent=2) + "\n")
    _figures(summary, unseen, out, preset)
    if "recommended" in args.band_sets:
        _spectra_figure(out, preset)
    coverage = _coverage(summary, unseen)
    (out / "coverage.json").write_text(json.dumps(coverage, indent=2) + "\n")
    default_run = args.out is None and not args.quick
    if default_run:
        from bandopt.results import update_readme_section, update_recommendation

        update_readme_section(
            "estimate",
            readme_text(summary, paired, unseen, variants),
            heading="## Estimation on unseen lamps",
        )
        update_recommendation("estimation", _recommendation(summary, coverage))
    computed_at = None
    if args.summarise_only and (out / "manifest.json").is_file():
        prev = json.loads((out / "manifest.json").read_text())
        # a summary of a summary keeps the commit the records were computed at
        computed_at = (prev.get("config") or {}).get(
            "records_computed_at_commit"
        ) or prev.get("git_commit")
    config = {
        "preset": preset,
        "partitions": parts,
        "band_sets": args.band_sets,
        "quick": args.quick,
        "scored_lamps": "measured lamps only",
        "training_lamps": "measured lamps only (no modelled lamp spectra); spectra "
        "ending at 780 nm carry the modelled NIR extension of bandopt.datasets.nir",
        "intervals": "posterior 5-95 % range widened by split-conformal factors "
        "calibrated on the inner folds' held-out lamps (class-balanced)",
        "unexplained": "reduced chi2 above the 99th percentile of the inner "
        "held-out lamps",
        "records_computed_at_commit": computed_at,
    }
    if n_model:
        config.update(modelled_lamps_config(n_model))
    kw = {}
    if n_model:
        kw["lamp_models"] = (
            f"used in training only: {n_model} modelled lamps per class of "
            f"{list(inv_mod.MODELLED_CLASSES)} (bandopt.lampmodels, calibrated on "
            "each fit's measured training lamps) in the rows inversion+models, "
            "ridge+models, kernel+models and the unseen-types entry "
            "recommended+models; never scored (test lamps are measured)"
        )
    write_manifest(out, seed=0, config=config, **kw)
    log(f"done: {out}")
    return 0


def modelled_estimators(band_set_name: str, n_bands: int) -> tuple[str, ...]:
    """Estimators trained on modelled lamps too in a `--modelled-per-class`
    run: the ridge for every band set, the kernel ridge for every band set
    with more than one band (as without models), the inversion for the
    recommended bands only (its prior: the slow part)."""
    out = ("ridge+models",) + (("kernel+models",) if n_bands > 1 else ())
    return ((MODELS,) if band_set_name == "recommended" else ()) + out


def modelled_per_class_of(records) -> int:
    """Modelled lamps per class of a run's `inversion+models` rows (0: a run
    without them, e.g. every record written before the option existed)."""
    return max((int(r.get("modelled_per_class", 0)) for r in records), default=0)


def modelled_lamps_config(n_model: int) -> dict:
    """What the manifest says of a run with modelled lamps."""
    from bandopt.inversion import MIN_CALIBRATION_LAMPS, MODELLED_CLASSES

    return {
        "training_lamps": "measured lamps (spectra ending at 780 nm carry the "
        "modelled NIR extension of bandopt.datasets.nir); estimator "
        f"'{MODELS}' (recommended bands, surface unknown, and the unseen-types "
        "entry 'recommended+models'), 'ridge+models' and 'kernel+models' (every "
        f"band set, surface unknown) also {n_model} modelled lamps per class of "
        f"{list(MODELLED_CLASSES)} with >= {MIN_CALIBRATION_LAMPS} measured "
        "training lamps (bandopt.lampmodels), calibrated on each fit's measured "
        "training lamps only",
        "modelled_per_class": n_model,
        "modelled_classes": list(MODELLED_CLASSES),
    }


TYPICAL = (
    "hps",
    "led_warm",
    "led_cool",
    "metal_halide",
    "fluorescent_linear",
    "mercury",
)


def _spectra_figure(out, preset):
    """Reconstructed (posterior-mean) vs true spectra of typical held-out lamps:
    recommended bands, partition 0, outer fold 0, surface unknown, the first
    scene of each lamp."""
    import matplotlib

    matplotlib.use("Agg")
    import jax.numpy as jnp
    import matplotlib.pyplot as plt

    from bandopt import inversion as inv_mod
    from bandopt.search import get_context

    ctx = get_context(preset, None, 0, "auto")
    bands = band_set("recommended")
    rad = ctx.radiance(bands)
    s = ctx.splits[0]
    inv = inv_mod.fit_for_context(ctx, bands, rad, s.train, s.inner)
    lamps, _, _, _ = inv_mod.context_setup(ctx)
    grid = ctx.wavelength_nm
    picks = []
    for c in TYPICAL:
        test = [i for i in s.test if lamps.level2[i] == c]
        if test:
            picks.append(test[0])
    fig, axes = plt.subplots(2, 3, figsize=(13, 7), sharex=True)
    resp = np.asarray(bands.response(jnp.asarray(grid)))
    for ax, lamp in zip(axes.flat, picks, strict=False):
        row = int(np.flatnonzero(ctx.table.lamp_of == lamp)[0])
        rec = inv.reconstruct(rad[row : row + 1])[0]
        res = inv.predict(rad[row : row + 1])
        true = lamps.spectra[lamp]
        ax.plot(grid, true / true.max(), "k", lw=1, label="true (measured)")
        ax.plot(grid, rec / true.max(), "C0", lw=1, label="reconstructed")
        for r in resp:
            ax.fill_between(grid, 0, r / r.max() * 0.15, color="C1", alpha=0.15, lw=0)
        e = res.estimate[0]
        t = ctx.table.truth[lamp]
        ax.set_title(
            f"{lamps.level2[lamp]}: LER {t[0]:.0f} -> {e[0]:.0f} lm/W, "
            f"CCT {t[2]:.0f} -> {e[2]:.0f} K",
            fontsize=8,
        )
        ax.set_ylabel("spectral flux per lumen [rel. to true peak]")
        ax.set_xlabel("wavelength [nm]")
        ax.legend(fontsize=7, loc="upper left")
    fig.suptitle("Held-out lamps: inversion's posterior-mean spectrum (bands shaded)")
    fig.tight_layout()
    fig.savefig(out / "spectra.png", dpi=80)
    plt.close(fig)


def _coverage(summary, unseen) -> dict:
    """Interval coverage of the inversion (fraction of true values inside the
    90 % interval), held-out lamps per band set / surface, and unseen types."""
    out = {"nominal_coverage": 0.9, "held_out_lamps": {}, "unseen_types": {}}
    for r in summary:
        if r["estimator"] not in INVERSIONS:
            continue
        key = f"{r['band_set']}/{r['surface']}"
        if r["estimator"] != "inversion":
            key += f"/{r['estimator']}"
        out["held_out_lamps"][key] = {
            f"{m}_coverage": r.get(f"{m}_covered") for m in ("LER", "G", "CCT")
        }
    for name, u in (unseen or {}).items():
        out["unseen_types"][name] = {
            f"{m}_coverage": u["overall"].get(f"{m}_covered")
            for m in ("LER", "G", "CCT")
        }
    return out


def readme_text(summary, paired, unseen, variants=()) -> str:
    """The results/README.md section, every number read from the summaries."""
    lines = [
        "## Estimation on unseen lamps (`results/estimate/`, `make estimate`)",
        "",
        "Held-out measured lamps (nested, lamp-grouped, class-stratified; the same "
        "folds for every row), class-balanced MAE, mean ± SD over "
        f"{summary[0]['partitions'] if summary else 0} lamp partitions; CCT in K "
        "(a null CCT counts as 25000 K) and mired. Inversion: surface unknown / "
        "class known / measured by Sentinel-2; its band-error scale σ_rel chosen "
        f"on the inner folds by held-out metric error (`inversion`) or by "
        f"held-out log evidence (`{EVIDENCE}`). Coverage: fraction of true values "
        "inside the 90 % intervals. "
        + _training_sentence(summary)
        + " Generated by `python -m experiments.estimate "
        "--summarise-only` from `summary.json`.",
        "",
        "| band set | estimator | surface | LER [lm/W] | G | CCT [K] | CCT [mired] "
        "| coverage LER/G/CCT | level-1 right | unexplained | out of range |",
        "|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for r in summary:
        cov = "/".join(
            "n/a" if r.get(f"{m}_covered") is None else f"{r[f'{m}_covered']:.2f}"
            for m in ("LER", "G", "CCT")
        )
        l1 = "n/a" if r.get("level1_correct") is None else f"{r['level1_correct']:.2f}"
        un = "n/a" if r.get("unexplained") is None else f"{r['unexplained']:.3f}"
        lines.append(
            f"| {r['band_set']} | {r['estimator']} | {r['surface']} | "
            f"{fmt_cell(r, 'LER', 1)} | {fmt_cell(r, 'G', 3)} | "
            f"{fmt_cell(r, 'CCT', 0)} | {fmt_cell(r, 'CCT_mired', 1)} | {cov} | "
            f"{l1} | {un} | {r['out_of_range']} |"
        )
    if paired:
        lines += [
            "",
            "Paired differences (reference sensor minus recommended, by partition; "
            "positive = the reference sensor is worse):",
            "",
            "| vs | estimator | surface | LER | G | CCT [K] |",
            "|---|---|---|---|---|---|",
        ]
        for p in paired:
            cells = diff_cells(p)
            lines.append(
                f"| {p['band_set']} | {p['estimator']} | {p['surface']} | "
                + " | ".join(cells)
                + " |"
            )
    if variants:
        lines += [
            "",
            "What modelled training lamps, the evidence rule for σ_rel and the "
            "told Moon change "
            "(variant minus base estimator, same band set and folds, by partition; "
            "positive = the variant is worse; `estimator_paired.json`):",
            "",
            "| band set | variant | vs | surface | LER | G | CCT [K] |",
            "|---|---|---|---|---|---|---|",
        ]
        for p in variants:
            cells = diff_cells(p)
            lines.append(
                f"| {p['band_set']} | {p['estimator']} | {p['vs']} | {p['surface']} | "
                + " | ".join(cells)
                + " |"
            )
    for name, u in (unseen or {}).items():
        o = u["overall"]
        n_u = u.get("modelled_per_class", 0)
        est_u = (
            f"{MODELS}, {n_u} modelled lamps per class calibrated on the training "
            "classes only"
            if n_u
            else (f"{MOON}, the Moon told" if u.get("moon") else "inversion")
        )
        base = name.removesuffix("+models").removesuffix("+moon")
        lines += [
            "",
            f"Unseen lamp types ({base}, {est_u}, surface "
            "unknown; each scored "
            "class held out in turn, its lamps scored by a model that never saw "
            f"the class): coverage LER {o['LER_covered']:.2f}, G "
            f"{o['G_covered']:.2f}, CCT {o['CCT_covered']:.2f}; level-1 type right "
            f"{o['level1_correct']:.2f} (where the family is still in the prior: "
            f"{o['level1_correct_where_family_in_prior']:.2f}); unexplained "
            f"{o['unexplained']:.2f}; estimates outside the physical range: "
            f"{o['out_of_range']}. Per class: `unseen_types.json`.",
        ]
        lines += where_lines(u.get("by_class"))
    return "\n".join(lines) + "\n"


def _training_sentence(summary) -> str:
    """Which lamps trained which rows (scoring: measured lamps only)."""
    n = max((r.get("modelled_per_class", 0) for r in summary), default=0)
    if not n:
        return (
            "Training and scoring use measured lamps only (no modelled lamp spectra)."
        )
    from bandopt.inversion import MIN_CALIBRATION_LAMPS, MODELLED_CLASSES

    return (
        "Scoring uses measured lamps only. Rows "
        f"`{MODELS}` (in the prior), `ridge+models` and `kernel+models` (among "
        f"the training rows) also train on {n} modelled lamps per class of "
        f"{', '.join(MODELLED_CLASSES)} (physical lamp models, `bandopt.lampmodels`; "
        f"classes with >= {MIN_CALIBRATION_LAMPS} measured training lamps), "
        "calibrated on each fit's measured training lamps only; every other row "
        "trains on measured lamps only (no modelled lamp spectra)."
    )


def _recommendation(summary, coverage) -> dict:
    rows = {
        f"{r['band_set']}/{r['estimator']}/{r['surface']}": {
            k: r.get(k)
            for k in (
                "LER",
                "LER_sd",
                "G",
                "G_sd",
                "CCT",
                "CCT_sd",
                "CCT_mired",
                "level1_correct",
                "partitions",
            )
        }
        for r in summary
    }
    for r in summary:  # runs with modelled lamps say so per row
        if "modelled_per_class" in r:
            key = f"{r['band_set']}/{r['estimator']}/{r['surface']}"
            rows[key]["modelled_per_class"] = r["modelled_per_class"]
    return {
        "estimator": "inversion (bandopt.inversion), surface unknown, is the default "
        "of bandopt evaluate; it tells the inversion each scene's Moon brightness "
        f"(rows {MOON}), holds same-class blends of the library lamps in its "
        "prior (scored in results/estimate_mix/summary.json, rows "
        "inversion-moon-mix), estimates each metric under its own band-error "
        "model (scored in results/estimate_noise/summary.json, rows "
        "inversion-moon-mix-metric), gives 90 % intervals in the narrowest "
        "calibrated unit (results/estimate_intervals/summary.json, rows "
        "inversion-moon-mix-metric-narrow) and also holds shifted copies of the "
        "direct-emission LEDs and the library's modelled incandescent (Planck) "
        "spectra in its prior (results/estimate_defaults/summary.json, rows "
        "inversion-moon-mix-metric-narrow-shift-planck; modelled spectra train, "
        "never score). Its error on lamps its prior holds, against the same lamps "
        "held out, and against the library's size: results/estimate_library/"
        "summary.json (rows ending '(in library)' and '(held out)', "
        "library_size); your own measured lamps go into its prior with "
        "bandopt evaluate --prior-lamps",
        "class_balanced_mae": rows,
        "coverage": coverage,
        "source": "results/estimate/summary.json",
    }


ESTIMATOR_COLOURS = {
    "inversion": "C0",
    "ridge": "C1",
    "kernel": "C2",
    MODELS: "C3",
    "ridge+models": "C4",
    "kernel+models": "C5",
    EVIDENCE: "C6",
    MOON: "C8",
}
COLOUR_NAMES = {
    "C0": "blue",
    "C1": "orange",
    "C2": "green",
    "C3": "red",
    "C4": "purple",
    "C5": "brown",
    "C6": "pink",
    "C8": "olive",
}


def _figures(summary, unseen, out, preset):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.patches import Patch

    units = {"LER": "lm/W", "G": "1", "CCT": "K"}
    # one horizontal bar per row, grouped by band set, labels on the left
    rows = sorted(summary, key=lambda r: (r["band_set"], r["estimator"], r["surface"]))
    n = len(rows)
    fig, axes = plt.subplots(
        1, 3, figsize=(15, 1.5 + 0.22 * n), sharey=True, squeeze=False
    )
    y = np.arange(n)[::-1]
    labels = [f"{r['band_set']} · {r['estimator']} / {r['surface']}" for r in rows]
    colours = [ESTIMATOR_COLOURS.get(r["estimator"], "C7") for r in rows]
    for ax, m in zip(axes[0], ("LER", "G", "CCT"), strict=True):
        v = [np.nan if r.get(m) is None else r[m] for r in rows]
        e = [r.get(f"{m}_sd") or 0.0 for r in rows]
        ax.barh(y, v, xerr=e, color=colours, capsize=2)
        ax.set_yticks(y, labels, fontsize=7)
        ax.set_xlabel(f"class-balanced MAE {m} [{units[m]}]")
        ax.set_title(f"{m}: mean ± SD over partitions", fontsize=10)
        ax.grid(axis="x", alpha=0.3)
        for k in range(1, n):  # a line between band sets
            if rows[k]["band_set"] != rows[k - 1]["band_set"]:
                ax.axhline(y[k] + 0.5, color="0.6", lw=0.6)
    present = {r["estimator"] for r in rows}
    handles = [
        Patch(color=c, label=e) for e, c in ESTIMATOR_COLOURS.items() if e in present
    ]
    fig.legend(
        handles=handles,
        loc="lower center",
        ncol=len(handles),
        fontsize=8,
        title="estimator (+models: modelled lamps also train)",
        title_fontsize=8,
        frameon=False,
    )
    fig.suptitle(f"Held-out measured lamps (preset {preset})")
    fig.tight_layout(rect=(0, 1.2 / (1.5 + 0.22 * n), 1, 1))
    fig.savefig(out / "errors.png", dpi=90, bbox_inches="tight")  # long labels
    plt.close(fig)

    inv_rows = [r for r in summary if r["estimator"] in INVERSIONS]
    fig, ax = plt.subplots(figsize=(11, 5))
    w = 0.25
    xx = np.arange(len(inv_rows))
    for j, m in enumerate(("LER", "G", "CCT")):
        ax.bar(
            xx + (j - 1) * w,
            [r.get(f"{m}_covered", np.nan) for r in inv_rows],
            w,
            label=m,
        )
    ax.axhline(0.9, color="k", ls="--", lw=1, label="nominal 90 %")
    ax.axhline(0.8, color="r", ls=":", lw=1, label="goal >= 80 %")
    ax.set_xticks(
        xx,
        [
            f"{r['band_set']}/{r['surface']}"
            + {MODELS: "/+models", EVIDENCE: "/evidence-σ", MOON: "/Moon told"}.get(
                r["estimator"], ""
            )
            for r in inv_rows
        ],
        rotation=45,
        ha="right",
        fontsize=7,
    )
    ax.set_ylabel("true values inside the 90 % interval [fraction]")
    ax.set_ylim(0, 1.05)
    ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=7)
    ax.set_title("Interval coverage on held-out lamps (inversion)")
    fig.tight_layout()
    fig.savefig(out / "coverage.png", dpi=90)
    plt.close(fig)
    if unseen:
        fig, ax = plt.subplots(figsize=(9, 4.5))
        width = 0.8 / len(unseen)
        for j, (name, u) in enumerate(unseen.items()):
            cls = list(u["by_class"])
            ax.bar(
                np.arange(len(cls)) + (j - (len(unseen) - 1) / 2) * width,
                [u["by_class"][c]["level1_correct"] for c in cls],
                width,
                label=name,
            )
            ax.set_xticks(np.arange(len(cls)), cls, rotation=45, ha="right", fontsize=7)
        ax.axhline(0.9, color="r", ls=":", lw=1, label="goal 90 %")
        ax.set_ylabel("level-1 type right (fraction of lamps) [1]")
        ax.set_title("Held-out lamp classes (the class is absent from the prior)")
        ax.legend(fontsize=7)
        fig.tight_layout()
        fig.savefig(out / "unseen_level1.png", dpi=90)
        plt.close(fig)


if __name__ == "__main__":
    raise SystemExit(main())
