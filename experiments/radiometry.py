"""Radiometric sampling (issue 7; thesis section 4.2, Tables 4.5-4.7).

Run:   python -m experiments.radiometry [--quick] [--bands NAME|FILE]
Writes results/radiometry/ (distributions.csv, limits.csv, sensitivity.csv,
snr_ner.csv, quantisation_noise.csv, bit_depth.csv, summary.json,
histograms/*.png, manifest.json) and key "radiometry" of
results/recommendation.json. Same as `bandopt radiometry --bands ours`.
"""

import sys

from bandopt.cli import main


if __name__ == "__main__":
    argv = sys.argv[1:]
    if not any(a.startswith("--bands") for a in argv):
        argv = ["--bands", "ours", *argv]
    sys.exit(main(["radiometry", *argv]))
