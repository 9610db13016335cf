"""Sections of results/README.md generated from the experiments' own files.

Run:   python -m experiments.readme_sections classification|spatial [--results DIR]

`make classify` and `make spatial` call this after the experiment, so the
README quotes exactly what `results/classify/summary.json` and
`results/spatial/summary.json` / `overlap.json` hold (the report refuses to
build when a quoted number disagrees with its file, `bandopt.report`). The
radiometry section is written by `experiments.radiometry`, the search section
by `experiments.search`.
"""

import argparse
import json
import math
import sys
from pathlib import Path

from bandopt.report._checks import spatial_median
from bandopt.results import update_readme_section


def classification_text(summary: dict) -> str:
    nested = {
        r["n_bands"]: r["level2_macro_f1"]
        for r in summary["band_count"]
        if r.get("method") == "nlopt"
    }
    ns = sorted(nested)
    refs = {
        r["sensor"]: r for r in summary["reference_sensors"] if r.get("noise")
    }
    goal = summary.get("goal", {})
    best = next(iter(goal.values()), {}).get("best_reference")
    single = sorted({round(r["level2_macro_f1"], 2) for r in refs.values()
                     if r["n_bands"] == 1})
    parts = [
        "## Classification (`results/classify/`, `make classify`)\n",
        "See `results/classify/report.md`. Nested outer-fold level-2 macro F1 "
        "(photon noise): " + " / ".join(f"{nested[n]:.2f}" for n in ns)
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


def _span(values, fmt="{:.2f}") -> str:
    vals = [v for v in values if v is not None and not math.isnan(v)]
    lo, hi = fmt.format(min(vals)), fmt.format(max(vals))
    return lo if lo == hi else f"{lo}-{hi}"


def spatial_text(summary: dict, overlap: dict | None) -> str:
    median = spatial_median(summary)
    never = [
        k for k, v in summary["gsd_needed_m"].items() if v.get("coarsest_gsd_m") is None
    ]
    text = (
        "## Spatial sampling (`results/spatial/`, `make spatial`)\n\n"
        "See `results/spatial/summary.md`: median GSD needed to detect single lamps "
        f"{median:g} m over the row and arrangement scenes; thesis: "
        f"{summary.get('thesis', 'n/a')}. Detected at no GSD: "
        + (", ".join(never) or "none") + " (explained there)."
    )
    if overlap:
        rows = overlap["rows"]
        pure = [r for r in rows if not math.isnan(r["f1_pure"])]
        text += (
            " Overlapping lamp types (`overlap.json`, `overlap.png`): pixels lit by "
            f"one type are identified with F1 {_span(r['f1_pure'] for r in pure)} "
            f"(GSD {_span((r['gsd_m'] for r in pure), '{:g}')} m); pixels where two "
            "types mix (" + _span((100 * r["mixed_fraction"] for r in rows), "{:.0f}")
            + " % of lit pixels in the layout) get F1 "
            + _span(r["f1_mixed"] for r in rows) + "."
        )
    return text + (
        " Generated from `summary.json` and `overlap.json` by "
        "`python -m experiments.readme_sections spatial`."
    )


def write(section: str, results: str | Path = "results") -> Path:
    root = Path(results)
    if section == "classification":
        summary = json.loads((root / "classify" / "summary.json").read_text())
        return update_readme_section(
            "classification", classification_text(summary),
            heading="## Classification", results_dir=root,
        )
    if section == "spatial":
        summary = json.loads((root / "spatial" / "summary.json").read_text())
        ov = root / "spatial" / "overlap.json"
        overlap = json.loads(ov.read_text()) if ov.is_file() else None
        return update_readme_section(
            "spatial", spatial_text(summary, overlap),
            heading="## Spatial sampling", results_dir=root,
        )
    raise ValueError(
        f"unknown section {section!r}; expected one of ['classification', 'spatial']"
    )


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("section", choices=["classification", "spatial"])
    p.add_argument("--results", default="results")
    args = p.parse_args(argv)
    print(f"wrote {write(args.section, args.results)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
