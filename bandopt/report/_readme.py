"""Sections of `results/README.md` generated from the experiments' own files.

`make classify` and `make spatial` write theirs after the experiment, so the
README quotes exactly what `results/classify/summary.json` and
`results/spatial/summary.json` / `overlap.json` hold (the report refuses to
build when a quoted number disagrees with its file, `check_consistency`);
`make noise-aware` writes its section from
`results/noise_aware/noise_aware.json`.
"""

import json
import math
from pathlib import Path

from ..results import update_readme_section
from ._checks import spatial_median


README_SECTIONS = ("classification", "spatial", "noise-aware")
"""The README sections `write_readme_section` writes."""


def classification_text(summary: dict) -> str:
    """The classification section from `classify/summary.json`: nested
    level-2 macro F1 per band count beside the reference sensors, and the
    goal."""
    nested = {
        r["n_bands"]: r["level2_macro_f1"]
        for r in summary["band_count"]
        if r.get("method") == "nlopt"
    }
    ns = sorted(nested)
    refs = {r["sensor"]: r for r in summary["reference_sensors"] if r.get("noise")}
    goal = summary.get("goal", {})
    best = next(iter(goal.values()), {}).get("best_reference")
    single = sorted(
        {round(r["level2_macro_f1"], 2) for r in refs.values() if r["n_bands"] == 1}
    )
    parts = [
        "## Classification (`results/classify/`, `make classify`)\n",
        "See `results/classify/report.md`. Nested outer-fold level-2 macro F1 "
        "(photon noise): "
        + " / ".join(f"{nested[n]:.2f}" for n in ns)
        + f" for {ns[0]}-{ns[-1]} bands ({summary['budget']['nlopt_algorithm'].upper()}"
        " band search)",
    ]
    refs_text = []
    if best in refs:
        refs_text.append(
            f"best reference sensor {best} ({refs[best]['n_bands']} bands) "
            f"{refs[best]['level2_macro_f1']:.2f}"
        )
    if "sdgsat-1" in refs and best != "sdgsat-1":
        refs_text.append(f"SDGSAT-1 {refs['sdgsat-1']['level2_macro_f1']:.2f}")
    if single:
        refs_text.append("single-band sensors " + "-".join(f"{v:.2f}" for v in single))
    if refs_text:
        parts[-1] += "; " + ", ".join(refs_text)
    parts[-1] += "."
    if goal:
        met = any(g.get("met") for g in goal.values())
        margins = ", ".join(
            f"{100 * g['margin']:+.0f} points at {n} bands" for n, g in goal.items()
        )
        parts.append(
            "Goal (>= 10 points above the best reference with >= 4 bands): "
            f"{'met' if met else 'not met'} ({margins})."
        )
    parts.append(
        "Generated from `summary.json` by "
        "`python -m experiments.readme_sections classification`."
    )
    return parts[0] + "\n" + " ".join(parts[1:])


def _defined(v) -> bool:
    """A number that is there: strict JSON writes an undefined one as null
    (older files as NaN)."""
    return v is not None and not math.isnan(v)


def _span(values, fmt="{:.2f}") -> str:
    """`lo-hi` of the finite `values` formatted by `fmt` (one number when
    both read the same)."""
    vals = [v for v in values if _defined(v)]
    lo, hi = fmt.format(min(vals)), fmt.format(max(vals))
    return lo if lo == hi else f"{lo}-{hi}"


def spatial_text(summary: dict, overlap: dict | None) -> str:
    """The spatial section from `spatial/summary.json` and, when run,
    `spatial/overlap.json`."""
    median = spatial_median(summary)
    never = [
        k for k, v in summary["gsd_needed_m"].items() if v.get("coarsest_gsd_m") is None
    ]
    text = (
        "## Spatial sampling (`results/spatial/`, `make spatial`)\n\n"
        "See `results/spatial/summary.md`: median GSD needed to detect single lamps "
        f"{median:g} m over the row and arrangement scenes; thesis: "
        f"{summary.get('thesis', 'n/a')}. Detected at no GSD: "
        + (", ".join(never) or "none")
        + " (explained there)."
    )
    if overlap:
        rows = overlap["rows"]
        pure = [r for r in rows if _defined(r["f1_pure"])]
        text += (
            " Overlapping lamp types (`overlap.json`, `overlap.png`): pixels lit by "
            f"one type are identified with F1 {_span(r['f1_pure'] for r in pure)} "
            f"(GSD {_span((r['gsd_m'] for r in pure), '{:g}')} m); pixels where two "
            "types mix ("
            + _span((100 * r["mixed_fraction"] for r in rows), "{:.0f}")
            + " % of lit pixels in the layout) get F1 "
            + _span(r["f1_mixed"] for r in rows)
            + "."
        )
    return text + (
        " Generated from `summary.json` and `overlap.json` by "
        "`python -m experiments.readme_sections spatial`."
    )


def noise_aware_text(data: dict) -> str:
    """The noise-aware section: bands per signal level, how far they move
    between the brightest and the dimmest noisy level, and the CV losses."""
    # JAX: the rest of the report loads none (start-up time)
    from ..scene import LIGHTING_CLASSES, class_illuminance_lx

    rows = data["rows"]

    def label(level):
        if level.upper() not in LIGHTING_CLASSES:
            return level
        return f"{level} ({class_illuminance_lx(level):g} lx)"

    def bands(r):
        return ", ".join(f"{c:.0f}/{f:.0f}" for c, f in sorted(r["bands"]))

    noisy = [r for r in rows if r["level"] != "noise-free"]
    free = [r for r in rows if r["level"] == "noise-free"]
    listing = "; ".join(f"{label(r['level'])} {bands(r)}" for r in noisy + free)
    text = [
        "## Noise-aware bands (`results/noise_aware`, `make noise-aware`)\n",
        f"{data.get('note', '')}. Photon noise at EN 13201 class levels (scenes of "
        "that class only, no Moon; the noise-free row uses the default preset with "
        "Moon, so its loss is not comparable). Bands (centre/FWHM nm): "
        f"{listing}.",
    ]
    if len(noisy) >= 2:
        a = sorted(noisy[0]["bands"])
        b = sorted(noisy[-1]["bands"])
        dc = max(abs(x[0] - y[0]) for x, y in zip(a, b, strict=True))
        dw = max(abs(x[1] - y[1]) for x, y in zip(a, b, strict=True))
        losses = " -> ".join(f"{r['cv_loss']:.2f}" for r in noisy)
        text.append(
            f"From {noisy[0]['level']} to {noisy[-1]['level']} the bands (sorted "
            f"by centre) move by at most {dc:.0f} nm in centre and {dw:.0f} nm in "
            f"width; the CV loss goes {losses}."
        )
    text.append(
        "Figure: `bands_vs_signal.png`. One seed, one search per level: "
        "indicative only. Generated from `noise_aware.json` by "
        "`python -m experiments.readme_sections noise-aware`."
    )
    return text[0] + "\n" + " ".join(text[1:])


def _read(path: Path):
    return json.loads(path.read_text())


def write_readme_section(section: str, results: str | Path = "results") -> Path:
    """Write the page `section` (one of `README_SECTIONS`) of the results
    index (`bandopt.results.update_readme_section`) from its experiment's
    files under `results`; returns the page's path."""
    root = Path(results)
    if section == "classification":
        text = classification_text(_read(root / "classify" / "summary.json"))
        heading = "## Classification"
    elif section == "spatial":
        ov = root / "spatial" / "overlap.json"
        overlap = _read(ov) if ov.is_file() else None
        text = spatial_text(_read(root / "spatial" / "summary.json"), overlap)
        heading = "## Spatial sampling"
    elif section == "noise-aware":
        text = noise_aware_text(_read(root / "noise_aware" / "noise_aware.json"))
        heading = "## Noise-aware bands"
    else:
        raise ValueError(
            f"unknown section {section!r}; expected one of {list(README_SECTIONS)}"
        )
    return update_readme_section(section, text, heading=heading, results_dir=root)
