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
        [--band-sets NAME ...] [--no-unseen] [--resume]
        [--modelled-per-class N] [--summarise-only]

Writes `records.jsonl` (one line per test lamp; recomputed from scratch unless
`--resume`, which keeps finished (partition, band set) units of an interrupted
run and skips them), `summary.json/.csv`,
`paired.json` (band sets), `estimator_paired.json` (modelled training lamps
and the evidence rule against their base estimator), `unseen_types.json`,
figures, `coverage.json`, `manifest.json` and (default run) the `estimate`
section of `results/README.md` and the `estimation` part of
recommendation.json (`_estimate_report`). Training uses
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
import time
from pathlib import Path

from .. import inversion as inv_mod
from ..inversion import MIN_CALIBRATION_LAMPS, MODELLED_CLASSES
from ..provenance import add_allow_dirty, refuse_dirty_at_start, write_manifest
from ..results import update_readme_section, update_recommendation
from ..search import get_context
from ..strict_json import strict_dumps
from ._estimate_report import (
    EVIDENCE as EVIDENCE,
    INVERSIONS as INVERSIONS,
    MODELS as MODELS,
    MOON as MOON,
    figures as figures,
    readme_text as readme_text,
    spectra_figure as spectra_figure,
)
from ._text import held_out
from ._units import band_set, keep_unit, load_records, log as _log


DEFAULT_BAND_SETS = ("recommended", "sdgsat-1", "nightsat", "viirs-dnb")
"""Band sets scored by default: our bands and three reference sensors."""
FULL_SURFACE_SETS = ("recommended", "sdgsat-1")
"""Band sets scored with every surface mode (unknown, class known, measured)."""


def log(msg: str) -> None:
    """Progress line on stderr, `[estimate HH:MM:SS] msg`."""
    _log(msg, "estimate")


def run(argv=None) -> int:
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
    add_allow_dirty(ap)
    args = ap.parse_args(argv)
    if args.modelled_per_class < 0:
        ap.error("--modelled-per-class must be >= 0.")

    out = Path(
        args.out or ("results/estimate_quick" if args.quick else "results/estimate")
    )
    refuse_dirty_at_start(ap, args, out)
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
        t0 = time.time()
        records += keep_unit(rec_path, unit(preset, p, name, n_model))
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
    (out / "summary.json").write_text(strict_dumps(summary, indent=2) + "\n")
    (out / "paired.json").write_text(strict_dumps(paired, indent=2) + "\n")
    variants = inv_mod.estimator_differences(summary)
    (out / "estimator_paired.json").write_text(strict_dumps(variants, indent=2) + "\n")
    write_summary_csv(summary, out / "summary.csv")
    unseen = None
    if args.summarise_only and (out / "unseen_types.json").is_file():
        unseen = json.loads((out / "unseen_types.json").read_text())
    elif not args.no_unseen:
        unseen = unseen_types(preset, args.band_sets, n_model)
        (out / "unseen_types.json").write_text(strict_dumps(unseen, indent=2) + "\n")
    figures(summary, unseen, out, preset)
    if "recommended" in args.band_sets:
        spectra_figure(out, preset)
    coverage = interval_coverage(summary, unseen)
    (out / "coverage.json").write_text(strict_dumps(coverage, indent=2) + "\n")
    default_run = args.out is None and not args.quick
    if default_run:
        update_readme_section(
            "estimate",
            readme_text(summary, paired, unseen, variants),
            heading="## Estimation on unseen lamps",
        )
        update_recommendation("estimation", recommendation(summary, coverage))
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
            f"{list(MODELLED_CLASSES)} (bandopt.lampmodels, calibrated on "
            "each fit's measured training lamps) in the rows inversion+models, "
            "ridge+models, kernel+models and the unseen-types entry "
            "recommended+models; never scored (test lamps are measured)"
        )
    write_manifest(out, seed=0, config=config, **kw)
    log(f"done: {out}")
    return 0


def unit(preset: str, p: int, name: str, n_model: int) -> list[dict]:
    """Records of one (partition `p`, band set `name`) unit: the inversion
    (metric and evidence rules, the Moon told) and the ridge and kernel-ridge
    baselines (no kernel for a single band), every surface mode for
    `FULL_SURFACE_SETS`; with `n_model`, also `modelled_estimators` trained
    on `n_model` modelled lamps per rare class (surface unknown)."""
    ctx = get_context(preset, None, p, "auto")
    bands = band_set(name)
    modes = (
        ("unknown", "class", "measured") if name in FULL_SURFACE_SETS else ("unknown",)
    )
    ests = (
        ("inversion", EVIDENCE, MOON, "ridge", "kernel")
        if len(bands.names) > 1
        else ("inversion", EVIDENCE, MOON, "ridge")
    )
    labels = dict(partition=p, band_set=name)
    scores = inv_mod.cross_validate(
        ctx, bands, estimators=ests, surface_modes=modes, seed=p
    )
    if not n_model:
        return [r.as_record(**labels) for r in scores]
    # the plain estimators' records say they had no modelled lamps
    recs = [r.as_record(modelled_per_class=0, **labels) for r in scores]
    modelled = inv_mod.cross_validate(
        ctx,
        bands,
        estimators=modelled_estimators(name, len(bands.names)),
        surface_modes=("unknown",),
        seed=p,
        modelled_per_class=n_model,
    )
    return recs + [r.as_record(**labels) for r in modelled]


def write_summary_csv(summary: list[dict], path: Path) -> None:
    """The summary rows as CSV: band set, estimator, surface, partitions, out
    of range, then each of `inversion.SUMMARY_COLUMNS` and its SD."""
    cols = ["band_set", "estimator", "surface", "partitions", "out_of_range"]
    for c in inv_mod.SUMMARY_COLUMNS:
        cols += [c, f"{c}_sd"]
    with path.open("w", newline="") as fh:
        wr = csv.DictWriter(fh, fieldnames=cols, extrasaction="ignore")
        wr.writeheader()
        wr.writerows(summary)


def _unseen_entry(recs: list[dict], **extra) -> dict:
    """An `unseen_types.json` entry: the records, per held-out class and
    overall (`held_out_by_class`, `held_out_overall`), then `extra`."""
    return {"records": recs, **held_out(recs), **extra}


def unseen_types(preset: str, band_sets, n_model: int) -> dict:
    """Unseen types (partition 0, each scored class held out in turn,
    `inversion.leave_one_class_out`) for the recommended bands and SDGSAT-1
    where in `band_sets`: the Moon fitted (`<band set>`) and told
    (`<band set>+moon`); with `n_model`, the recommended bands with modelled
    lamps in the prior too (`recommended+models`)."""
    ctx = get_context(preset, None, 0, "auto")
    unseen = {}
    tag = {"modelled_per_class": 0} if n_model else {}
    for name in [b for b in ("recommended", "sdgsat-1") if b in band_sets]:
        log(f"unseen types: {name}")
        recs = inv_mod.leave_one_class_out(ctx, band_set(name))
        unseen[name] = _unseen_entry(recs, **tag)
        log(f"unseen types: {name}, the Moon told")
        recs = inv_mod.leave_one_class_out(ctx, band_set(name), moon_known=True)
        unseen[f"{name}+moon"] = _unseen_entry(recs, moon="known per pixel", **tag)
    if n_model and "recommended" in band_sets:
        log("unseen types: recommended, inversion with modelled lamps")
        recs = inv_mod.leave_one_class_out(
            ctx, band_set("recommended"), modelled_per_class=n_model
        )
        unseen["recommended+models"] = _unseen_entry(recs, modelled_per_class=n_model)
    return unseen


def modelled_estimators(band_set_name: str, n_bands: int) -> tuple[str, ...]:
    """Estimators trained on modelled lamps too in a `--modelled-per-class`
    run: the ridge for every band set, the kernel ridge for every band set
    with more than one band (as without models), the inversion for the
    recommended bands only (its prior: the slow part)."""
    out = ("ridge+models",) + (("kernel+models",) if n_bands > 1 else ())
    return ((MODELS,) if band_set_name == "recommended" else ()) + out


def modelled_per_class_of(records) -> int:
    """Modelled lamps per class of a run's `inversion+models` rows (0: a run
    without them)."""
    return max((int(r.get("modelled_per_class", 0)) for r in records), default=0)


def modelled_lamps_config(n_model: int) -> dict:
    """What the manifest says of a run with modelled lamps."""
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


def interval_coverage(summary, unseen) -> dict:
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


def recommendation(summary, coverage) -> dict:
    """The `estimation` part of recommendation.json: the default estimator
    and where its variants are scored, each summary row's class-balanced MAE,
    and the interval `coverage` (`interval_coverage`)."""
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
