"""Mixtures in the prior: what fills the gaps between the library's lamps (issue 12).

The inversion's posterior is a weighted set of measured training lamps. Told
the test lamp itself (in its prior), its error on the scenes of `make
estimate` drops to ~0 (0.04 lm/W): the scene (surface, atmosphere, Moon) is
not what limits it; the prior's coverage of lamp space is. This scores the
told-Moon inversion (`inversion-moon`) against the same inversion whose
priors also hold pairwise same-class mixtures of their own lamps
(`inversion-moon-mix`, `bandopt.inversion.mixture_lamps`), on the scenes,
lamp partitions and folds of `make estimate`, for the recommended bands and
the reference sensors (same estimators for every band set), and on unseen
lamp types (each scored class held out; recommended bands, partition 0).
`experiments.estimate_noise` runs this study's machinery (`Study`) on its
own configuration.

    python -m experiments.estimate_mix [--partitions 4] [--out DIR] [--resume]

Writes `records.jsonl` (one line per test lamp; resumable per (partition,
band set)), `summary.json` (class-balanced MAE, coverage and level-1 per
band set, estimator and surface mode, mean ± SD over partitions; paired
differences: mix − no mix per band set, reference − recommended per
estimator; the unseen-types study), `errors.png`, `manifest.json` and the
`estimate-mix` section of `results/README.md` (default output only).
Measured lamps only score; the mixtures are built from each fit's training
lamps only and never score.
"""

import argparse
import dataclasses
import json
import sys
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np

from experiments.estimate import (
    _by_class,
    _fmt,
    _overall,
    band_set,
    diff_cells,
    load_records,
    where_lines,
)


BAND_SETS = {
    "recommended": ("unknown", "class", "measured"),
    "sdgsat-1": ("unknown", "class", "measured"),
    "nightsat": ("unknown",),
}
"""Band sets and the surface modes each is scored in (the two with every
mode in `make estimate`, and its best reference sensor there)."""
UNKNOWN_ONLY = {b: ("unknown",) for b in BAND_SETS}
"""The same band sets, surface unknown only (the studies after
`make estimate-noise`: our bands and the two best reference sensors)."""
ESTIMATORS = ("inversion-moon", "inversion-moon-mix")
"""The told-Moon inversion without and with mixtures in its priors."""
PAIRS = (("inversion-moon-mix", "inversion-moon"),)
"""(variant, base) estimators compared paired by partition."""
UNSEEN = (
    ("inversion-moon", 0, "lamps", "error"),
    ("inversion-moon-mix", None, "lamps", "error"),
    ("inversion-moon-mix-loco", None, "classes", "error"),
)
"""Unseen-types runs: label, mixtures (None: `MIX_PAIRS`), interval
calibration (`fit_inversion(calibration=)`; "classes" with mixtures is what
`bandopt evaluate` does by default) and `σ_rel` rule (`SIGMA_RULES`;
"per-metric" also chooses the floor from `FLOOR_GRID`); optionally a fifth,
the interval offsets (`fit_inversion(interval_offsets=)`; several: the
offset-0 intervals of the same fit are reported too, as "LABEL (offset 0)"),
and a sixth, further keyword arguments of `leave_one_class_out` (e.g.
`{"peak_shifts": ...}`, `{"planck": True}`; default none)."""


def unseen_options(run: tuple) -> tuple:
    """An unseen-types run's (interval offsets, further keyword arguments),
    the optional fifth and sixth fields (defaults `(0.0,)` and `{}`)."""
    rest = run[4:]
    return (
        tuple(rest[0]) if rest else (0.0,),
        dict(rest[1]) if len(rest) > 1 else {},
    )


def _by_intervals(recs) -> dict:
    """Unseen-types records by their `"intervals"` tag (None when untagged:
    one kind of interval), in order of first appearance."""
    out: dict = {}
    for r in recs:
        out.setdefault(r.get("intervals"), []).append(r)
    return out


def log(msg: str, study: str = "estimate_mix") -> None:
    """Progress line on stderr, `[study HH:MM:SS] msg`."""
    print(f"[{study} {time.strftime('%H:%M:%S')}] {msg}", file=sys.stderr, flush=True)


def row_line(r: dict, surface: bool = True) -> str:
    """A summary row as a README table line: band set, surface (optional),
    estimator, MAE ± SD per metric, coverage per metric, level-1 right."""
    cov = "/".join(
        "n/a" if r.get(f"{m}_covered") is None else f"{r[f'{m}_covered']:.2f}"
        for m in ("LER", "G", "CCT")
    )
    l1 = r.get("level1_correct")
    where = f"{r['band_set']} | {r['surface']}" if surface else r["band_set"]
    return (
        f"| {where} | {r['estimator']} | "
        f"{_fmt(r, 'LER', 1)} | {_fmt(r, 'G', 3)} | {_fmt(r, 'CCT', 0)} | "
        f"{cov} | {'n/a' if l1 is None else f'{l1:.2f}'} |"
    )


def readme_text(summary: dict) -> str:
    lines = [
        "## Mixtures in the prior (`results/estimate_mix/`, `make estimate-mix`)",
        "",
        "The scenes, lamp partitions and folds of `make estimate`; class-balanced "
        f"MAE, mean ± SD over {summary['partitions']} partitions; measured lamps "
        "only score. Both estimators are told the Moon's brightness. "
        "`inversion-moon-mix` also holds, in every prior it builds, pairwise "
        f"mixtures of that prior's own lamps of one class (up to "
        f"{summary['mix_pairs']} pairs per class, flux fractions "
        f"{', '.join(f'{f:g}' for f in summary['mix_fractions'])}). With the "
        "test lamp itself in the prior the error is ~0 (partition 0, fold 0: "
        f"{summary['oracle']['LER']:.2f} lm/W, G {summary['oracle']['G']:.3f}): "
        "the prior's coverage of lamp space, not the scene, limits the estimate. "
        "Coverage: fraction of true values inside the 90 % intervals. Generated "
        "from `summary.json`.",
        "",
        "| band set | surface | estimator | LER [lm/W] | G | CCT [K] | coverage "
        "LER/G/CCT | level-1 right |",
        "|---|---|---|---|---|---|---|---|",
    ]
    lines += [row_line(r) for r in summary["rows"]]
    lines += [
        "",
        "Paired by partition (positive = the first is worse): mixtures minus "
        "none, same band set and surface; reference minus recommended, same "
        "estimator and surface.",
        "",
        "| compared | estimator | surface | LER [lm/W] | G | CCT [K] |",
        "|---|---|---|---|---|---|",
    ]
    for p in summary["paired"]:
        what = {
            "inversion-moon": f"{p['band_set']}: mix − no mix",
            "inversion-moon-mix": f"{p['band_set']}: per-metric − one error model",
        }.get(p.get("vs"), f"{p['band_set']} − {p['vs']}")
        lines.append(
            f"| {what} | {p['estimator']} | {p['surface']} | "
            + " | ".join(diff_cells(p))
            + " |"
        )
    unseen = summary.get("unseen_types") or {}
    if any(k.endswith("-loco") for k in unseen):
        lines += [
            "",
            "Unseen types: `-loco` calibrates the 90 % intervals on training "
            "classes held out in turn instead of held-out lamps (`bandopt "
            "evaluate`'s default, `--intervals any-type`, with the blends: "
            "`inversion-moon-mix-loco`); the estimates are the same.",
        ]
    for label, u in unseen.items():
        o = u["overall"]
        lines += [
            "",
            f"Unseen lamp types (recommended bands, `{label}`, partition 0; each "
            "scored class held out in turn): coverage LER "
            f"{o['LER_covered']:.2f}, G {o['G_covered']:.2f}, CCT "
            f"{o['CCT_covered']:.2f}; level-1 type right {o['level1_correct']:.2f}; "
            f"unexplained {o['unexplained']:.2f}; out of range {o['out_of_range']}.",
        ]
        lines += where_lines(u.get("by_class"))
    return "\n".join(lines) + "\n"


TITLE = (
    "Held-out measured lamps, Moon told: prior of measured lamps vs with "
    "same-class mixtures (mean ± SD over partitions)"
)
"""The figure's title (a summary's `"title"` replaces it)."""


@dataclasses.dataclass(frozen=True)
class Study:
    """What `main` runs and writes: cross-validated estimators per band set and
    surface modes, paired estimator pairs, unseen-types runs, and where the
    results and the README section go."""

    name: str = "estimate-mix"
    out: str = "results/estimate_mix"
    heading: str = "## Mixtures in the prior"
    band_sets: dict = dataclasses.field(default_factory=lambda: dict(BAND_SETS))
    estimators: tuple = ESTIMATORS
    pairs: tuple = PAIRS
    unseen: tuple = UNSEEN
    title: str = TITLE
    oracle: bool = True
    readme: Callable[[dict], str] | None = None
    description: str = ""
    paired_columns: tuple = ()
    figure: Callable[[dict, Path], None] | None = None
    figure_name: str = "errors.png"
    extra: Callable[[list], dict] | None = None


def figure(summary: dict, path: Path) -> None:
    """Class-balanced MAE per band set and surface mode, without and with
    mixtures, mean ± SD over partitions."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    keys = []
    for r in summary["rows"]:
        k = (r["band_set"], r["surface"])
        if k not in keys:
            keys.append(k)
    by = {(r["band_set"], r["surface"], r["estimator"]): r for r in summary["rows"]}
    height = 1.8 + 0.45 * len(keys)
    fig, axes = plt.subplots(1, 3, figsize=(14, height), sharey=True)
    y = np.arange(len(keys))[::-1]
    for ax, (m, unit) in zip(
        axes, (("LER", "lm/W"), ("G", "1"), ("CCT", "K")), strict=True
    ):
        estimators = summary.get("estimators", ESTIMATORS)
        colours = ("C8", "C9", "C2")[: len(estimators)]
        for j, (est, colour) in enumerate(zip(estimators, colours, strict=True)):
            v = [by.get((*k, est), {}).get(m) for k in keys]
            e = [by.get((*k, est), {}).get(f"{m}_sd") or 0.0 for k in keys]
            v = [np.nan if x is None else x for x in v]
            off = 0.4 * (len(estimators) - 1) / 2 - 0.4 * j
            ax.barh(y + off, v, height=0.8 / len(estimators), xerr=e,
                    color=colour, capsize=2, label=est)  # fmt: skip
        ax.set_yticks(y, [f"{b} / {s}" for b, s in keys], fontsize=8)
        ax.set_xlabel(f"class-balanced MAE {m} [{unit}]")
        ax.grid(axis="x", alpha=0.3)
    handles, labels = axes[0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="lower center", ncol=3, fontsize=8, frameon=False)
    fig.suptitle(summary.get("title", TITLE), fontsize=10)
    fig.subplots_adjust(
        left=0.12, right=0.98, top=1 - 0.55 / height, bottom=1.0 / height, wspace=0.08
    )
    fig.savefig(path, dpi=120, bbox_inches="tight")
    plt.close(fig)


def oracle(ctx, bands) -> dict:
    """Partition 0, outer fold 0, recommended bands, Moon told, surface
    unknown: the error with each test lamp in the prior itself (σ_rel 0.003),
    the floor the scene leaves."""
    from bandopt import inversion as inv_mod
    from bandopt.folds import class_balanced_weights

    lamps, always, cond, _ = inv_mod.context_setup(ctx)
    rad = ctx.radiance(bands)
    w = inv_mod.band_weights_on(bands, ctx.wavelength_nm)
    row_lamp = np.asarray(ctx.table.lamp_of)
    s = ctx.splits[0]
    rows = np.flatnonzero(np.isin(row_lamp, s.test))
    moon = inv_mod.context_moon(ctx)
    prior = lamps.take(np.concatenate([s.train, s.test]))
    prior = prior if always is None else prior + always
    inv = inv_mod.build_inversion(
        prior, w, cond, inv_mod._basis(ctx.wavelength_nm), "unknown", 0.003
    )
    est = inv.predict(rad[rows], None, moon[rows]).estimate
    l2 = np.asarray(lamps.level2, object)[s.test]
    wts = class_balanced_weights(l2)
    out = {}
    for m, name in enumerate(("LER", "G")):
        e = np.array(
            [
                np.abs(est[row_lamp[rows] == i, m] - ctx.table.truth[i, m]).mean()
                for i in s.test
            ]
        )
        ok = ctx.table.valid[s.test, m]
        out[name] = float(np.sum(wts[ok] * e[ok]) / wts[ok].sum())
    out["sigma_rel"] = 0.003
    return out


def _planck_used(study: Study) -> bool:
    """Whether any estimator or unseen run of `study` has modelled
    incandescent spectra in its prior."""
    return any("planck" in e for e in study.estimators) or any(
        unseen_options(run)[1].get("planck") for run in study.unseen
    )


def manifest_config(study: Study, partitions: int) -> dict:
    """The manifest's `config` of a run of `study` over `partitions`."""
    from bandopt import inversion as inv_mod

    return {
        "partitions": partitions,
        "study": study.name,
        "band_sets": {k: list(v) for k, v in study.band_sets.items()},
        "estimators": list(study.estimators),
        "mix_pairs_per_class": inv_mod.MIX_PAIRS,
        "mix_fractions": list(inv_mod.MIX_FRACTIONS),
        "floor_grid": list(inv_mod.FLOOR_GRID),
        "sigma_grid": list(inv_mod.SIGMA_REL_GRID),
        "unseen_types": [
            {
                "label": a,
                "mixtures": b,
                "interval_calibration": c,
                "sigma_rule": d,
                "interval_offsets": list(unseen_options(run)[0]),
                "options": {
                    k: list(v) if isinstance(v, tuple) else v
                    for k, v in unseen_options(run)[1].items()
                },
            }
            for run in study.unseen
            for a, b, c, d in [run[:4]]
        ],
        "peak_shifts_nm": list(inv_mod.PEAK_SHIFTS_NM),
        "interval_offset_grid": list(inv_mod.INTERVAL_OFFSET_GRID),
        "scored_lamps": "measured lamps only",
        "training_lamps": "measured lamps and their same-class mixtures"
        + (
            "; wavelength-shifted copies of direct-emission LEDs where the "
            "estimator or unseen run says -shift"
            if any("shift" in e for e in study.estimators)
            or any("peak_shifts" in unseen_options(run)[1] for run in study.unseen)
            else ""
        )
        + (
            "; the library's modelled incandescent spectra (Planck's law) where "
            "the estimator or unseen run says -planck"
            if _planck_used(study)
            else ""
        ),
        "modelled_lamps_used": _planck_used(study),
    }


def keep_unit(rec_path: Path, recs: list[dict]) -> list[dict]:
    """Append a finished unit's records to `rec_path` (a resumable run keeps
    them whatever fails later) and return them."""
    with rec_path.open("a") as fh:
        for r in recs:
            fh.write(json.dumps(r) + "\n")
    return recs


def partition_args(argv, description: str, out: str, unseen: bool = True):
    """The command line of a partitioned, resumable study: `--partitions`,
    `--out` (default `out`), `--resume`, `--only-partitions` and, with
    `unseen`, `--no-unseen`; (args, the partitions to compute)."""
    ap = argparse.ArgumentParser(description=description)
    ap.add_argument("--partitions", type=int, default=4, help="lamp partitions")
    ap.add_argument("--out", default=None, help=f"output (default {out})")
    ap.add_argument(
        "--resume",
        action="store_true",
        help="keep finished (partition, band set) units of records.jsonl",
    )
    if unseen:
        ap.add_argument("--no-unseen", action="store_true", help="skip unseen types")
    ap.add_argument(
        "--only-partitions",
        type=int,
        nargs="+",
        default=None,
        metavar="P",
        help="compute only these partitions' units (to run partitions in "
        "parallel processes with their own --out; concatenate their "
        "records.jsonl and summarise with --resume)",
    )
    args = ap.parse_args(argv)
    if args.partitions < 1:
        ap.error("--partitions must be >= 1.")
    only = args.only_partitions
    if only is not None and any(not 0 <= p < args.partitions for p in only):
        ap.error(f"--only-partitions {only}: each must be in 0..{args.partitions - 1}.")
    if only is not None and args.out is None:
        ap.error("--only-partitions needs its own --out (a partial summary).")
    return args, range(args.partitions) if only is None else only


def main(argv=None, study: Study | None = None) -> int:
    study = Study() if study is None else study
    args, only = partition_args(
        argv, study.description or __doc__.splitlines()[0], study.out
    )

    from bandopt._config import configure

    configure()
    from bandopt import inversion as inv_mod
    from bandopt.provenance import write_manifest
    from bandopt.results import update_readme_section
    from bandopt.search import get_context

    out = Path(args.out or study.out)
    out.mkdir(parents=True, exist_ok=True)
    rec_path = out / "records.jsonl"
    records, done = load_records(rec_path, keep=args.resume, say=log)
    t0 = time.time()
    units = [(p, b) for p in only for b in study.band_sets]
    for j, (p, name) in enumerate(units):
        if (p, name) in done:
            continue
        ctx = get_context("search", None, p, "auto")
        t1 = time.time()
        recs = inv_mod.cross_validate(
            ctx,
            band_set(name),
            estimators=study.estimators,
            surface_modes=study.band_sets[name],
            seed=p,
        )
        for r in recs:
            r.update(partition=p, band_set=name)
        records += keep_unit(rec_path, recs)
        log(
            f"partition {p}, {name}: {time.time() - t1:.0f} s "
            f"({j + 1}/{len(units)} units, {time.time() - t0:.0f} s)"
        )
    summ = inv_mod.summarise(records)
    order = {b: i for i, b in enumerate(study.band_sets)}
    summ.sort(key=lambda r: (order[r["band_set"]], r["surface"], r["estimator"]))
    paired = inv_mod.estimator_differences(
        summ, study.pairs, study.paired_columns or inv_mod.PAIRED_COLUMNS
    )
    for name in list(study.band_sets)[1:]:
        paired += inv_mod.paired_differences(summ, "recommended", name)
    ctx0 = get_context("search", None, 0, "auto")
    rec_bands = band_set("recommended")
    unseen = {}
    if not args.no_unseen:
        for run in study.unseen:
            label, mix, calibration, rule = run[:4]
            offsets, more = unseen_options(run)
            recs = inv_mod.leave_one_class_out(
                ctx0,
                rec_bands,
                moon_known=True,
                mixtures=inv_mod.MIX_PAIRS if mix is None else mix,
                calibration=calibration,
                sigma_rule=rule,
                floor_grid=(
                    inv_mod.FLOOR_GRID
                    if rule == "per-metric"
                    else (inv_mod.SIGMA_FLOOR,)
                ),
                interval_offsets=offsets,
                **more,
            )
            for tag, rs in _by_intervals(recs).items():
                key = label if tag in (None, "narrowest") else f"{label} ({tag})"
                unseen[key] = {"by_class": _by_class(rs), "overall": _overall(rs)}
            log(f"unseen types, {label}: {time.time() - t0:.0f} s")
    summary = {
        "partitions": args.partitions,
        "estimators": list(study.estimators),
        "title": study.title,
        "mix_pairs": inv_mod.MIX_PAIRS,
        "mix_fractions": list(inv_mod.MIX_FRACTIONS),
        "floor_grid": list(inv_mod.FLOOR_GRID),
        "sigma_grid": list(inv_mod.SIGMA_REL_GRID),
        "offset_grid": list(inv_mod.INTERVAL_OFFSET_GRID),
        "peak_shifts_nm": list(inv_mod.PEAK_SHIFTS_NM),
        "oracle": oracle(ctx0, rec_bands) if study.oracle else None,
        "rows": summ,
        "paired": paired,
        "unseen_types": unseen,
        "extra": study.extra(records) if study.extra else None,
        "bands": {"recommended": "results/search/recommended_bands.json"},
        "scored_lamps": "measured lamps only",
        "modelled_lamps_used": _planck_used(study),
    }
    (out / "summary.json").write_text(json.dumps(summary, indent=2) + "\n")
    (study.figure or figure)(summary, out / study.figure_name)
    if args.out is None:
        text = (study.readme or readme_text)(summary)
        update_readme_section(study.name, text, heading=study.heading)
    write_manifest(
        out,
        seed=0,
        config=manifest_config(study, args.partitions),
    )
    log(f"done: {out} ({time.time() - t0:.0f} s)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
