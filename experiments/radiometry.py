"""Radiometric sampling (thesis section 4.2, Tables 4.5-4.7).

Run:   python -m experiments.radiometry [--quick] [--bands NAME|FILE|ours]
       (`make radiometry`: the full configuration)
       python -m experiments.radiometry --readme-only

The experiment owns `results/radiometry/` and key "radiometry" of
`results/recommendation.json`:

- `--bands ours` (default): the "spectral" bands of
  results/recommendation.json, else SDGSAT-1
  (`bandopt.radiometry.study_band_set`); writes results/radiometry/
  (distributions.csv, limits.csv, sensitivity.csv, snr_ner.csv,
  quantisation_noise.csv, bit_depth.csv, summary.json, histograms/*.png,
  manifest.json), key "radiometry" and the radiometry section of
  results/README.md (generated from summary.json; `--readme-only`
  regenerates just that section);
- another band set: results/radiometry/<name>/, no recommendation;
- `--quick`: results/radiometry/quick/ (never the committed full tables) and
  no recommendation unless `--recommend` is given; every part written to
  recommendation.json records its `mode` ("quick"/"full") and settings.

`bandopt radiometry --out DIR` runs the same analysis into any folder and
touches nothing else.
"""

import argparse
import sys

from bandopt.provenance import add_allow_dirty, refuse_dirty_at_start


def main(argv=None) -> int:
    from bandopt import configure, radiometry as rad
    from bandopt.cli import run_radiometry
    from bandopt.results import RECOMMENDATION, RESULTS_DIR

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
    add_allow_dirty(ap)
    args = ap.parse_args(argv)
    if args.readme_only:
        print(f"wrote {rad.write_readme()}")
        return 0
    bands, label, note = rad.study_band_set(args.bands)
    over = {"seed": args.seed}
    if args.no_references:
        over["references"] = False
    if args.no_bit_depth:
        over["bit_depth_table"] = False
    quick = args.quick
    make_config = rad.RadiometryConfig.quick if quick else rad.RadiometryConfig
    out = rad.study_out_dir(label, quick=quick)
    refuse_dirty_at_start(ap, args, out)
    recommend = args.recommend or (label == "ours" and not quick)
    rec = RESULTS_DIR / RECOMMENDATION if recommend else None
    run_radiometry(
        bands, label, out, config=make_config(**over), recommend=rec, note=note
    )
    print(f"[radiometry] wrote {out}")
    if label == "ours" and not quick:
        rad.write_readme()
    return 0


if __name__ == "__main__":
    sys.exit(main())
