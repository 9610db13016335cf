"""Checks the commands apply to band sets before using them.

- `coverage_check`: the one rule for bands beyond the 380-900 nm data, for
  every band set (reference sensor or file): a band with more than
  `MAX_FRACTION_OUTSIDE` of its response area outside is refused, naming it
  and the fraction; a partial loss above `WARN_FRACTION_OUTSIDE` is a warning
  in the command's JSON. It is printed on stderr for a band-set file; a
  shipped reference sensor's loss is fixed and documented
  (`bandopt bands NAME`), so it is not repeated on stderr at every run.
- `has_usable_ratio`: whether a band set has at least one informative band
  ratio (two bands whose responses are not proportional).
"""

import numpy as np


MAX_FRACTION_OUTSIDE = 0.5
"""A band losing more than half of its response area outside the data
(380-900 nm) is refused: most of what it would see is not modelled."""

WARN_FRACTION_OUTSIDE = 1e-3
"""Above this (the library's `band_average` tolerance) a partial loss is
reported as a warning naming the band and the fraction."""


def coverage_check(bands, *, source: str, log=None) -> list[str]:
    """Apply the off-grid policy to `bands` on the library grid: raise
    `ValueError` for a band more than `MAX_FRACTION_OUTSIDE` outside (the
    library's `outside="raise"` with that tolerance), return (and print to
    `log`) a warning for each band losing more than `WARN_FRACTION_OUTSIDE`."""
    from ..spectra import GRID_1NM

    grid = np.asarray(GRID_1NM, float)
    frac = np.asarray(bands.fraction_outside(grid), float)
    names = list(bands.names)
    try:  # the library's policy: outside="raise" with this tolerance
        bands.band_average(
            np.ones((1, grid.size)),
            grid,
            outside="raise",
            tolerance=MAX_FRACTION_OUTSIDE,
        )
    except ValueError:
        bad = [
            f"{n} ({100 * f:.1f} % of its response)"
            for n, f in zip(names, frac, strict=True)
            if f > MAX_FRACTION_OUTSIDE
        ]
        raise ValueError(
            f"{source}: band {', '.join(bad)} lies outside the "
            f"{grid[0]:g}-{grid[-1]:g} nm data; bands must have at least "
            f"{100 * (1 - MAX_FRACTION_OUTSIDE):g} % of their response inside."
        ) from None
    if _shipped(source):
        log = None  # documented once (`bandopt bands NAME`), not at every run
    warnings = [
        f"{source}: band {n} loses {100 * f:.2g} % of its response area beyond the "
        f"{grid[0]:g}-{grid[-1]:g} nm data; its radiance is the average over the "
        "part inside (renormalised)"
        for n, f in zip(names, frac, strict=True)
        if f > WARN_FRACTION_OUTSIDE
    ]
    if log is not None:
        for w in warnings:
            print(f"warning: {w}", file=log)
    return warnings


def _shipped(source) -> bool:
    """True when `source` names a shipped reference sensor (not a file)."""
    from pathlib import Path

    from ..sensor.reference import resolve

    if Path(str(source)).exists():
        return False
    try:
        resolve(str(source))
    except (KeyError, ValueError):
        return False
    return True


def sensor_for_gsd(gsd_m, **kwargs):
    """`SensorParams` (the Table 2.3 integration time when `gsd_m` is None,
    else `SensorParams.for_gsd`); `ValueError` naming `--gsd` when its
    integration time leaves the photon model no counts (radiance to electrons
    underflows float64: a GSD far below any real pixel)."""
    from ..sensor import SensorParams

    if gsd_m is None:
        return SensorParams(**kwargs)
    params = SensorParams.for_gsd(gsd_m, **kwargs)
    scale = float(params.etendue_time_m2_sr_s)
    if not scale >= np.finfo(float).tiny:
        raise ValueError(
            f"--gsd {gsd_m:g}: an integration time of "
            f"{float(params.integration_time_s):.3g} s collects no light (the "
            "sensor's radiance-to-energy factor underflows float64); give the GSD "
            "of a real sensor."
        )
    return params


def has_usable_ratio(bands, *, rtol: float = 1e-6) -> bool:
    """True when some pair of bands has responses that are not proportional
    on the data grid (otherwise every band ratio is a constant and the
    estimators can only return the training mean)."""
    from ..spectra import GRID_1NM

    r = np.asarray(bands.response(np.asarray(GRID_1NM, float)), float)
    if r.ndim != 2 or r.shape[0] < 2:
        return False
    norm = r / np.maximum(np.linalg.norm(r, axis=1, keepdims=True), 1e-300)
    for i in range(len(norm)):
        for j in range(i + 1, len(norm)):
            if np.max(np.abs(norm[i] - norm[j])) > rtol:
                return True
    return False


NO_RATIO_WARNING = (
    "{source}: no usable band ratio ({why}); every LER, G and CCT estimate is "
    "the training mean, whatever the lamp"
)


def ratio_warning(bands, source: str) -> str | None:
    """The warning text when `bands` has no usable ratio, else None."""
    if has_usable_ratio(bands):
        return None
    why = "one band" if len(bands.names) < 2 else "the bands have identical responses"
    return NO_RATIO_WARNING.format(source=source, why=why)


def band_set_warnings(bands, source: str, *, log=None) -> list[str]:
    """`coverage_check` (raises for a band mostly outside the data) plus the
    no-usable-ratio warning, for commands that estimate from band ratios."""
    out = coverage_check(bands, source=source, log=log)
    w = ratio_warning(bands, source)
    if w is not None:
        out.append(w)
        if log is not None:
            print(f"warning: {w}", file=log)
    return out
