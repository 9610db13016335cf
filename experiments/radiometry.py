"""Radiometric sampling (issue 7; thesis section 4.2, Tables 4.5-4.7).

Run:   python -m experiments.radiometry [--quick] [--bands NAME|FILE|ours]
       (`make radiometry`: the full configuration)
       python -m experiments.radiometry --readme-only

The experiment owns `results/radiometry/` and key "radiometry" of
`results/recommendation.json`:

- `--bands ours` (default): the "spectral" bands of
  results/recommendation.json, else SDGSAT-1 (`DEFAULT_BAND_SET`); writes
  results/radiometry/ (distributions.csv, limits.csv, sensitivity.csv,
  snr_ner.csv, quantisation_noise.csv, bit_depth.csv, summary.json,
  histograms/*.png, manifest.json), key "radiometry" and the radiometry
  section of results/README.md (generated from summary.json;
  `--readme-only` regenerates just that section);
- another band set: results/radiometry/<name>/, no recommendation;
- `--quick`: results/radiometry/quick/ (never the committed full tables) and
  no recommendation unless `--recommend` is given; every part written to
  recommendation.json records its `mode` ("quick"/"full") and settings.

`bandopt radiometry --out DIR` runs the same analysis into any folder and
touches nothing else.
"""

import argparse
import json
import sys
from pathlib import Path


DEFAULT_BAND_SET = "sdgsat-1"
RESULTS = Path("results")


def load_band_set(source: str, *, results_dir: str | Path = RESULTS):
    """A band set and its label from `source`: `ours` (the "spectral" bands
    of results/recommendation.json, else the documented default
    `DEFAULT_BAND_SET`), a reference sensor name or a band-set JSON file.
    Returns `(bands, label, note)`."""
    from bandopt import radiometry
    from bandopt.results import recommended_band_set

    if str(source).strip().lower() in ("ours", "recommended"):
        path = Path(results_dir) / "recommendation.json"
        found = recommended_band_set("spectral", path=path)  # the one reader
        if found is not None:
            return found, "ours", f"bands from {path} key 'spectral'"
        bands, _, _ = radiometry.load_band_set(DEFAULT_BAND_SET)
        return (
            bands,
            "ours",
            f"no 'spectral' bands in {path}: default {DEFAULT_BAND_SET} "
            "(SDGSAT-1 Glimmer PAN, blue, green, red)",
        )
    return radiometry.load_band_set(source)


def run(
    bands,
    label: str,
    out_dir: str | Path,
    *,
    config=None,
    params=None,
    rule=None,
    recommend: bool = True,
    results_dir: str | Path | None = None,
    note: str = "",
    log=print,
) -> dict:
    """Compute (`bandopt.radiometry.compute`), write `out_dir` and, with
    `recommend`, key "radiometry" of `results_dir`/recommendation.json with
    the mode and settings. Returns the summary."""
    from bandopt.cli import OutputLock, write_radiometry_results
    from bandopt.radiometry import compute
    from bandopt.results import update_recommendation

    with OutputLock(out_dir) as lock:
        result = compute(
            bands, label, config=config, params=params, rule=rule, note=note, log=log
        )
        write_radiometry_results(result, lock.directory)
    if recommend:
        update_recommendation(
            "radiometry",
            {**result["recommendation"], "results": str(out_dir)},
            results_dir=results_dir,
        )
    log(f"[radiometry] wrote {out_dir}")
    return result["summary"]


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


def main(argv=None) -> int:
    from bandopt import configure
    from bandopt.radiometry import RadiometryConfig

    configure()
    ap = argparse.ArgumentParser(prog="python -m experiments.radiometry")
    ap.add_argument("--bands", default="ours", help="ours, a sensor name or a file")
    ap.add_argument("--quick", action="store_true", help="small scenario sets")
    ap.add_argument(
        "--recommend",
        action="store_true",
        help="update key 'radiometry' even for --quick or a band set not ours",
    )
    ap.add_argument("--no-references", action="store_true")
    ap.add_argument("--no-bit-depth", action="store_true")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument(
        "--readme-only",
        action="store_true",
        help="only regenerate the radiometry section of results/README.md",
    )
    args = ap.parse_args(argv)
    if args.readme_only:
        print(f"wrote {write_readme()}")
        return 0
    bands, label, note = load_band_set(args.bands)
    over = {"seed": args.seed}
    if args.no_references:
        over["references"] = False
    if args.no_bit_depth:
        over["bit_depth_table"] = False
    config = RadiometryConfig.quick(**over) if args.quick else RadiometryConfig(**over)
    out = RESULTS / "radiometry"
    if label != "ours":
        out = out / label
    if args.quick:
        out = out / "quick"
    recommend = args.recommend or (label == "ours" and not args.quick)
    run(bands, label, out, config=config, recommend=recommend, note=note)
    if label == "ours" and not args.quick:
        write_readme()
    return 0


if __name__ == "__main__":
    sys.exit(main())
