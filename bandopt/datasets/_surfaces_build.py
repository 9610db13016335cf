"""Regenerate `data/surfaces/earthlib_surfaces.npz` from the `earthlib` package.

Run `python -m bandopt.datasets._surfaces_build` (rewrites the file) or with
`--check` (compares a fresh extraction with the vendored file, exit 1 on a
difference). Only the build needs `earthlib`; the library reads the .npz.

What is extracted (reference `Anderson2023`, earthlib's *full* library, whose
metadata `spectra.csv` is row-aligned with `spectra.sli`):

- the measured urban ("built") classes asphalt, road, parking lot, sidewalk,
  driveway, composition shingle, wood shingle, tile, metal and concrete roof
  tile, and the bare classes sand and soil. `earthlib.list_types()` lists only
  level-2 classes and misses some level-3 ones (parking_lot, sand), so the
  classes are selected from the metadata table directly;
- only the wavelengths 400-1100 nm (earthlib samples 400-2450 nm at 10 nm;
  nothing is measured below 400 nm);
- every spectrum of every class except soil: of earthlib's 4,185 soil spectra a
  seeded subsample of `N_SOIL` (uniform without replacement, `SOIL_SEED`) is kept
  to keep the file small. The row numbers in earthlib's library are stored
  beside every spectrum, so the subsample does not depend on numpy's generator.

Licence: the earthlib package is MIT; no licence is stated for the spectra it
ships (recorded in the file's metadata and in `data/surfaces/README.md`).
"""

import argparse
import json
import sys
from pathlib import Path

import earthlib
import numpy as np
from earthlib import config


OUT_PATH = Path(__file__).parent / "data" / "surfaces" / "earthlib_surfaces.npz"
RANGE_NM = (400.0, 1100.0)
N_SOIL = 500
SOIL_SEED = 20190101

EARTHLIB_CLASSES: dict[str, tuple[str, str]] = {
    "asphalt": ("built", "asphalt"),
    "road": ("built", "road"),
    "parking_lot": ("built", "parking_lot"),
    "sidewalk": ("built", "sidewalk"),
    "driveway": ("built", "driveway"),
    "composition_shingle": ("built", "comp_shingle"),
    "wood_shingle": ("built", "wood_shingle"),
    "tile_roof": ("built", "tile"),
    "metal_roof": ("built", "metal"),
    "concrete_roof_tile": ("built", "concrete_tile"),
    "sand": ("bare", "sand"),
    "soil": ("bare", "soil"),
}
"""bandopt id -> (earthlib LEVEL_2, LEVEL_3) of the full library's metadata."""


def read_earthlib() -> tuple[np.ndarray, np.ndarray, "object", str]:
    """Earthlib's full library: wavelengths [nm], spectra (7261, 180) [1],
    metadata table and package version."""
    spectra, names, sensor = earthlib.read.envi_library(config.full_endmember_path)
    unit = sensor.wavelength_unit.lower()
    scale = {"micrometers": 1000.0, "nanometers": 1.0}.get(unit)
    if scale is None:
        raise ValueError(f"earthlib library: unknown wavelength unit {unit!r}")
    # the header's float32 micrometres (0.41 -> 409.999996 nm): round to 0.001 nm
    wavelength_nm = np.round(np.asarray(sensor.band_centers, float) * scale, 3)
    meta = config.full_metadata
    if len(meta) != len(spectra):
        raise ValueError(
            f"earthlib library: {len(meta)} metadata rows but {len(spectra)} spectra"
        )
    # earthlib pairs metadata and spectra by row; check the names agree for every
    # row we use (one 'burned' row differs by a typo, not used here).
    meta = meta.assign(SLI_NAME=list(names))
    return wavelength_nm, np.asarray(spectra), meta, earthlib.__version__


def extract(n_soil: int = N_SOIL, seed: int = SOIL_SEED) -> dict[str, np.ndarray]:
    """The arrays written to the .npz (see the module docstring)."""
    wavelength_nm, spectra, meta, version = read_earthlib()
    keep = (wavelength_nm >= RANGE_NM[0]) & (wavelength_nm <= RANGE_NM[1])
    out: dict[str, np.ndarray] = {"wavelength_nm": wavelength_nm[keep]}
    classes = {}
    for name, (level2, level3) in EARTHLIB_CLASSES.items():
        rows = np.flatnonzero(
            (meta["LEVEL_2"].to_numpy() == level2)
            & (meta["LEVEL_3"].to_numpy() == level3)
        )
        n_total = rows.size
        if n_total == 0:
            raise ValueError(f"earthlib has no spectra of class {level2}/{level3}")
        sub = meta.iloc[rows]
        bad = sub["NAME"].to_numpy() != sub["SLI_NAME"].to_numpy()
        if bad.any():
            raise ValueError(
                f"earthlib metadata and spectra disagree for {level3}: "
                f"{sub['NAME'].to_numpy()[bad][:3]}"
            )
        subsample = None
        if name == "soil" and n_soil < n_total:
            rng = np.random.default_rng(seed)
            rows = np.sort(rng.choice(rows, size=n_soil, replace=False))
            subsample = {
                "n": int(n_soil),
                "seed": int(seed),
                "method": "uniform without replacement",
            }
        out[f"reflectance__{name}"] = spectra[rows][:, keep].astype(np.float32)
        out[f"rows__{name}"] = rows.astype(np.int32)
        out[f"ids__{name}"] = meta["NAME"].to_numpy()[rows].astype(str)
        classes[name] = {
            "earthlib_level_2": level2,
            "earthlib_level_3": level3,
            "n_in_earthlib": int(n_total),
            "n_kept": int(rows.size),
            "sources": sorted(set(meta["SOURCE"].to_numpy()[rows].astype(str))),
            "subsample": subsample,
        }
    info = {
        "earthlib_version": version,
        "package_licence": "MIT",
        "data_licence": "not stated by earthlib",
        "library": "earthlib full library (data/spectra.sli + spectra.csv)",
        "range_nm": list(RANGE_NM),
        "classes": classes,
    }
    out["info"] = np.array(json.dumps(info, sort_keys=True))
    return out


def compare(fresh: dict[str, np.ndarray], path: Path = OUT_PATH) -> list[str]:
    """Differences between a fresh extraction and the vendored file."""
    problems = []
    with np.load(path, allow_pickle=False) as old:
        if set(old.files) != set(fresh):
            problems.append(f"keys differ: {sorted(set(old.files) ^ set(fresh))}")
        for key in sorted(set(old.files) & set(fresh)):
            a, b = old[key], fresh[key]
            if key == "info":
                ia, ib = json.loads(str(a)), json.loads(str(b))
                ia.pop("earthlib_version"), ib.pop("earthlib_version")
                same = ia == ib
            else:
                same = a.shape == b.shape and bool(np.all(a == b))
            if not same:
                problems.append(f"{key} differs")
    return problems


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=OUT_PATH)
    parser.add_argument(
        "--check",
        action="store_true",
        help="compare with the vendored file instead of writing",
    )
    args = parser.parse_args(argv)
    fresh = extract()
    if args.check:
        problems = compare(fresh, args.out)
        for p in problems:
            print(p, file=sys.stderr)
        print("up to date" if not problems else "DIFFERS")
        return 1 if problems else 0
    args.out.parent.mkdir(parents=True, exist_ok=True)
    np.savez_compressed(args.out, **fresh)
    print(f"wrote {args.out} ({args.out.stat().st_size / 1e3:.0f} kB)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
