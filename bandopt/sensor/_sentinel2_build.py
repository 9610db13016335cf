"""Vendor the Sentinel-2A MSI spectral responses that Py6S ships into package data.

Run `python -m bandopt.sensor._sentinel2_build` (needs the `atmos` extra, i.e.
Py6S; never at run time). Py6S (`Wilson2013`) stores each band as
`(6S band id, start [µm], end [µm], response at 2.5 nm steps)`, taken from the
ESA Sentinel-2 spectral response functions (`ESA2017S2SRF`). Written:
`bandopt/sensor/data/sentinel2a_msi_srf.csv`, one column per band on a 2.5 nm
grid, zero outside each band's tabulated range.
"""

import sys
from pathlib import Path

import numpy as np


OUT = Path(__file__).parent / "data" / "sentinel2a_msi_srf.csv"
BANDS = ("01", "02", "03", "04", "05", "06", "07", "08", "8A", "09")
"""MSI bands up to 950 nm (the longer ones see no night-time lamp light)."""


def build(out: Path = OUT) -> Path:
    # optional dependency Py6S (extra `atmos`)
    from Py6S import PredefinedWavelengths as P

    grid = np.round(np.arange(400.0, 1000.0 + 1e-9, 2.5), 2)
    cols = []
    for b in BANDS:
        _, start, end, values = getattr(P, f"S2A_MSI_{b}")
        wl = 1000.0 * start + 2.5 * np.arange(len(values))
        if abs(wl[-1] - 1000.0 * end) > 1e-6:
            raise RuntimeError(f"Py6S S2A_MSI_{b}: grid does not end at {end} µm")
        cols.append(np.interp(grid, wl, values, left=0.0, right=0.0))
    header = "wavelength_nm," + ",".join(f"B{b}" for b in BANDS)
    rows = np.column_stack([grid, *cols])
    np.savetxt(out, rows, delimiter=",", header=header, comments="", fmt="%.6g")
    return out


if __name__ == "__main__":
    print(build(Path(sys.argv[1]) if len(sys.argv) > 1 else OUT))
