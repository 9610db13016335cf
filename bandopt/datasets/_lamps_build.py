"""Build the vendored lamp spectra under `data/lamps_*/` from `../shared/data`.

Run `python -m bandopt.datasets._lamps_build` (rewrites the package data) or
with `--check` (rebuilds in memory and compares with the vendored files, exit 1
on a difference). Only this build reads `../shared/data`; the package reads the
vendored files. Three sets (see `data/lamps_*/README.md` for sources, citations
and licences):

- **LSPDD** (`LSPDD2016`, CC BY-NC-ND 2.5 CA: no derivatives): the JSON records
  are copied byte for byte into `data/lamps_lspdd/`; the records of the
  categories `EXCLUDED_LSPDD_CATEGORIES` (CIE standard illuminants that
  colour-science ships, biological action spectra, the sun) are not copied.
  bandopt parses and resamples them in memory at load time.
- **photobiology** (`Aphalo2023`, `Aphalo2024leds`, GPL >= 2): the R data files
  are read with the pure-Python package `rdata` (build extra `build`; never
  needed at run time) and the spectra named in `PHOTOBIOLOGY_LAMPS` and
  `PHOTOBIOLOGY_LEDS` are written unchanged (native wavelengths) to
  `data/lamps_photobiology/spectra.csv` (long format `name,wavelength_nm,value`),
  cut to `KEEP_NM`.
  The 13 `licor_lamps` are the LI-1800 files already in `data/lamps_li1800/`
  and are skipped, as are UV, germicidal, coloured, grow, photographic and
  flashlight sources (not lighting of a city at night).
- **color-pollution** (`Robinson2016`, MIT): the pandas HTML tables at 0.1 nm
  (`LPS`, `HPS`, `MH`, `HgV`) are box-averaged to 0.5 nm (each output sample is
  the mean of the five 0.1 nm samples within +-0.2 nm, which keeps the
  integral); the 1-2 nm tables and the CSV files are kept at their native
  sampling. Written to `data/lamps_color_pollution/spectra.csv` (same long
  format) with `metadata.json`.
"""

import argparse
import hashlib
import io
import json
import re
import shutil
import sys
import warnings
from pathlib import Path

import numpy as np

from ..strict_json import strict_dumps


DATA = Path(__file__).parent / "data"
SHARED = Path(__file__).resolve().parents[3] / "shared" / "data"

KEEP_NM = (360.0, 905.0)
"""Wavelengths kept from the photobiology spectra (the library spans 380-900 nm;
some spectra reach 188-1119 nm). [nm]"""

EXCLUDED_LSPDD_CATEGORIES = ("Standard Illuminant", "Biological Sensitivities", "sun")

PHOTOBIOLOGY_LAMPS: dict[str, str] = {
    # compact fluorescent
    "Airam.CF.15W.2700K": "fluorescent_compact",
    "Airam.CF.Spiraali.14W.3000K": "fluorescent_compact",
    # linear fluorescent
    "Osram.FT.L36W.840": "fluorescent_linear",
    "Osram.FT.L36W.865": "fluorescent_linear",
    "Philips.FT.TL5.35W.830.HE": "fluorescent_linear",
    # household LED bulbs and tubes (phosphor white; warm/cool by CCT)
    "Airam.LED.11W.4000K": "led",
    "Airam.LED.14W.4000K": "led",
    "Airam.LED.9W.3000K": "led",
    "Ikea.LED.6.3W.2700K": "led",
    "Ledenergie.LED.Nano.T8.9.5W.4000K": "led",
    "Ledenergie.LED.Teho.T8.9W.4000K": "led",
    "Ledstore.LED.10W.4000K": "led",
    "Osram.LED.10W.2700K": "led",
    "Osram.LED.8W.2700K": "led",
    "Philips.LED.T8.10W.840": "led",
    "Toshiba.LED.12W.2700K": "led",
    "Toshiba.LED.9.5W.2700K": "led",
    "V.light.LED.2W.6000K": "led",
    # incandescent and halogen (measured to 800 nm)
    "Osram.Inc.20W": "incandescent_halogen",
    "Philips.Inc.50W.spot.halogen": "incandescent_halogen",
}
"""photobiologyLamps `lamps.mspct` spectra taken -> class hint ("led": phosphor
white, warm/cool decided by CCT)."""

PHOTOBIOLOGY_LEDS: dict[str, str] = {
    # direct (AlInGaP) amber emitters: not phosphor-converted
    "Agilent_HLMP_DL32": "led_amber_direct",
    "Epileds_3W_590nm": "led_amber_direct",
    "Epileds_3W_600nm": "led_amber_direct",
    "Osram_LY5436": "led_amber_direct",
    # phosphor-converted amber channel of a multi-channel emitter
    "LedEngin_LZ7_N4M100_ch_F_PC_Amber": "led_amber_pc",
    # white LED packages (phosphor white; warm/cool by CCT)
    "Bridgelux_BXRE_50S2001_c_73": "led",
    "LCFOCUS_LC_10FS504_G24": "led",
    "LCFOCUS_LC_10FSCOB1917_4000": "led",
    "LCFOCUS_LC_10FSCOB1411_6000": "led",
    "LCFOCUS_LC_10FSCOB1411_2700": "led",
    "LedEngin_LZ7_N4M100_ch_E_CW_Cool_white": "led",
    "Nichia_NFSW757G_Rsp0a": "led",
    "Nichia_NFSL757GT_Rsp0a": "led",
    "Nichia_NFCWL036B_V3_Rfcb0": "led",
    "Nichia_NF2W757GT_F1_sm505_Rfc00": "led",
    "Nichia_NS6L183AT_H1_sw": "led",
    "Osram_GW_CSSRM3.HW": "led",
    "Samsung_SPHWHAHDND25YZT3D3": "led",
    "SeoulSemicon_STW9C2SB_S": "led",
}
"""photobiologyLEDs `leds.mspct` spectra taken -> class hint."""

COLOR_POLLUTION: dict[str, dict] = {
    "LPS": {"file": "LPS.html", "hint": "lps", "documented": False},
    "HPS": {"file": "HPS.html", "hint": "hps", "documented": False},
    "MH": {"file": "MH.html", "hint": "metal_halide", "documented": False},
    "HgV": {"file": "HgV.html", "hint": "mercury", "documented": False},
    "WWLED": {"file": "WWLED.html", "hint": "led", "documented": False},
    "CWLED": {"file": "CWLED.html", "hint": "led", "documented": False},
    "FLED_Hilo": {"file": "FLED_Hilo.html", "hint": "led", "documented": False},
    "Philips_Amber_PC_LED": {
        "file": "Philips_Amber_PC_LED.csv",
        "hint": "led_amber_pc",
        "documented": True,
    },
    "PC_Amber": {"file": "PC_Amber.csv", "hint": "led_amber_pc", "documented": False},
    "LE174_H00_N30_2A_29_DOE": {
        "file": "LE174_H00_N30_2A_29_DOE.csv",
        "hint": "led",
        "documented": False,
    },
    "LE174_H00_N50_2A_DOE": {
        "file": "LE174_H00_N50_2A_DOE.csv",
        "hint": "led",
        "documented": False,
    },
    "LE174_H00_N50_2A_CW9_DOE": {
        "file": "LE174_H00_N50_2A_CW9_DOE.csv",
        "hint": "led",
        "documented": False,
    },
    "WW_CW9": {"file": "WW_CW9.csv", "hint": "led", "documented": True},
}
"""color-pollution files taken -> class hint and whether the file itself
documents its instrument (the LI-style headers of `Philips_Amber_PC_LED.csv`
and the sphere report `WW_CW9.csv` do; the HTML tables and the bare CSVs do
not)."""


def _csv_rows(rows) -> str:
    out = io.StringIO()
    out.write("name,wavelength_nm,value\n")
    for name, w, v in rows:
        for x, y in zip(w, v, strict=True):
            out.write(f"{name},{x:.6g},{y:.6g}\n")
    return out.getvalue()


def photobiology_spectra(shared: Path) -> tuple[str, dict]:
    """The selected photobiology spectra as CSV text and metadata."""
    # optional dependency rdata (extra `build`)
    import rdata

    rows, meta = [], {}
    for fname, key, table in (
        ("lamps-mspct.rda", "lamps.mspct", PHOTOBIOLOGY_LAMPS),
        ("leds-mspct.rda", "leds.mspct", PHOTOBIOLOGY_LEDS),
    ):
        with warnings.catch_warnings():
            # rdata has no constructors for the R classes of the spectra's
            # attributes (POSIXct, instr_desc...) and says so; the data frames
            # themselves convert.
            warnings.simplefilter("ignore", UserWarning)
            data = rdata.read_rda(shared / "lamps_photobiology" / fname)
        licor = {str(x) for x in data.get("licor_lamps", [])}
        spectra = data[key]
        for name, hint in table.items():
            if name in licor:
                raise ValueError(f"{name} is an LI-1800 lamp already vendored.")
            if name not in spectra:
                raise ValueError(f"{fname}: no spectrum {name!r} in {key}.")
            df = spectra[name]
            w = np.asarray(df["w.length"], float)
            v = np.asarray(df["s.e.irrad"], float)
            order = np.argsort(w)
            w, v = w[order], v[order]
            ok = np.isfinite(v) & (w >= KEEP_NM[0]) & (w <= KEEP_NM[1])
            rows.append((name, w[ok], v[ok]))
            meta[name] = {
                "file": fname,
                "object": key,
                "hint": hint,
                "range_nm": [float(w[ok][0]), float(w[ok][-1])],
                "samples": int(ok.sum()),
            }
    return _csv_rows(rows), meta


def _read_html_table(path: Path) -> tuple[np.ndarray, np.ndarray, float]:
    text = path.read_text()
    head = re.search(
        r"start = ([\d.]+) nm, end = ([\d.]+) nm, interval = ([\d.]+) nm", text
    )
    if head is None:
        raise ValueError(
            f"{path.name}: no 'start = .., end = .., interval = ..' header."
        )
    start, end, step = (float(x) for x in head.groups())
    vals = np.array([float(x) for x in re.findall(r"<td>([^<]+)</td>", text)])
    w = start + step * np.arange(vals.size)
    # The end is inclusive in most tables and exclusive (numpy arange) in
    # CWLED.html (275 values at 2 nm: 380-928 nm).
    if not -step * 1.5 < w[-1] - end < step / 2:
        raise ValueError(
            f"{path.name}: {vals.size} values do not span {start}-{end} nm."
        )
    return w, vals, step


def _box_average(w, v, step, out_step=0.5):
    """Mean of the samples within +-out_step/2 (exclusive of the far edge) of
    each output wavelength; keeps the band integral."""
    k = round(out_step / step)
    if k <= 1:
        return w, v
    half = k // 2
    centres = np.arange(w[0] + half * step, w[-1] - half * step + step / 2, out_step)
    idx = np.rint((centres - w[0]) / step).astype(int)
    out = np.array([v[i - half : i + half + 1].mean() for i in idx])
    return np.round(centres, 4), out


def _read_cp_csv(path: Path) -> tuple[np.ndarray, np.ndarray]:
    """Numeric `wavelength,value` rows of a color-pollution CSV (the LE174
    files: column 3, absolute mW/nm; the others: column 2)."""
    lines = path.read_bytes().decode("latin-1").replace("\r", "").split("\n")
    col = 2 if path.name.startswith("LE174") else 1
    start = 0
    if path.name == "WW_CW9.csv":
        start = next(
            i for i, x in enumerate(lines) if x.startswith("Wavelength ,Scan1")
        )
    elif path.name == "Philips_Amber_PC_LED.csv":
        start = next(i for i, x in enumerate(lines) if x.startswith("[Data]"))
    w, v = [], []
    for line in lines[start:]:
        p = line.split(",")
        if len(p) <= col or not re.fullmatch(r"\d+(\.\d+)?", p[0].strip()):
            continue
        if not p[col].strip():
            continue  # PC_Amber.csv leaves 380-399 nm empty
        w.append(float(p[0]))
        v.append(float(p[col]))
    if len(w) < 100:
        raise ValueError(f"{path.name}: fewer than 100 numeric rows.")
    return np.array(w), np.array(v)


def color_pollution_spectra(shared: Path) -> tuple[str, dict]:
    rows, meta = [], {}
    folder = shared / "lamps_color_pollution"
    for name, info in COLOR_POLLUTION.items():
        path = folder / info["file"]
        if path.suffix == ".html":
            w, v, step = _read_html_table(path)
            w, v = _box_average(w, v, step)
            native = step
        else:
            w, v = _read_cp_csv(path)
            native = float(np.median(np.diff(w)))
        rows.append((name, w, v))
        meta[name] = {
            "file": info["file"],
            "hint": info["hint"],
            "provenance_documented": info["documented"],
            "native_step_nm": native,
            "stored_step_nm": float(np.median(np.diff(w))),
            "range_nm": [float(w[0]), float(w[-1])],
        }
    return _csv_rows(rows), meta


def _lspdd_files(shared: Path) -> list[Path]:
    keep = []
    for path in sorted((shared / "lamps_lspdd").glob("*.json")):
        rec = json.loads(path.read_text())
        if rec.get("category") not in EXCLUDED_LSPDD_CATEGORIES:
            keep.append(path)
    return keep


def _digest(b: bytes) -> str:
    return hashlib.sha256(b).hexdigest()[:16]


def build(shared: Path, *, write: bool) -> list[str]:
    """Build every set; write it (write=True) or return the differences."""
    diffs = []

    def put(path: Path, content: bytes):
        if write:
            path.parent.mkdir(parents=True, exist_ok=True)
            path.write_bytes(content)
        elif not path.is_file() or _digest(path.read_bytes()) != _digest(content):
            diffs.append(str(path.relative_to(DATA)))

    pb_csv, pb_meta = photobiology_spectra(shared)
    put(DATA / "lamps_photobiology" / "spectra.csv", pb_csv.encode())
    put(
        DATA / "lamps_photobiology" / "metadata.json",
        (strict_dumps(pb_meta, indent=1, sort_keys=True) + "\n").encode(),
    )
    cp_csv, cp_meta = color_pollution_spectra(shared)
    put(DATA / "lamps_color_pollution" / "spectra.csv", cp_csv.encode())
    put(
        DATA / "lamps_color_pollution" / "metadata.json",
        (strict_dumps(cp_meta, indent=1, sort_keys=True) + "\n").encode(),
    )
    files = _lspdd_files(shared)
    names = {p.name for p in files}
    out = DATA / "lamps_lspdd"
    for p in files:
        if write:
            out.mkdir(parents=True, exist_ok=True)
            shutil.copyfile(p, out / p.name)
        elif (
            not (out / p.name).is_file()
            or (out / p.name).read_bytes() != p.read_bytes()
        ):
            diffs.append(f"lamps_lspdd/{p.name}")
    if out.is_dir():
        for extra in out.glob("*.json"):
            if extra.name not in names:
                diffs.append(f"lamps_lspdd/{extra.name} (not in the source)")
    return diffs


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--check", action="store_true", help="compare, do not write")
    ap.add_argument(
        "--shared", type=Path, default=SHARED, help="the shared data folder"
    )
    args = ap.parse_args(argv)
    if not args.shared.is_dir():
        print(f"no shared data folder at {args.shared}", file=sys.stderr)
        return 2
    diffs = build(args.shared, write=not args.check)
    if args.check:
        for d in diffs:
            print("differs:", d)
        print("vendored lamp data", "differ" if diffs else "match the sources")
        return 1 if diffs else 0
    print("wrote data/lamps_photobiology, data/lamps_color_pollution, data/lamps_lspdd")
    return 0


if __name__ == "__main__":
    sys.exit(main())
