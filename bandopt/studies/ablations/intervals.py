"""Narrower 90 % intervals at the same coverage: the conformal unit.

The inversion's 90 % interval is its posterior 5-95 % range widened by a
split-conformal factor times a unit. Until now the unit was the posterior's
half-width: a pixel whose posterior is broad gets a very wide interval, and
one whose posterior sits on a wrong lamp needs a large factor, which every
broad pixel then pays for. This scores `inversion-moon-mix-metric` (the
estimator of `make study NAME=estimate-noise`: blends in the prior, the Moon told, one
band-error model per metric; unit = half-width) against
`inversion-moon-mix-metric-narrow`, the same fit whose unit is the
half-width plus an offset chosen per metric from `INTERVAL_OFFSET_GRID`
(fractions of the metric's spread over the training lamps) as the one whose
calibrated intervals are narrowest on the inner folds' held-out lamps
(`fit_inversion(interval_offsets=)`). Both come from one fit: the same
estimates, types and flags; only the intervals differ. Surface unknown, our
bands and the two best reference sensors, the scenes, lamp partitions and
folds of `make estimate`, paired by partition; and on unseen lamp types
(recommended bands, partition 0, intervals calibrated on training classes
held out in turn, as `bandopt evaluate` by default).

    make study NAME=estimate-intervals [ARGS="--resume ..."]

Writes `records.jsonl`, `summary.json`, `intervals.png`, `manifest.json`
and the `estimate-intervals` section of `results/README.md` (default output
only), as every study does (`bandopt.studies.run`). Measured lamps only
score; the blends are built from each fit's training lamps only.
"""

from pathlib import Path

import numpy as np

from .._study import UNKNOWN_ONLY, Study
from .._text import base_paired_lines, fmt_cell


BASE, NARROW = "inversion-moon-mix-metric", "inversion-moon-mix-metric-narrow"
"""The same fit, its intervals in units of the posterior's half-width, and
in units of half-width plus the narrowest calibrated offset."""

GRID = (0.0, 0.01, 0.03, 0.1, 0.3, 1.0, 3.0, 10.0)
"""`bandopt.inversion.INTERVAL_OFFSET_GRID` (checked by the tests; named here
so `--help` needs no JAX)."""

WIDTH_COLUMNS = (
    "LER_width",
    "G_width",
    "CCT_width",
    "CCT_width_mired",
    "LER_covered",
    "G_covered",
    "CCT_covered",
)
"""Summary columns compared by partition, narrow minus half-width unit."""

METRIC_UNITS = (("LER", "lm/W", 0), ("G", "1", 3), ("CCT", "K", 0))


def coverage_by_width(records) -> dict:
    """Recommended bands: held-out lamps grouped by the quartile of their
    half-width intervals' mean width (per metric), the mean coverage under
    each unit per quartile (narrowest posteriors first): whether the
    narrowest unit moves the misses onto broad posteriors."""

    def by_lamp(est: str) -> dict:
        return {
            (r["partition"], r["fold"], r["lamp"]): r
            for r in records
            if r["band_set"] == "recommended" and r["estimator"] == est
        }

    base, narrow = by_lamp(BASE), by_lamp(NARROW)
    out = {}
    for m, _, _ in METRIC_UNITS:
        ks = [k for k, r in base.items() if r.get(f"{m}_width") is not None]
        if len(ks) < 4 or any(k not in narrow for k in ks):
            continue
        w = np.array([base[k][f"{m}_width"] for k in ks])
        quart = np.minimum((np.argsort(np.argsort(w)) * 4) // len(ks), 3)
        out[m] = {}
        for unit, src in (("half-width", base), ("narrowest", narrow)):
            cov = np.array([src[k][f"{m}_covered"] for k in ks])
            out[m][unit] = [float(cov[quart == i].mean()) for i in range(4)]
    return out


def _lowest_class(by_class: dict) -> str:
    """' Lowest held-out class: ...' per metric (the class whose true values
    the intervals hold least often), or '' without classes."""
    parts = []
    for m, _, _ in METRIC_UNITS:
        cov = {c: r[f"{m}_covered"] for c, r in by_class.items()
               if r.get(f"{m}_covered") is not None}  # fmt: skip
        if cov:
            c = min(cov, key=cov.get)
            parts.append(f"{m} {c} {cov[c]:.2f}")
    return f" Lowest held-out class: {', '.join(parts)}." if parts else ""


def readme_text(summary: dict) -> str:
    lines = [
        "## Narrower 90 % intervals at the same coverage "
        "(`results/estimate_intervals/`, `make study NAME=estimate-intervals`)",
        "",
        "The scenes, lamp partitions and folds of `make estimate`; surface "
        "unknown, the Moon told, blends in every prior, one band-error model per "
        "metric (as `make study NAME=estimate-noise`); "
        f"{summary['partitions']} partitions, "
        "class-balanced over held-out measured lamps, mean ± SD over partitions. "
        "The interval is the posterior 5-95 % range widened by a conformal factor "
        f"times a unit. `{BASE}`: the unit is the posterior's half-width. "
        f"`{NARROW}`: half-width plus an offset, per metric the one of "
        f"{', '.join(f'{g:g}' for g in summary['offset_grid'])} x the metric's "
        "spread over the training lamps whose calibrated intervals are narrowest "
        "on the inner folds' held-out lamps. One fit gives both: the estimates "
        "are the same. Width: mean of upper − lower bound. Generated from "
        "`summary.json`.",
        "",
        "| band set | intervals | coverage LER/G/CCT | width LER [lm/W] | width G "
        "| width CCT [K] |",
        "|---|---|---|---|---|---|",
    ]
    for r in summary["rows"]:
        cov = "/".join(
            "n/a" if r.get(f"{m}_covered") is None else f"{r[f'{m}_covered']:.2f}"
            for m, _, _ in METRIC_UNITS
        )
        lines.append(
            f"| {r['band_set']} | {r['estimator']} | {cov} | "
            + " | ".join(fmt_cell(r, f"{m}_width", nd) for m, _, nd in METRIC_UNITS)
            + " |"
        )
    lines += [
        "",
        f"Paired by partition, `{NARROW}` minus `{BASE}` (negative = narrower):",
        "",
        "| band set | width LER [lm/W] | width G | width CCT [K] | coverage "
        "LER | coverage G | coverage CCT |",
        "|---|---|---|---|---|---|---|",
    ]
    lines += base_paired_lines(
        summary["paired"],
        BASE,
        [(f"{m}_width", nd) for m, _, nd in METRIC_UNITS]
        + [(f"{m}_covered", 2) for m, _, _ in METRIC_UNITS],
    )
    by_width = (summary.get("extra") or {}).get("coverage_by_width") or {}
    if by_width:
        cells = "; ".join(
            f"{m} "
            + " → ".join(
                "/".join(f"{x:.2f}" for x in v[unit])
                for unit in ("half-width", "narrowest")
            )
            for m, v in by_width.items()
        )
        lines += [
            "",
            "Coverage of held-out lamps (recommended bands, per lamp, all "
            "partitions) by quartile of their half-width intervals' width, "
            f"narrowest posteriors first, half-width unit → narrowest: {cells}.",
        ]
    for label, u in (summary.get("unseen_types") or {}).items():
        o = u["overall"]
        widths = ", ".join(
            f"{m} {o[f'{m}_width']:.{nd}f}" + ("" if unit == "1" else f" {unit}")
            for m, unit, nd in METRIC_UNITS
            if o.get(f"{m}_width") is not None
        )
        if o.get("CCT_width_mired") is not None:
            widths += f" ({o['CCT_width_mired']:.0f} mired)"
        lines += [
            "",
            f"Unseen lamp types (recommended bands, `{label}`; partition 0, each "
            "scored class held out in turn, intervals calibrated on training "
            f"classes held out in turn): coverage LER {o['LER_covered']:.2f}, G "
            f"{o['G_covered']:.2f}, CCT {o['CCT_covered']:.2f}; mean width "
            f"{widths}; out of range {o['out_of_range']}."
            + _lowest_class(u.get("by_class") or {}),
        ]
    return "\n".join(lines) + "\n"


def figure(summary: dict, path: Path) -> None:
    """Mean interval width and coverage per band set, both units, mean ± SD
    over partitions; the nominal 0.90 marked."""
    import matplotlib  # plotting only: start-up time

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt  # after matplotlib.use("Agg")

    bands = list(dict.fromkeys(r["band_set"] for r in summary["rows"]))
    by = {(r["band_set"], r["estimator"]): r for r in summary["rows"]}
    fig, axes = plt.subplots(2, 3, figsize=(13, 5.5))
    y = np.arange(len(bands))[::-1]
    for j, (m, unit, _) in enumerate(METRIC_UNITS):
        for row, (col, label) in enumerate(
            ((f"{m}_width", f"mean 90 % interval width {m} [{unit}]"),
             (f"{m}_covered", f"coverage {m} (held-out lamps)"))
        ):  # fmt: skip
            ax = axes[row, j]
            for k, (est, colour) in enumerate(((BASE, "C9"), (NARROW, "C2"))):
                v = [by.get((b, est), {}).get(col) for b in bands]
                e = [by.get((b, est), {}).get(f"{col}_sd") or 0.0 for b in bands]
                v = [np.nan if x is None else x for x in v]
                ax.barh(y + 0.2 - 0.4 * k, v, height=0.4, xerr=e, color=colour,
                        capsize=2, label=est)  # fmt: skip
            if row == 1:
                ax.axvline(0.9, color="k", lw=0.8, ls="--")
                ax.set_xlim(0.5, 1.0)
            ax.set_yticks(y, bands if j == 0 else [""] * len(bands), fontsize=8)
            ax.set_xlabel(label, fontsize=8)
            ax.grid(axis="x", alpha=0.3)
    handles, labels = axes[0, 0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="lower center", ncol=2, fontsize=8, frameon=False)
    fig.suptitle(summary.get("title", ""), fontsize=10)
    fig.tight_layout(rect=(0, 0.05, 1, 0.95))
    fig.savefig(path, dpi=110)
    plt.close(fig)


STUDY = Study(
    name="estimate-intervals",
    out="results/estimate_intervals",
    heading="## Narrower 90 % intervals at the same coverage",
    band_sets=dict(UNKNOWN_ONLY),
    estimators=(BASE, NARROW),
    pairs=((NARROW, BASE),),
    unseen=(f"{NARROW}-loco",),
    title="Held-out measured lamps, surface unknown, Moon told: 90 % intervals "
    "in units of the posterior's half-width vs half-width + narrowest offset",
    oracle=False,
    readme=readme_text,
    description=__doc__.splitlines()[0],
    paired_columns=WIDTH_COLUMNS,
    figure=figure,
    figure_name="intervals.png",
    extra=lambda records: {"coverage_by_width": coverage_by_width(records)},
)
"""The study (`bandopt.studies.Study`)."""
