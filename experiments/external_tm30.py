"""External check: `bandopt evaluate` on 210 measured lamps the library has
never seen (the IES TM-30-15 set; issue 12).

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
not in the errors and coverage. Summaries are class-balanced over the library's scored
level-2 classes (RGB LED mixtures, a class the library does not score, are
reported apart), with a 90 % bootstrap interval over lamps (resampled
within class, `BOOTSTRAP` draws, seed `SEED`); reference sensors minus ours
are paired on the same lamps. Then the same lamps told the scene's surface
(`SURFACE_KNOWN`): evaluate's estimator with our bands against the
library-free direct estimate (`--estimator direct`) with 26 contiguous
bands, paired on the same lamps.

    python -m experiments.external_tm30 [--out DIR]

Writes `lamps.csv` (per lamp and band set), `summary.json`, `errors.png`,
`manifest.json` and the `external-tm30` section of `results/README.md`
(default output only). Measured lamps only; evaluate's prior holds the
library's five modelled Planck spectra (its default), said in the summary.
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


BAND_SETS = {
    "recommended": "results/search/recommended_bands.json",
    "sdgsat-1": "sdgsat-1",
    "nightsat": "nightsat",
}
"""Label -> `bandopt evaluate --bands` argument."""
SURFACE_KNOWN = {
    "recommended, inversion": ("results/search/recommended_bands.json", ()),
    "contiguous-26, direct": ("contiguous-26", ("--estimator", "direct")),
}
"""Label -> (`--bands` argument, other options) of the runs told the scene's
surface (`--surface asphalt`): evaluate's default estimator with our bands,
and the library-free direct estimate (`bandopt.direct`) with 26 contiguous
bands of 20 nm (written as a band-set file for the run)."""
METRICS = ("LER", "G", "CCT")
CCT_NULL_K = 25000.0
"""A null CCT estimate counts as this when scored (as in `make estimate`)."""
RANGE = {"LER": (0.0, 683.0), "CCT": (1000.0, 25000.0)}
"""Physical ranges an estimate must lie in (G: any finite value)."""
BOOTSTRAP = 2000
"""Bootstrap draws of the lamps (within class) for the 90 % intervals."""
SEED = 0
UNSCORED = ("led_rgb",)
"""TM-30 classes the library does not score: reported apart."""


def log(msg: str) -> None:
    print(
        f"[external_tm30 {time.strftime('%H:%M:%S')}] {msg}",
        file=sys.stderr,
        flush=True,
    )


def lamp_rows(evaluate_json: dict, classes: dict) -> list[dict]:
    """Per-lamp scores from one `bandopt evaluate --json` output. `classes`:
    file stem -> (level1, level2) of the lamp."""
    rows = []
    for lamp in evaluate_json["lamps"]:
        stem = Path(lamp["file"]).stem
        if stem not in classes:
            raise ValueError(
                f"evaluate output names an unknown lamp file {lamp['file']!r}."
            )
        level1, level2 = classes[stem]
        t, e, iv = lamp["true"], lamp["estimate"], lamp.get("interval90") or {}
        row = {
            "lamp": stem,
            "level1": level1,
            "level2": level2,
            "predicted_level1": lamp.get("predicted_level1"),
            "unexplained": bool(lamp.get("unexplained")),
        }
        row["level1_correct"] = row["predicted_level1"] == level1
        out = 0
        for m in METRICS:
            if t.get(m) is None or row["unexplained"]:
                # flagged, not guessed: its estimates are null, counted in
                # `unexplained`, not as errors
                row[m] = row[f"{m}_covered"] = None
                continue
            est = e.get(m)
            if est is not None:
                lo, hi = RANGE.get(m, (-np.inf, np.inf))
                out += int(not (np.isfinite(est) and lo <= est <= hi))
            v = CCT_NULL_K if (m == "CCT" and est is None) else est
            row[m] = None if v is None else float(abs(v - t[m]))
            bounds = iv.get(m)
            row[f"{m}_covered"] = (
                None
                if bounds is None or None in bounds
                else bool(bounds[0] <= t[m] <= bounds[1])
            )
        row["out_of_range"] = out
        rows.append(row)
    return rows


def _class_mean(rows, key, classes) -> float | None:
    per = []
    for c in classes:
        v = [r[key] for r in rows if r["level2"] == c and r.get(key) is not None]
        if v:
            per.append(float(np.mean(v)))
    return float(np.mean(per)) if per else None


def _balanced(rows, keys, classes, draws: int, seed: int) -> dict:
    """Each key's class-balanced mean over `rows` and its 90 % bootstrap
    interval (`key_ci90`; lamps resampled within class, seeded; None when no
    draw has a value)."""
    by = {c: [r for r in rows if r["level2"] == c] for c in classes}
    rng = np.random.default_rng(seed)
    boot = {k: [] for k in keys}
    for _ in range(draws):
        sample = [
            by[c][i] for c in classes for i in rng.integers(0, len(by[c]), len(by[c]))
        ]
        for k in keys:
            boot[k].append(_class_mean(sample, k, classes))
    out = {}
    for k in keys:
        v = [x for x in boot[k] if x is not None]
        out[k] = _class_mean(rows, k, classes)
        out[f"{k}_ci90"] = (
            [float(np.quantile(v, 0.05)), float(np.quantile(v, 0.95))] if v else None
        )
    return out


def summarise(rows: list[dict], *, draws: int = BOOTSTRAP, seed: int = SEED) -> dict:
    """Class-balanced means over the scored classes (`UNSCORED` apart), each
    with a 90 % bootstrap interval over lamps resampled within class; per
    class means; totals of out-of-range estimates and lamps."""
    scored = [r for r in rows if r["level2"] not in UNSCORED]
    classes = sorted({r["level2"] for r in scored})
    keys = (
        *METRICS,
        *(f"{m}_covered" for m in METRICS),
        "level1_correct",
        "unexplained",
    )
    by = {c: [r for r in scored if r["level2"] == c] for c in classes}
    out = {"lamps": len(scored), "classes": classes}
    out.update(_balanced(scored, keys, classes, draws, seed))
    out["by_class"] = {
        c: {"lamps": len(by[c]), **{k: _class_mean(by[c], k, [c]) for k in keys}}
        for c in classes
    }
    apart = [r for r in rows if r["level2"] in UNSCORED]
    out["unscored"] = {
        c: {
            "lamps": sum(r["level2"] == c for r in apart),
            **{k: _class_mean(apart, k, [c]) for k in keys},
        }
        for c in sorted({r["level2"] for r in apart})
    }
    out["out_of_range"] = int(sum(r["out_of_range"] for r in rows))
    return out


def paired(rows_a: list[dict], rows_b: list[dict], *, draws=BOOTSTRAP, seed=SEED):
    """Class-balanced difference a - b of each metric's |error| on the same
    lamps, with a 90 % bootstrap interval over lamps (within class)."""
    a = {r["lamp"]: r for r in rows_a if r["level2"] not in UNSCORED}
    b = {r["lamp"]: r for r in rows_b if r["level2"] not in UNSCORED}
    lamps = sorted(set(a) & set(b))
    diff = []
    for lamp in lamps:
        d = {"lamp": lamp, "level2": a[lamp]["level2"]}
        for m in METRICS:
            x, y = a[lamp][m], b[lamp][m]
            d[m] = None if x is None or y is None else x - y
        diff.append(d)
    classes = sorted({d["level2"] for d in diff})
    out = {"lamps": len(lamps)}
    out.update(_balanced(diff, METRICS, classes, draws, seed))
    return out


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
    # lazy: matplotlib only when a figure is drawn (start-up time)
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

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


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument(
        "--out", default=None, help="output (default results/external_tm30)"
    )
    args = ap.parse_args(argv)

    from bandopt import configure

    configure()
    from bandopt.datasets.lamps import library
    from bandopt.provenance import write_manifest
    from bandopt.results import update_readme_section
    from bandopt.sensor import BandSet

    out = Path(args.out or "results/external_tm30")
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
        files = []
        for i in keep:
            r, v = lib.records[i], lib.values[i]
            ok = np.isfinite(v)  # the measured 380-780 nm part
            path = Path(tmp) / f"{r.id}.csv"
            with path.open("w", newline="") as fh:
                w = csv.writer(fh)
                w.writerow(["wavelength_nm", "relative_power"])
                w.writerows(
                    zip(lib.wavelength_nm[ok].tolist(), v[ok].tolist(), strict=True)
                )
            files.append(str(path))
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
            if bands.startswith("contiguous-"):
                path = Path(tmp) / f"{bands}.json"
                BandSet.contiguous(int(bands.split("-")[1])).to_json(path)
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
    (out / "summary.json").write_text(json.dumps(summary, indent=2) + "\n")
    figure(summary, out / "errors.png")
    if args.out is None:
        update_readme_section(
            "external-tm30",
            readme_text(summary),
            heading="## External check: `bandopt evaluate` on",
        )
    write_manifest(
        out,
        seed=SEED,
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
    log(f"done: {out} ({time.time() - t0:.0f} s)")
    return 0


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


if __name__ == "__main__":
    raise SystemExit(main())
