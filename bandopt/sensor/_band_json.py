"""Band sets as JSON: the fields `BandSet.from_json` / `from_dict` read and
the ones they ignore, with every error naming the file (or text) and field.

Kept apart from `_bands` because reading and checking a user's file is a
task of its own (one message per malformed field) and has no part in the
band maths; `BandSet.from_dict` turns what `band_fields` returns into bands.
"""

import dataclasses
import json
import os
from pathlib import Path

import numpy as np

from ._band_common import DATA_RANGE_NM


SUMMARY_FIELDS = frozenset(
    {
        "kind",
        "grid_nm",
        "key",
        "title",
        "gsd_m",
        "bit_depth",
        "detection_limit_w_m2_sr_nm",
        "citations",
        "response",
        "note",
    }
)
"""Top-level fields of `bandopt bands --json` that describe a band set
without defining it; `BandSet.from_dict` ignores them."""

SUMMARY_BAND_FIELDS = frozenset({"half_max_edges_nm", "fraction_outside_grid"})
"""Per-band fields of `bandopt bands --json` that `from_dict` ignores."""


@dataclasses.dataclass(frozen=True)
class BandFields:
    """A band set's definition as read from a JSON object.

    - `centres_nm`, `fwhms_nm` [nm] and `shape_k` [1]: one per band;
    - `names`: one per band; `name`: the set's;
    - `kwargs`: the caller's keyword arguments for `BandSet.from_physical`,
      with `lower_nm`, `upper_nm` [nm] set from `range_nm` or the bands'
      supports where the caller did not give them.
    """

    centres_nm: list
    fwhms_nm: list
    shape_k: list
    names: list
    name: str
    kwargs: dict


def read_json(source: str | os.PathLike) -> tuple[object, str]:
    """`(parsed JSON, label)` of a file path or a JSON text starting with `{`;
    the label (the path, or `<json text>`) starts every error message."""
    text_given = isinstance(source, str) and source.lstrip().startswith("{")
    label = "<json text>" if text_given else str(source)
    try:
        text = source if text_given else Path(source).read_text()
    except UnicodeDecodeError:
        raise ValueError(
            f"{label}: not a band-set JSON file (not UTF-8 text)."
        ) from None
    except OSError as err:
        raise ValueError(f"{label}: cannot read band-set file ({err}).") from err
    try:
        data = json.loads(text)
    except json.JSONDecodeError as err:
        raise ValueError(f"{label}: invalid JSON ({err}).") from err
    return data, label


def band_fields(data, label: str, kwargs: dict) -> BandFields:
    """Check and read a parsed band-set object (the rules of
    `BandSet.from_json`); `kwargs` (not changed) are the caller's keyword
    arguments for `BandSet.from_physical`. Raises `ValueError` naming
    `label` and the field."""
    kwargs = dict(kwargs)

    def fail(field, problem):
        raise ValueError(f"{label}: {field}: {problem}")

    def number(field, value, positive=False):
        if isinstance(value, bool) or not isinstance(value, int | float):
            fail(field, f"expected a number, got {value!r}")
        if not np.isfinite(value) or (positive and value <= 0):
            fail(
                field,
                f"expected a {'positive ' if positive else ''}finite "
                f"number, got {value!r}",
            )
        return float(value)

    if not isinstance(data, dict):
        fail("<top level>", "expected an object with 'name' and 'bands'")
    if data.get("kind") == "tabulated":
        fail(
            "kind",
            "a tabulated response (`bandopt bands --json` of a tabulated "
            "sensor) has no centre/FWHM form; give the sensor's name instead",
        )
    unknown = set(data) - {"name", "bands", "range_nm", *SUMMARY_FIELDS}
    if unknown:
        fail(sorted(unknown)[0], "unknown field; expected name, bands, range_nm")
    name = data.get("name", Path(label).stem)
    if not isinstance(name, str):
        fail("name", f"expected a string, got {name!r}")
    if "range_nm" in data:
        rng = data["range_nm"]
        if not (isinstance(rng, list) and len(rng) == 2):
            fail("range_nm", f"expected [lower, upper], got {rng!r}")
        kwargs.setdefault("lower_nm", number("range_nm[0]", rng[0]))
        kwargs.setdefault("upper_nm", number("range_nm[1]", rng[1]))
    bands = data.get("bands")
    if not isinstance(bands, list) or not bands:
        fail("bands", "expected a non-empty list of band objects")
    names, centres, fwhms, ks = [], [], [], []
    for i, band in enumerate(bands):
        where = f"bands[{i}]"
        if not isinstance(band, dict):
            fail(where, f"expected an object, got {band!r}")
        extra = set(band) - {
            "name",
            "centre_nm",
            "fwhm_nm",
            "shape_k",
            "edges_nm",
            *SUMMARY_BAND_FIELDS,
        }
        if extra:
            fail(
                f"{where}.{sorted(extra)[0]}",
                "unknown field; expected name, "
                "centre_nm, fwhm_nm, shape_k or edges_nm",
            )
        bname = band.get("name", f"B{i + 1}")
        if not isinstance(bname, str):
            fail(f"{where}.name", f"expected a string, got {bname!r}")
        if "edges_nm" in band:
            if "centre_nm" in band or "fwhm_nm" in band:
                fail(where, "give either edges_nm or centre_nm/fwhm_nm, not both")
            e = band["edges_nm"]
            if not (isinstance(e, list) and len(e) == 2):
                fail(f"{where}.edges_nm", f"expected [lower, upper], got {e!r}")
            lo = number(f"{where}.edges_nm[0]", e[0])
            hi = number(f"{where}.edges_nm[1]", e[1])
            if hi <= lo:
                fail(f"{where}.edges_nm", f"need lower < upper, got {e!r}")
            centre, fwhm = 0.5 * (lo + hi), hi - lo
        else:
            for f in ("centre_nm", "fwhm_nm"):
                if f not in band:
                    fail(f"{where}.{f}", "missing (or give edges_nm)")
            centre = number(f"{where}.centre_nm", band["centre_nm"])
            fwhm = number(f"{where}.fwhm_nm", band["fwhm_nm"], positive=True)
        k = number(f"{where}.shape_k", band.get("shape_k", 6.0), positive=True)
        names.append(bname)
        centres.append(centre)
        fwhms.append(fwhm)
        ks.append(k)
    if len(set(names)) != len(names):
        fail("bands[].name", f"band names must be unique, got {names}")
    lo_edge = min(c - f / 2 for c, f in zip(centres, fwhms, strict=True))
    hi_edge = max(c + f / 2 for c, f in zip(centres, fwhms, strict=True))
    if lo_edge < DATA_RANGE_NM[0]:  # the reference sensors' rule (_edges)
        kwargs.setdefault("lower_nm", lo_edge - 1.0)
    if hi_edge > DATA_RANGE_NM[1]:
        kwargs.setdefault("upper_nm", hi_edge + 1.0)
    return BandFields(centres, fwhms, ks, names, name, kwargs)
