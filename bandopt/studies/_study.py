"""A study as a configuration, and the one machinery that runs every study.

`Study` says what is compared: estimators (by name, `inversion.cross_validate`)
per band set and surface modes, the pairs compared paired by partition,
unseen-types runs (each scored class held out in turn), and where results
and the README section go. `run` computes it over lamp partitions, resumable
per (partition, band set) unit, and writes `records.jsonl`, `summary.json`, a
figure, `manifest.json` and (default output only) its README section."""

import dataclasses
import functools
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np

from .. import inversion as inv_mod
from ..estimators import variant
from ..folds import class_balanced_weights
from ..results import DATA_KEY, band_digest, bands_record, data_digest
from ..search import get_context
from ._text import by_intervals, held_out
from ._units import (
    band_set,
    keep_unit,
    load_records,
    log,
    partition_args,
    write_outputs,
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
`make study NAME=estimate-noise`: our bands and the two best reference sensors)."""


@dataclasses.dataclass(frozen=True)
class Study:
    """What `run` computes and writes.

    - `name`: the registry key and README section name; `out` the default
      output folder; `heading` the README section's heading.
    - `band_sets`: band set name (`band_set`) -> surface modes scored.
    - `estimators`: estimator labels of `inversion.cross_validate`;
      `pairs`: (variant, base) labels compared paired by partition.
    - `unseen`: unseen-types runs (each scored class held out in turn,
      `inversion.leave_one_class_out`), each a variant's name
      (`inversion.options_of`: a `LABELLED` name, `-loco` for intervals
      calibrated on classes held out in turn).
    - `title`: the figure's; `oracle`: also the error with each test lamp in
      its own prior (`oracle`); `readme(summary) -> str` the section;
      `description` the command line's; `paired_columns` the summary
      columns paired (default `inversion.PAIRED_COLUMNS`); `figure(summary,
      path)` and `figure_name`; `extra(records) -> dict` more summary.
    - `preset`, `atmospheres`: the scenario set (`search.get_context`);
      the studies use the search's scenes, tests a tiny set."""

    name: str
    out: str
    heading: str
    band_sets: dict
    estimators: tuple
    pairs: tuple
    unseen: tuple
    title: str
    oracle: bool = False
    readme: Callable[[dict], str] | None = None
    description: str = ""
    paired_columns: tuple = ()
    figure: Callable[[dict, Path], None] | None = None
    figure_name: str = "errors.png"
    extra: Callable[[list], dict] | None = None
    preset: str = "search"
    atmospheres: str = "auto"

    def __post_init__(self):
        # every variant is the registry's, so a misspelt one stops here
        for label in (*self.estimators, *self.unseen):
            try:
                variant(label)
            except ValueError as exc:
                raise ValueError(f"study {self.name!r}: {exc}") from None


def figure(summary: dict, path: Path) -> None:
    """Class-balanced MAE per band set and surface mode, without and with
    mixtures, mean ± SD over partitions."""
    import matplotlib  # plotting only: start-up time

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt  # after matplotlib.use("Agg")

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
        estimators = summary["estimators"]
        palette = ("C8", "C9", "C2", "C0", "C1", "C3", "C4", "C5", "C6", "C7")
        colours = [palette[j % len(palette)] for j in range(len(estimators))]
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
    fig.suptitle(summary["title"], fontsize=10)
    fig.subplots_adjust(
        left=0.12, right=0.98, top=1 - 0.55 / height, bottom=1.0 / height, wspace=0.08
    )
    fig.savefig(path, dpi=120, bbox_inches="tight")
    plt.close(fig)


def oracle(ctx, bands) -> dict:
    """Partition 0, outer fold 0, recommended bands, Moon told, surface
    unknown: the error with each test lamp in the prior itself (σ_rel 0.003),
    the floor the scene leaves."""
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
        inv_mod.options_of(label).planck for label in study.unseen
    )


def unseen_records(ctx, bands, label: str) -> list[dict]:
    """Records of the named variant `label` (`inversion.options_of`) on
    unseen lamp types: each scored class of `ctx` held out in turn
    (`inversion.leave_one_class_out`)."""
    opts = inv_mod.options_of(label)
    return inv_mod.leave_one_class_out(
        ctx,
        bands,
        moon_known=opts.moon_told,
        mixtures=opts.mixtures,
        calibration=opts.calibration,
        sigma_rule=opts.sigma_rule,
        floor_grid=opts.floor_grid,
        interval_offsets=opts.interval_offsets,
        peak_shifts=opts.peak_shifts_nm,
        planck=opts.planck,
        tm30=opts.tm30,
    )


def _options_json(opts) -> dict:
    """A variant's options as JSON values (tuples as lists)."""
    return {
        k: list(v) if isinstance(v, tuple) else v
        for k, v in dataclasses.asdict(opts).items()
    }


def manifest_config(study: Study, partitions: int) -> dict:
    """The manifest's `config` of a run of `study` over `partitions`."""
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
            {"label": label, **_options_json(inv_mod.options_of(label))}
            for label in study.unseen
        ],
        "peak_shifts_nm": list(inv_mod.PEAK_SHIFTS_NM),
        "interval_offset_grid": list(inv_mod.INTERVAL_OFFSET_GRID),
        "scored_lamps": "measured lamps only",
        "training_lamps": "measured lamps and their same-class mixtures"
        + (
            "; wavelength-shifted copies of direct-emission LEDs where the "
            "estimator or unseen run says -shift"
            if any("shift" in e for e in study.estimators)
            or any(inv_mod.options_of(u).peak_shifts_nm for u in study.unseen)
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


def run(study: Study, argv=None) -> int:
    """Compute `study` (command line `argv`: `partition_args`) and write its
    outputs; returns the exit status."""
    args, only = partition_args(argv, study.description or study.title, study.out)
    say = functools.partial(log, study=study.name)
    out = Path(args.out or study.out)
    out.mkdir(parents=True, exist_ok=True)
    rec_path = out / "records.jsonl"
    digests = {name: band_digest(band_set(name)) for name in study.band_sets}
    digests[DATA_KEY] = data_digest()
    records, done = load_records(rec_path, keep=args.resume, say=say, digests=digests)
    t0 = time.time()
    units = [(p, b) for p in only for b in study.band_sets]
    for j, (p, name) in enumerate(units):
        if (p, name) in done:
            continue
        ctx = get_context(study.preset, None, p, study.atmospheres)
        t1 = time.time()
        scores = inv_mod.cross_validate(
            ctx,
            band_set(name),
            estimators=study.estimators,
            surface_modes=study.band_sets[name],
            seed=p,
        )
        recs = [r.as_record(partition=p, band_set=name) for r in scores]
        records += keep_unit(rec_path, recs)
        say(
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
    ctx0 = get_context(study.preset, None, 0, study.atmospheres)
    rec_bands = band_set("recommended")
    unseen = {}
    if not args.no_unseen:
        for label in study.unseen:
            recs = unseen_records(ctx0, rec_bands, label)
            for tag, rs in by_intervals(recs).items():
                key = label if tag in (None, "narrowest") else f"{label} ({tag})"
                unseen[key] = held_out(rs)
            say(f"unseen types, {label}: {time.time() - t0:.0f} s")
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
        "bands": {"recommended": bands_record(rec_bands)},
        "scored_lamps": "measured lamps only",
        "modelled_lamps_used": _planck_used(study),
    }
    return write_outputs(
        out,
        summary,
        [(study.figure or figure, study.figure_name)],
        section=(study.name, study.readme, study.heading)
        if args.out is None and study.readme is not None
        else None,
        seed=0,
        config=manifest_config(study, args.partitions),
        say=say,
        t0=t0,
    )
