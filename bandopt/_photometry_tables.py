"""Observer and Planckian tables for `bandopt.photometry`, read from colour-science.

Taken from colour-science (`Mansencal2025`) at first use and cached; every array
is read-only NumPy float64.

- CIE 1931 2° colour-matching functions and the CIE 1924 photopic luminous
  efficiency function V(λ), 360-830 nm at 1 nm, as tabulated by the CIE
  (`CIE2018`); no interpolation.
- The Ohno (2013) Planckian table (`Ohno2014`): colour's own
  `colour.temperature.ohno2013.planckian_table` with colour's defaults, so that
  CCT and Duv agree with `colour.temperature.uv_to_CCT_Ohno2013` to rounding:
  CMFs on 360-780 nm at 1 nm (colour's `SPECTRAL_SHAPE_DEFAULT`, rectangle sums),
  1000-100000 K, spacing factor 1.001 shrinking to 1.0001 towards 100000 K
  (6849 rows), Planck's law (`Planck1901`) with colour's radiation constants.
- The Robertson (1968) isotemperature lines (`Robertson1968`), 0-600 mired, with
  Lindbloom's correction at 325 mired, as colour ships them.
"""

import functools

import numpy as np


OBSERVER_START_NM = 360.0
"""First wavelength of the observer tables. [nm]"""
OBSERVER_END_NM = 830.0
"""Last wavelength of the observer tables. [nm]"""

OHNO2013_START_K = 1000.0
"""Lowest temperature of the Ohno (2013) Planckian table. [K]"""
OHNO2013_END_K = 100000.0
"""Highest temperature of the Ohno (2013) Planckian table. [K]"""
OHNO2013_SPACING = 1.001
"""Multiplicative spacing of the Ohno (2013) Planckian table (colour's default). [1]"""


def _frozen(a) -> np.ndarray:
    a = np.array(a, dtype=np.float64)
    a.setflags(write=False)
    return a


@functools.cache
def observer_tables() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """`(wavelength_nm (w,), v_lambda (w,), cmfs_xyz (w, 3))` on 360-830 nm at 1 nm.

    V(λ) is the CIE 1924 photopic observer; the CMFs are the CIE 1931 2°
    standard observer x̄, ȳ, z̄. [nm], [1], [1]
    """
    # start-up time: colour takes ~1.5 s to import; tables are read at first use
    import colour

    wavelength_nm = np.arange(OBSERVER_START_NM, OBSERVER_END_NM + 0.5, 1.0)
    lef = colour.SDS_LEFS["CIE 1924 Photopic Standard Observer"]
    cmfs = colour.MSDS_CMFS["CIE 1931 2 Degree Standard Observer"]
    for table in (lef, cmfs):
        if table.shape.interval != 1 or not (
            table.shape.start <= OBSERVER_START_NM
            and table.shape.end >= OBSERVER_END_NM
        ):
            raise RuntimeError(f"colour's {table.name!r} is not tabulated at 1 nm.")
    return (
        _frozen(wavelength_nm),
        _frozen(lef[wavelength_nm]),
        _frozen(cmfs[wavelength_nm]),
    )


@functools.cache
def planckian_table_ohno2013() -> np.ndarray:
    """Ohno (2013) Planckian table, rows `(T [K], u, v)` in CIE 1960 UCS. (n, 3)"""
    # start-up time: colour takes ~1.5 s to import
    from colour.colorimetry import handle_spectral_arguments
    from colour.temperature.ohno2013 import planckian_table

    cmfs, _ = handle_spectral_arguments()  # CIE 1931 2°, 360-780 nm at 1 nm
    return _frozen(
        planckian_table(cmfs, OHNO2013_START_K, OHNO2013_END_K, OHNO2013_SPACING)
    )


@functools.cache
def isotemperature_lines_robertson1968() -> np.ndarray:
    """Robertson (1968) isotemperature lines, rows `(mired, u, v, slope)`. (31, 4)

    Mired is the reciprocal megakelvin 10⁶/T [MK⁻¹]; `(u, v)` is the line's point
    on the Planckian locus and `slope` the line's slope dv/du [1], as tabulated
    (colour's `DATA_ISOTEMPERATURE_LINES_ROBERTSON1968`).
    """
    # start-up time: colour takes ~1.5 s to import
    from colour.temperature.robertson1968 import (
        DATA_ISOTEMPERATURE_LINES_ROBERTSON1968,
    )

    return _frozen(DATA_ISOTEMPERATURE_LINES_ROBERTSON1968)
