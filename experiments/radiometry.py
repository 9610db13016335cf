"""Radiometric sampling (issue 7; thesis section 4.2, Tables 4.5-4.7).

Run:   python -m experiments.radiometry [--quick] [--bands NAME|FILE]
       python -m experiments.radiometry --readme-only
Writes results/radiometry/ (distributions.csv, limits.csv, sensitivity.csv,
snr_ner.csv, quantisation_noise.csv, bit_depth.csv, summary.json,
histograms/*.png, manifest.json), key "radiometry" of
results/recommendation.json and the radiometry section of results/README.md
(generated from summary.json; `--readme-only` regenerates just that section).
Same as `bandopt radiometry --bands ours` plus the README section.
"""

import json
import sys
from pathlib import Path

from bandopt.cli import main


def readme_text(summary: dict) -> str:
    """The README section, every number read from `summary` (summary.json)."""
    label = summary["band_set"]
    rows = [r for r in summary["bands"] if r.get("band_set", label) == label]
    det = [r["detection_limit_w_m2_sr_nm"] for r in rows]
    sat = [r["saturation_w_m2_sr_nm"] for r in rows]
    snr = [r["snr_at_limit"] for r in rows]
    by = {}
    for r in rows:
        by.setdefault(r["limited_by"], []).append(r["band"])
    bits = summary.get("bit_depth") or {}
    target = summary["rule"]["snr_target"]
    comp = bits.get("companded_bits_per_scheme") or {}
    comp_text = (
        "; companded: " + ", ".join(f"{k} {v} bits" for k, v in sorted(comp.items()))
        if comp else ""
    )
    return (
        "## Radiometry (`results/radiometry/`, `make radiometry`)\n\n"
        f"Band set `{label}` ({summary.get('band_set_note', '')}): bands "
        + ", ".join(r["band"] for r in rows) + ". "
        f"Detection limits {min(det):.2g} to {max(det):.2g} W m-2 sr-1 nm-1 "
        "(set by "
        + "; ".join(f"{k}: {', '.join(v)}" for k, v in sorted(by.items()))
        + f") and saturation {min(sat):.2g} to {max(sat):.2g}; SNR at the limit "
        f"{min(snr):.2g}-{max(snr):.2g} (target {target:g}, met in "
        f"{sum(s >= target for s in snr)} of {len(snr)} bands). "
        f"Linear bit depth needed: {bits.get('recommended_linear_bits')} bits "
        "(thesis: 12 or more)" + comp_text + ". Rules and the table per band set: "
        "`summary.json`, `limits.csv`, `bit_depth.csv`; generated from "
        "`summary.json` by `python -m experiments.radiometry --readme-only`."
    )


def write_readme(results: str | Path = "results") -> Path:
    from bandopt.results import update_readme_section

    summary = json.loads((Path(results) / "radiometry" / "summary.json").read_text())
    return update_readme_section(
        "radiometry", readme_text(summary), heading="## Radiometry",
        results_dir=results,
    )


if __name__ == "__main__":
    argv = sys.argv[1:]
    if argv == ["--readme-only"]:
        print(f"wrote {write_readme()}")
        sys.exit(0)
    if not any(a.startswith("--bands") for a in argv):
        argv = ["--bands", "ours", *argv]
    # the default run (the make target) owns results/radiometry and its part of
    # recommendation.json; say so explicitly rather than rely on a default
    default_run = "ours" in argv and not any(
        a.startswith(("--out", "--quick")) for a in argv
    )
    if default_run and "--recommend" not in argv:
        argv.append("--recommend")
    rc = main(["radiometry", *argv])
    if rc == 0 and default_run:
        write_readme()
    sys.exit(rc)
