"""Band sets: the parametric `BandSet` (`_parametric`), the tabulated
`TabulatedBands` (`_tabulated`), `Bands` for either, and the CSV export of
any band set's response.

The one place the sensor package (`bandopt.sensor`, `sensor.reference`)
imports band sets from; the parts live in `_band_common` (range, bounds,
off-grid policy), `_band_json` (reading a band set's JSON), `_parametric`
and `_tabulated`.
"""

import csv
import os
from pathlib import Path

import jax.numpy as jnp
import numpy as np

from ..spectra import GRID_1NM
from ._band_common import (
    DATA_RANGE_NM as DATA_RANGE_NM,
    MIN_FWHM_NM as MIN_FWHM_NM,
    SHAPE_K_RANGE as SHAPE_K_RANGE,
    Numbers as Numbers,
    OutsidePolicy as OutsidePolicy,
)
from ._band_json import (
    SUMMARY_BAND_FIELDS as SUMMARY_BAND_FIELDS,
    SUMMARY_FIELDS as SUMMARY_FIELDS,
)
from ._parametric import BandSet as BandSet
from ._tabulated import TabulatedBands as TabulatedBands


Bands = BandSet | TabulatedBands
"""Anything with `names`, `response(wavelength_nm)` and `fraction_outside(...)`."""


def export_response_csv(
    bands: Bands,
    path: str | os.PathLike,
    wavelength_nm: Numbers | None = None,
) -> Path:
    """Write each band's response as a CSV table: `wavelength_nm,<band names...>`.

    Default grid `GRID_1NM` (380-900 nm, 1 nm). Returns the path.
    """
    wl = np.asarray(GRID_1NM if wavelength_nm is None else wavelength_nm, float)
    r = np.asarray(bands.response(jnp.asarray(wl)))
    path = Path(path)
    with path.open("w", newline="") as fh:
        writer = csv.writer(fh)
        writer.writerow(["wavelength_nm", *bands.names])
        for j, w in enumerate(wl):
            writer.writerow([f"{w:g}", *(f"{v:.8g}" for v in r[:, j])])
    return path


__all__ = [
    "DATA_RANGE_NM",
    "MIN_FWHM_NM",
    "SHAPE_K_RANGE",
    "BandSet",
    "Bands",
    "TabulatedBands",
    "export_response_csv",
]
