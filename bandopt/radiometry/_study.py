"""The radiometry study of the results folder (`make radiometry`): which
band set "ours" is, where its outputs go, and the README section written
from its `summary.json`.

The analysis itself is `compute` (writes nothing); the command line's
`bandopt.cli.run_radiometry` locks, computes and writes a folder.
"""

import json
from pathlib import Path

from ..results import recommended_band_set, update_readme_section
from ._report import DEFAULT_BAND_SET, load_band_set


def study_band_set(source: str, *, results_dir: str | Path = "results"):
    """A band set and its label from `source`: `ours` (the "spectral" bands
    of `results_dir`/recommendation.json, else the documented default
    `DEFAULT_BAND_SET`), a reference sensor name or a band-set JSON file.
    Returns `(bands, label, note)`."""
    if str(source).strip().lower() in ("ours", "recommended"):
        path = Path(results_dir) / "recommendation.json"
        found = recommended_band_set("spectral", path=path)  # the one reader
        if found is not None:
            return found, "ours", f"bands from {path} key 'spectral'"
        bands, _, _ = load_band_set(DEFAULT_BAND_SET)
        return (
            bands,
            "ours",
            f"no 'spectral' bands in {path}: default {DEFAULT_BAND_SET} "
            "(SDGSAT-1 Glimmer PAN, blue, green, red)",
        )
    return load_band_set(source)


def study_out_dir(
    label: str, *, quick: bool, results_dir: str | Path = "results"
) -> Path:
    """Where the study writes: `radiometry/` for our bands, `radiometry/<label>/`
    for another band set, and a `quick/` folder inside either for a quick run
    (never the committed full tables)."""
    out = Path(results_dir) / "radiometry"
    if label != "ours":
        out = out / label
    return out / "quick" if quick else out


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
        if comp
        else ""
    )
    ch = summary.get("instrument_changes") or {}
    change_text = ""
    if ch.get("changes"):
        c = ch["changes"]
        f = c["f_number"]["needed"]
        pitch = c["pixel_pitch_m"]["needed"] / c["pixel_pitch_m"]["now"]
        change_text = (
            f" To reach it in every band ({ch['limiting_band']} needs "
            f"{ch['exposure_factor']:.3g} times the signal), any one of: TDI "
            f"stages {c['tdi_stages']['now']} -> {c['tdi_stages']['needed']}; "
            + (
                f"f/{c['f_number']['now']:g} -> f/{f:.2g}; "
                if f is not None
                else "no f-number (faster than f/0.5); "
            )
            + f"pixel pitch x {pitch:.3g}"
            f" (GSD {ch['gsd_m']:.3g} -> {c['pixel_pitch_m']['gsd_m']:.3g} m); "
            f"{c['binning']['needed']} x {c['binning']['needed']} binning "
            f"(GSD {c['binning']['gsd_m']:.3g} m)."
        )
    return (
        "## Radiometry (`results/radiometry/`, `make radiometry`)\n\n"
        f"Band set `{label}` ({summary.get('band_set_note', '')}): bands "
        + ", ".join(r["band"] for r in rows)
        + ". "
        f"Detection limits {min(det):.2g} to {max(det):.2g} W m-2 sr-1 nm-1 "
        "(set by "
        + "; ".join(f"{k}: {', '.join(v)}" for k, v in sorted(by.items()))
        + f") and saturation {min(sat):.2g} to {max(sat):.2g}; SNR at the limit "
        f"{min(snr):.2g}-{max(snr):.2g} (target {target:g}, met in "
        f"{sum(s >= target for s in snr)} of {len(snr)} bands)." + change_text + " "
        f"Linear bit depth needed: {bits.get('recommended_linear_bits')} bits "
        "(thesis: 12 or more)" + comp_text + ". Rules and the table per band set: "
        "`summary.json`, `limits.csv`, `bit_depth.csv`; generated from "
        "`summary.json` by `python -m experiments.radiometry --readme-only`."
    )


def write_readme(results: str | Path = "results") -> Path:
    """Rewrite the radiometry section of `results`/README.md from
    `results`/radiometry/summary.json."""
    summary = json.loads((Path(results) / "radiometry" / "summary.json").read_text())
    return update_readme_section(
        "radiometry",
        readme_text(summary),
        heading="## Radiometry",
        results_dir=results,
    )
