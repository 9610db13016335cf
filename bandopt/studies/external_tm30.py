"""External check: `bandopt evaluate` on 210 measured lamps the library has
never seen (the IES TM-30-15 set).

People outside the team test bandopt on measured lamps of their own. The
IES TM-30-15 source library (`IES2015`, vendored from LuxPy) holds 210
measured lamps that the library lacks (`bandopt.inversion.tm30_lamps`: the
library's own classification, and its deduplication removed the copies of
library lamps). This runs exactly what such a user runs: each lamp's
measured 380-780 nm spectrum written as a CSV file, and `bandopt evaluate
--bands B --lamps FILE... --json` (in a spawned process, with its defaults:
the inversion trained on every scored library lamp, the TM-30 lamps NOT in
its prior) for our recommended bands and the two best reference sensors,
the same estimator for each. Scored per lamp against the truth computed
from the same spectrum: |error| of LER, G and CCT (a null CCT counts as
25,000 K, as in `make estimate`), whether each 90 % interval holds the
truth, the level-1 family, the `unexplained` flag and estimates outside the
physical range. A lamp evaluate flags `unexplained` has null estimates (not
guessed): it counts in the unexplained rate and as a wrong level-1 family,
not in the errors and coverage. Summaries are class-balanced over the
library's scored level-2 classes (RGB LED mixtures, a class the library
does not score, are reported apart), with a 90 % bootstrap interval over
lamps (resampled within class, `BOOTSTRAP` draws, seed `SEED`); reference
sensors minus ours are paired on the same lamps. Then the same lamps told
the scene's surface (`SURFACE_KNOWN`): evaluate's estimator with our bands
against the library-free direct estimate (`--estimator direct`) with 26
contiguous bands, paired on the same lamps.

`run(argv)` is the command line (`python -m experiments.external_tm30
[--out DIR]`, `make external-tm30`). It writes `lamps.csv` (per lamp and
band set), `summary.json`, `errors.png`, `manifest.json` and the
`external-tm30` section of `results/README.md` (default output only).
Measured lamps only; evaluate's prior holds the library's five modelled
Planck spectra (its default), said in the summary.
"""

import argparse
import csv
import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from ..datasets.lamps import library
from ..provenance import add_allow_dirty, refuse_dirty_at_start
from ._external_tm30_scores import (
    BOOTSTRAP as BOOTSTRAP,
    CCT_NULL_K as CCT_NULL_K,
    METRICS as METRICS,
    RANGE as RANGE,
    SEED as SEED,
    UNSCORED as UNSCORED,
    lamp_rows as lamp_rows,
    paired as paired,
    summarise as summarise,
)
from ._units import CONTIGUOUS, RECOMMENDED, band_set, log as _log, write_outputs


BAND_SETS = {
    "recommended": str(RECOMMENDED),
    "sdgsat-1": "sdgsat-1",
    "nightsat": "nightsat",
}
"""Label -> `bandopt evaluate --bands` argument."""
SURFACE_KNOWN = {
    "recommended, inversion": (str(RECOMMENDED), ()),
    "contiguous-26, direct": ("contiguous-26", ("--estimator", "direct")),
}
"""Label -> (`--bands` argument, other options) of the runs told the scene's
surface (`--surface asphalt`): evaluate's default estimator with our bands,
and the library-free direct estimate (`bandopt.direct`) with 26 contiguous
bands of 20 nm (written as a band-set file for the run)."""


def log(msg: str) -> None:
    """Progress line on stderr, `[external_tm30 HH:MM:SS] msg`."""
    _log(msg, "external_tm30")


def _num(v, digits: int) -> str:
    """`v` to `digits` decimals, "n/a" for None (e.g. every lamp of a class
    flagged unexplained)."""
    return "n/a" if v is None else f"{v:.{digits}f}"


def _fmt_ci(s: dict, k: str, digits: int) -> str:
    ci = s.get(f"{k}_ci90")
    v = s.get(k)
    if v is None:
        return "n/a"
    return f"{v:.{digits}f}" + (
        "" if ci is None else f" [{ci[0]:.{digits}f}, {ci[1]:.{digits}f}]"
    )


def table_row(name: str, s: dict) -> str:
    """A README table line of one run's summary: errors with their 90 %
    bootstrap intervals, coverage, level-1, unexplained, out of range."""
    cov = "/".join(
        "n/a" if s.get(f"{m}_covered") is None else f"{s[f'{m}_covered']:.2f}"
        for m in METRICS
    )
    return (
        f"| {name} | {_fmt_ci(s, 'LER', 1)} | {_fmt_ci(s, 'G', 3)} | "
        f"{_fmt_ci(s, 'CCT', 0)} | {cov} | {s['level1_correct']:.2f} | "
        f"{s['unexplained']:.2f} | {s['out_of_range']} |"
    )


def readme_text(summary: dict) -> str:
    """The `external-tm30` section of `results/README.md` from `summary.json`."""
    sets = summary["band_sets"]
    rec = sets["recommended"]
    lines = [
        f"## External check: `bandopt evaluate` on {summary['lamps']} measured lamps "
        "it has never seen (`results/external_tm30/`, `make external-tm30`)",
        "",
        f"The {summary['lamps']} measured lamps of the IES TM-30-15 source library "
        "that the library lacks (`IES2015`, vendored from LuxPy; copies of library "
        "lamps removed by the library's own rule), each given to `bandopt evaluate "
        "--bands B --lamps FILE... --json` as a user would (its defaults: the "
        "inversion trained on every scored library lamp, these lamps not in its "
        f"prior; one pixel per lamp, {summary['scene']}). Class-balanced over the "
        f"{len(rec['classes'])} scored classes ({', '.join(rec['classes'])}; "
        f"{rec['lamps']} lamps), 90 % bootstrap interval over lamps in brackets; a "
        "null CCT counts as 25,000 K; a lamp flagged `unexplained` (estimates null, "
        "not guessed) counts in that column and as a wrong level-1 family, not in "
        "the errors. Measured lamps only; evaluate's prior holds "
        "the library's five modelled Planck spectra (its default). Generated from "
        "`summary.json`.",
        "",
        "| band set | LER [lm/W] | G | CCT [K] | coverage LER/G/CCT | level-1 right "
        "| unexplained | out of range |",
        "|---|---|---|---|---|---|---|---|",
    ]
    lines += [table_row(name, s) for name, s in sets.items()]
    lines += [
        "",
        "Reference sensors minus recommended bands, paired on the same lamps "
        "(positive: ours is better):",
        "",
        "| compared | LER [lm/W] | G | CCT [K] |",
        "|---|---|---|---|",
    ]
    for name, p in summary["paired"].items():
        lines.append(
            f"| {name} − recommended | {_fmt_ci(p, 'LER', 1)} | {_fmt_ci(p, 'G', 3)} "
            f"| {_fmt_ci(p, 'CCT', 0)} |"
        )
    cells = [
        f"{c} ({v['lamps']}) {_num(v['LER'], 1)} lm/W, G {_num(v['G'], 2)}, "
        f"CCT {_num(v['CCT'], 0)} K, level-1 {v['level1_correct']:.2f}, "
        f"unexplained {v['unexplained']:.2f}"
        for c, v in rec["by_class"].items()
    ]
    lines += ["", "Per class, recommended bands: " + "; ".join(cells) + "."]
    for c, v in rec.get("unscored", {}).items():
        lines.append(
            f"Apart ({c}, a class the library does not score; {v['lamps']} lamps): "
            f"LER {_num(v['LER'], 1)} lm/W, level-1 {v['level1_correct']:.2f}, "
            f"unexplained {v['unexplained']:.2f}."
        )
    lines += surface_known_lines(summary)
    ref = summary.get("in_library_reference")
    if ref:
        lines += [
            "",
            f"For comparison, the same estimator on the library's held-out lamps "
            "(`make study NAME=estimate-defaults`, scenes with surfaces, "
            f"atmospheres and the Moon): {ref}.",
        ]
    return "\n".join(lines) + "\n"


def surface_known_lines(summary: dict) -> list[str]:
    """README lines of the runs told the scene's surface (`SURFACE_KNOWN`):
    their table, and the direct estimate minus the inversion on the same
    lamps."""
    known = summary.get("surface_known")
    if not known:
        return []
    lines = [
        "",
        "Told the scene's surface (`--surface asphalt`): evaluate's estimator with "
        "our bands, and the library-free direct estimate (`--estimator direct`, "
        "`bandopt.direct`: no lamp trains it) with 26 contiguous bands of 20 nm:",
        "",
        "| run | LER [lm/W] | G | CCT [K] | coverage LER/G/CCT | level-1 right "
        "| unexplained | out of range |",
        "|---|---|---|---|---|---|---|---|",
    ]
    lines += [table_row(name, s) for name, s in known.items()]
    p = summary.get("surface_known_paired")
    if p:
        lines += [
            "",
            "Direct (26 bands) minus inversion (our bands), paired on the same "
            f"lamps (negative: the direct estimate is better): LER "
            f"{_fmt_ci(p, 'LER', 1)} lm/W, G {_fmt_ci(p, 'G', 3)}, CCT "
            f"{_fmt_ci(p, 'CCT', 0)} K. The direct estimate has no `unexplained` "
            "flag (no lamp model to reject a pixel); its type is the nearest "
            "library lamp's in band shape.",
        ]
    return lines


def figure(summary: dict, path: Path) -> None:
    """LER / G / CCT error per class, one bar per band set."""
    import matplotlib  # plotting only: start-up time

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt  # after matplotlib.use("Agg")

    sets = summary["band_sets"]
    classes = sets["recommended"]["classes"]
    fig, axes = plt.subplots(1, 3, figsize=(15, 4.2), sharey=True)
    y = np.arange(len(classes))
    h = 0.8 / len(sets)
    for ax, m, unit in zip(axes, METRICS, ("lm/W", "1", "K"), strict=True):
        for j, (name, s) in enumerate(sets.items()):
            v = [s["by_class"][c][m] or 0.0 for c in classes]
            ax.barh(y + j * h, v, height=h, label=name)
        ax.set_yticks(y + h * (len(sets) - 1) / 2, classes)
        ax.set_xlabel(f"mean |error| {m} [{unit}]")
        ax.grid(axis="x", alpha=0.3)
    axes[0].legend(loc="lower right", fontsize=8)
    fig.suptitle(
        f"bandopt evaluate on the {summary['lamps']} measured IES TM-30-15 lamps "
        "the library lacks"
    )
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def lamp_files(lib, keep: list[int], folder: Path) -> list[str]:
    """Write each lamp `keep` of `lib` (read with `extend_nir=False`) as the
    file a user gives `bandopt evaluate --lamps`, `folder/<id>.csv`
    (`wavelength_nm, relative_power`): its measured values over the source
    file's range (`source_range_nm`, 380-780 nm). Where the library cut the
    source's trailing zeros as the end of the measurement (`cut_reason`
    "zeros": values <= 1e-5 of the peak), they are written as 0, as the
    source file holds them: a user's file is not cut. Their paths."""
    files = []
    for i in keep:
        r, v = lib.records[i], np.asarray(lib.values[i], float)
        lo, hi = r.source_range_nm or r.measured_range_nm
        span = (lib.wavelength_nm >= lo) & (lib.wavelength_nm <= hi)
        zeros = (r.cut_reason or "").startswith("zeros")
        after = lib.wavelength_nm > r.measured_range_nm[1]
        cut = span & ~np.isfinite(v) & after & zeros
        v = np.where(cut, 0.0, v)  # the source's zeros after the measured end
        ok = span & np.isfinite(v)
        path = folder / f"{r.id}.csv"
        with path.open("w", newline="") as fh:
            w = csv.writer(fh)
            w.writerow(["wavelength_nm", "relative_power"])
            w.writerows(
                zip(lib.wavelength_nm[ok].tolist(), v[ok].tolist(), strict=True)
            )
        files.append(str(path))
    return files


def run(argv=None) -> int:
    """Compute the check (command line `argv`) and write its outputs;
    returns the exit status."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument(
        "--out", default=None, help="output (default results/external_tm30)"
    )
    add_allow_dirty(ap)
    args = ap.parse_args(argv)

    out = Path(args.out or "results/external_tm30")
    refuse_dirty_at_start(ap, args, out)
    out.mkdir(parents=True, exist_ok=True)
    t0 = time.time()
    lib = library(tm30=True, extend_nir=False)
    keep = [
        i
        for i, r in enumerate(lib.records)
        if r.source_set == "ies_tm30" and r.excluded is None and r.level2 is not None
    ]
    classes = {
        lib.records[i].id: (lib.records[i].level1, lib.records[i].level2) for i in keep
    }
    results, rows_by = {}, {}
    with tempfile.TemporaryDirectory() as tmp:
        files = lamp_files(lib, keep, Path(tmp))
        log(f"{len(files)} lamp files written ({time.time() - t0:.0f} s)")
        for name, bands in BAND_SETS.items():
            t1 = time.time()
            data = _evaluate(bands, files)
            rows_by[name] = lamp_rows(data, classes)
            results[name] = {
                **summarise(rows_by[name]),
                "estimator_description": data["scene"]["estimator_description"],
                "modelled_in_prior": data.get("modelled_in_prior", []),
                "tm30_lamps_in_prior": data.get("tm30_lamps_in_prior", 0),
            }
            scene = data["scene"]
            log(f"{name}: {time.time() - t1:.0f} s")
        known, known_rows = {}, {}
        for label, (bands, options) in SURFACE_KNOWN.items():
            t1 = time.time()
            if bands.startswith(CONTIGUOUS):
                path = Path(tmp) / f"{bands}.json"
                band_set(bands).to_json(path)
                bands = str(path)
            data = _evaluate(bands, files, ["--surface", "asphalt", *options])
            known_rows[label] = lamp_rows(data, classes)
            known[label] = {
                **summarise(known_rows[label]),
                "estimator_description": data["scene"]["estimator_description"],
                "tm30_lamps_in_prior": data.get("tm30_lamps_in_prior", 0),
            }
            log(f"{label}, surface known: {time.time() - t1:.0f} s")
    if any(r["tm30_lamps_in_prior"] for r in [*results.values(), *known.values()]):
        raise RuntimeError(
            "the TM-30 lamps were in evaluate's prior: not an external test."
        )
    with (out / "lamps.csv").open("w", newline="") as fh:
        fields = ["band_set", *rows_by["recommended"][0]]
        w = csv.DictWriter(fh, fieldnames=fields)
        w.writeheader()
        for name, rows in rows_by.items():
            for r in rows:
                w.writerow({"band_set": name, **r})
    ref = _in_library_reference(Path("results/estimate_defaults/summary.json"))
    summary = {
        "lamps": len(keep),
        "scene": (
            f"{scene['surface']}, atmosphere {scene['atmosphere']}, moonless, "
            f"{scene['illuminance_lx']:g} lx, noise-free"
        ),
        "band_sets": results,
        "paired": {
            name: paired(rows_by[name], rows_by["recommended"])
            for name in BAND_SETS
            if name != "recommended"
        },
        "in_library_reference": ref,
        "surface_known": known,
        "surface_known_paired": paired(
            known_rows["contiguous-26, direct"], known_rows["recommended, inversion"]
        ),
        "bootstrap": {"draws": BOOTSTRAP, "seed": SEED, "level": 0.9},
        "scored_lamps": "measured lamps only (IES TM-30-15, not in the library)",
        "modelled_lamps_used": True,
        "modelled_lamps_note": "evaluate's prior holds the library's five modelled "
        "Planck spectra (its default); they train, never score",
    }
    heading = "## External check: `bandopt evaluate` on"
    return write_outputs(
        out,
        summary,
        [(figure, "errors.png")],
        section=("external-tm30", readme_text, heading) if args.out is None else None,
        seed=SEED,
        say=log,
        t0=t0,
        config={
            "band_sets": BAND_SETS,
            "surface_known": {k: [b, *o] for k, (b, o) in SURFACE_KNOWN.items()},
            "bootstrap": BOOTSTRAP,
            "cct_null_k": CCT_NULL_K,
            "unscored": list(UNSCORED),
            "lamps": "bandopt.datasets.lamps.library(tm30=True), source_set ies_tm30",
            "modelled_lamps_used": "evaluate's default Planck spectra (training)",
        },
    )


def _evaluate(bands: str, files: list[str], options=()) -> dict:
    """`bandopt evaluate --bands BANDS --lamps FILES... --json [OPTIONS]` in a
    spawned process, as a user runs it; its JSON."""
    cmd = [sys.executable, "-m", "bandopt", "evaluate", "--bands", bands,
           "--lamps", *files, "--json", *options]  # fmt: skip
    p = subprocess.run(cmd, capture_output=True, text=True)
    if p.returncode != 0:
        raise RuntimeError(f"bandopt evaluate --bands {bands} failed:\n{p.stderr}")
    return json.loads(p.stdout)


def _in_library_reference(path: Path) -> str | None:
    """Our bands' and SDGSAT-1's held-out errors with evaluate's estimator, as
    stored by `make study NAME=estimate-defaults` (read, not recomputed)."""
    if not path.is_file():
        return None
    data = json.loads(path.read_text())
    want = "inversion-moon-mix-metric-narrow-shift-planck"
    parts = []
    for r in data.get("rows", []):
        if r["estimator"] == want and r["band_set"] in ("recommended", "sdgsat-1"):
            parts.append(
                f"{r['band_set']} {r['LER']:.1f} lm/W / {r['G']:.3f} / {r['CCT']:.0f} K"
            )
    return "; ".join(parts) or None
