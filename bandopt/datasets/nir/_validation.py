"""The leave-one-out validation of the near-infrared extension and its error.

`validate_extension` cuts every lamp measured to 900 nm at 780 nm, extends it
by its technology calibrated without it and compares band powers;
`extension_error` turns those errors into a 90 % range per class or
technology (or a stated bound where there is no validation). A module of its
own because it sits on top of the models (`_model`) and is what the library
and the inversion read about the extension's quality; `bandopt.datasets.nir`
re-exports every public name here.
"""

import dataclasses
import functools

import numpy as np

from .._lamp_sources import (
    EXTENSION_START_NM,
    classes_with_measured_nir,
    lspdd_enabled,
    measured_nir_spectra,
    technology_of,
)
from ._model import (
    LINES_NM,
    UPPER_BOUND,
    _per_lamp_fits,
    extend_spectrum,
    is_validated,
)


VALIDATION_BANDS_NM: dict[str, tuple[float, float]] = {
    "780-900": (780.0, 900.0),
    "780-800": (780.0, 800.0),
    "800-840": (800.0, 840.0),
    "840-900": (840.0, 900.0),
    "500-900": (500.0, 900.0),
}
"""Boxcar bands used to validate the extension (band-integrated power)."""


def validate_extension(lspdd: bool = True) -> list[dict]:
    """Leave-one-out check on every lamp of the library measured to 900 nm.

    Spectra failing `lamps.nir_quality` (clipped or edge-artefact NIR) are
    skipped. Each spectrum is cut at 780 nm and extended by its technology, calibrated
    without it (the line models and mercury; LED and incandescent tails use the
    lamp's own visible part only), and the band powers beyond 780 nm are
    compared with the measurement. Each row: id, level 2, subtype, technology,
    source set, whether the check is leave-one-out (False when the technology
    has a single measured lamp: then the check is in-sample), and per band the
    measured and extended band-integrated power and their relative error.
    """
    grid = np.arange(380.0, 900.01, 1.0)
    vis = grid <= EXTENSION_START_NM
    rows = []
    for m in measured_nir_spectra(lspdd):
        tech = m["technology"]
        if tech is None or m["subtype"] == "white_son" or m["nir_quality"]:
            continue
        s1 = np.interp(grid, m["wavelength_nm"], m["values"])
        exclude = ()
        loo = True
        if tech in LINES_NM:
            ids = _per_lamp_fits(tech, lspdd)[0]
            loo = len(ids) > 1
            exclude = (m["id"],) if loo else ()
        ext = s1.copy()
        ext[~vis] = extend_spectrum(
            grid[vis], s1[vis], tech, grid[~vis], exclude=exclude, lspdd=lspdd
        )
        p_vis = float(np.trapezoid(s1[vis], grid[vis]))
        bands = {}
        for name, (lo, hi) in VALIDATION_BANDS_NM.items():
            b = (grid >= lo) & (grid <= hi)
            true = float(np.trapezoid(s1[b], grid[b]))
            est = float(np.trapezoid(ext[b], grid[b]))
            bands[name] = {
                "measured": true / p_vis,
                "extended": est / p_vis,
                "rel_error": est / true - 1 if true > 0 else None,
            }
        rows.append(
            {
                "id": m["id"],
                "level2": m["level2"],
                "subtype": m["subtype"],
                "technology": tech,
                "source_set": m["source_set"],
                "leave_one_out": loo,
                "bands": bands,
            }
        )
    return rows


ERROR_QUANTILES = (0.05, 0.95)
"""The quantiles of the leave-one-out error that `extension_error` reports: a
90 % range, the interval level of bandopt's estimates."""

MIN_CLASS_LAMPS = 5
"""A class with fewer validated lamps than this takes the error of its
technology's pooled lamps: four points give no 5 % or 95 % quantile worth the
name."""

UPPER_BOUND_ERROR = (-1.0, 0.0)
"""The error range of an upper-bound extension (`UPPER_BOUND`): the true
near-infrared lies between none and the modelled level."""

ERROR_BAND = "780-900"
"""The `VALIDATION_BANDS_NM` band whose power `extension_error` is about."""


@dataclasses.dataclass(frozen=True)
class NirError:
    """The relative error of the near-infrared extension's 780-900 nm band
    power: measured / modelled - 1, so the true power is the modelled one times
    (1 + e) with e in [`low`, `high`].

    - `low`, `high`: the `ERROR_QUANTILES` (5 % and 95 %) of that error over
      the lamps of `basis`, or a stated bound when there is no validation. [1]
    - `n_lamps`: lamps the quantiles come from (0 for a stated bound).
    - `validated`: the range comes from the leave-one-out validation.
    - `basis`: where the range comes from, in words.
    """

    low: float
    high: float
    n_lamps: int
    validated: bool
    basis: str


@functools.cache
def _validated_errors(lspdd: bool) -> tuple[dict, dict]:
    """Leave-one-out errors (measured / modelled - 1 of the `ERROR_BAND` power)
    per level-2 class and per technology, each as (errors, number of lamps left
    out because their extension is 0 there: the ratio is undefined)."""
    by_class: dict[str, list] = {}
    by_tech: dict[str, list] = {}
    for row in validate_extension(lspdd):
        if not row["leave_one_out"]:
            continue
        band = row["bands"][ERROR_BAND]
        for d, key in ((by_class, row["level2"]), (by_tech, row["technology"])):
            errors, zero = d.setdefault(key, [[], 0])
            if band["extended"] > 0.0:
                errors.append(band["measured"] / band["extended"] - 1.0)
            else:
                d[key][1] = zero + 1
    pack = lambda d: {k: (np.array(e), z) for k, (e, z) in d.items()}  # noqa: E731
    return pack(by_class), pack(by_tech)


def _quantile_error(errors: np.ndarray, basis: str) -> NirError:
    lo, hi = np.quantile(errors, ERROR_QUANTILES)
    return NirError(float(lo), float(hi), int(errors.size), True, basis)


def extension_error(
    level2: str | None,
    technology: str | None,
    *,
    subtype: str | None = None,
    lspdd: bool | None = None,
) -> NirError:
    """The measured error of the near-infrared extension of a lamp of class
    `level2` extended as `technology` (None: `technology_of(level2)`), as a
    `NirError` on its 780-900 nm band power.

    - a validated technology and a class with measured near-infrared: the 5 %
      and 95 % quantiles of the leave-one-out error of the class's lamps
      (`validate_extension`), or of the technology's pooled lamps when the
      class has fewer than `MIN_CLASS_LAMPS`;
    - an upper-bound technology (`UPPER_BOUND`, mercury): `UPPER_BOUND_ERROR`;
    - anything else (LPS, calibrated on one lamp; White SON, `subtype`
      "white_son"; classes without measured near-infrared; no technology):
      not validated, and the envelope of the validated technologies' ranges
      (the widest low and high among them): an unvalidated extension is taken
      to be as wrong as the worst validated one.

    Lamps whose extension is 0 in the band (the ratio is undefined) are left
    out of the quantiles, and `basis` counts them. Computed from the
    validation once per `lspdd` setting (a few seconds) and cached.
    """
    use_lspdd = lspdd_enabled(lspdd)
    tech = technology if technology is not None else technology_of(level2)
    by_class, by_tech = _validated_errors(use_lspdd)

    def left_out(zero):
        return (
            f"; {zero} lamps whose extension is 0 in {ERROR_BAND} nm left out "
            "(ratio undefined)"
            if zero
            else ""
        )

    if tech in UPPER_BOUND:
        lo, hi = UPPER_BOUND_ERROR
        return NirError(
            lo,
            hi,
            0,
            False,
            f"{tech}: the extension is an upper bound (the one measured lamp's "
            "780-930 nm level equals its instrument floor): the true power lies "
            "between 0 and the modelled one",
        )
    reason = None
    if tech is None:
        reason = "no extension technology"
    elif not is_validated(tech):
        reason = f"{tech}: calibrated in-sample on a single measured lamp"
    elif subtype == "white_son":
        reason = (
            "White SON (high-CRI HPS): no measured lamp; the HPS calibration "
            "is standard HPS"
        )
    elif level2 is not None and level2 not in classes_with_measured_nir(use_lspdd):
        reason = f"no measured near-infrared for class {level2}"
    if reason is None:
        errors, zero = by_class.get(level2, (np.array([]), 0))
        if errors.size >= MIN_CLASS_LAMPS:
            return _quantile_error(
                errors,
                f"leave-one-out validation of {level2} ({errors.size} lamps, "
                f"{tech} extension, {ERROR_BAND} nm band power){left_out(zero)}",
            )
        few = errors.size
        errors, zero = by_tech[tech]
        return _quantile_error(
            errors,
            f"leave-one-out validation of the {tech} technology's pooled lamps "
            f"({errors.size} lamps; class {level2} has {few} < {MIN_CLASS_LAMPS}; "
            f"{ERROR_BAND} nm band power){left_out(zero)}",
        )
    ranges = [_quantile_error(e, "") for e, _ in by_tech.values()]
    return NirError(
        min(r.low for r in ranges),
        max(r.high for r in ranges),
        0,
        False,
        f"no leave-one-out validation ({reason}): the envelope of the validated "
        f"technologies' 5-95 % ranges ({', '.join(sorted(by_tech))})",
    )
