"""Read user lamp spectra: two-column CSV, LI-1800 PRN, IES TM-27 XML.

Every loader returns a `LoadedSpectrum` in energy units on the file's own grid
and validates it the same way (`validate_spectrum`): errors name the file and
the problem. The checks:

- wavelengths strictly increasing (no duplicates), at least 10 points;
- no NaN or infinity;
- values below -1 % of the peak are an error; smaller negatives are noise and
  are clipped to 0 with a `SpectrumWarning`;
- the range must cover 380-780 nm (the photometric range);
- the unit must be known (`UNITS`); photon units are converted to energy.

A spectrum ending at 780 nm is *not* silently padded: the lamp library's
near-infrared policy (`bandopt.datasets.nir`) extends it by its classified
technology, or leaves it flagged, when a band reaches beyond.
"""

import csv
import dataclasses
import io
import warnings
from pathlib import Path

import numpy as np


PHOTON_TO_ENERGY_NM = 119.627
"""Photon to energy: E [W m⁻² nm⁻¹] = q [µmol m⁻² s⁻¹ nm⁻¹] · 119.627 / λ [nm],
since N_A·h·c = 0.119627 J m mol⁻¹ and 1 µmol = 10⁻⁶ mol, 1 m = 10⁹ nm."""

UNITS = {
    "w m-2 nm-1": "energy",
    "w/m2/nm": "energy",
    "w m-2 sr-1 nm-1": "energy",
    "relative": "energy",
    "relative energy": "energy",
    "1": "energy",
    "mw m-2 nm-1": "energy",
    "umol m-2 s-1 nm-1": "photon",
    "µmol m-2 s-1 nm-1": "photon",
    "qntm": "photon",
    "photon": "photon",
}
"""Accepted unit strings (case-insensitive) and whether they are energy or photon
units. Relative units are taken as relative *energy*."""

MIN_POINTS = 10
NEGATIVE_TOLERANCE = 0.01
"""Negative values down to -1 % of the peak are noise (clipped, with a warning)."""
REQUIRED_RANGE_NM = (380.0, 780.0)


class SpectrumWarning(UserWarning):
    """A spectrum was repaired (small negatives clipped)."""


@dataclasses.dataclass(frozen=True)
class LoadedSpectrum:
    """A lamp spectrum read from a file, in energy units on its own grid.

    - `wavelength_nm`: strictly increasing samples. [nm]
    - `values`: relative spectral power in energy units, >= 0. [`unit`]
    - `unit`: the energy unit after conversion.
    - `name`: the lamp's name (from the file's header, or the file stem).
    - `path`: the file read.
    """

    wavelength_nm: np.ndarray
    values: np.ndarray
    unit: str
    name: str
    path: str

    @property
    def measured_range_nm(self) -> tuple[float, float]:
        return float(self.wavelength_nm[0]), float(self.wavelength_nm[-1])


def _unit_kind(unit: str, where: str) -> str:
    key = " ".join(unit.strip().lower().replace("⁻", "-").split())
    if key not in UNITS:
        raise ValueError(
            f"{where}: unknown unit {unit!r}; expected one of {sorted(set(UNITS))}."
        )
    return UNITS[key]


def validate_spectrum(
    wavelength_nm: np.ndarray,
    values: np.ndarray,
    *,
    where: str,
    require_range_nm: tuple[float, float] | None = REQUIRED_RANGE_NM,
) -> np.ndarray:
    """Check a spectrum and return its values with small negatives clipped.

    `where` names the file (and field) in error messages.
    """
    wavelength_nm = np.asarray(wavelength_nm, float)
    values = np.asarray(values, float)
    if wavelength_nm.shape != values.shape or wavelength_nm.ndim != 1:
        raise ValueError(
            f"{where}: wavelength and value columns differ in length "
            f"({wavelength_nm.shape} vs {values.shape})."
        )
    if wavelength_nm.size < MIN_POINTS:
        raise ValueError(
            f"{where}: only {wavelength_nm.size} points; need at least {MIN_POINTS}."
        )
    if not np.all(np.isfinite(wavelength_nm)):
        raise ValueError(f"{where}: wavelength column has NaN or infinite values.")
    bad = np.flatnonzero(~np.isfinite(values))
    if bad.size:
        raise ValueError(
            f"{where}: value is NaN or infinite at {wavelength_nm[bad[0]]:g} nm "
            f"({bad.size} samples)."
        )
    step = np.diff(wavelength_nm)
    if np.any(step == 0):
        i = int(np.flatnonzero(step == 0)[0])
        raise ValueError(f"{where}: duplicate wavelength {wavelength_nm[i]:g} nm.")
    if np.any(step < 0):
        i = int(np.flatnonzero(step < 0)[0])
        raise ValueError(
            f"{where}: wavelengths not increasing at {wavelength_nm[i]:g} -> "
            f"{wavelength_nm[i + 1]:g} nm."
        )
    peak = float(values.max())
    if peak <= 0:
        raise ValueError(f"{where}: no positive value (peak {peak:g}).")
    if peak < np.finfo(float).tiny:
        raise ValueError(
            f"{where}: peak {peak:g} is below the smallest normal float64 "
            f"({np.finfo(float).tiny:g}): its values keep too few digits for "
            "photometry; multiply them by a constant (results are scale-free)."
        )
    if values.min() < -NEGATIVE_TOLERANCE * peak:
        i = int(np.argmin(values))
        raise ValueError(
            f"{where}: value {values[i]:g} at {wavelength_nm[i]:g} nm is negative "
            f"beyond -{NEGATIVE_TOLERANCE:.0%} of the peak {peak:g}."
        )
    if values.min() < 0:
        n = int(np.sum(values < 0))
        warnings.warn(
            f"{where}: {n} small negative values (noise, >= -1 % of peak) "
            "clipped to 0.",
            SpectrumWarning,
            stacklevel=3,
        )
        values = np.clip(values, 0.0, None)
    if require_range_nm is not None:
        lo, hi = require_range_nm
        if wavelength_nm[0] > lo or wavelength_nm[-1] < hi:
            raise ValueError(
                f"{where}: range {wavelength_nm[0]:g}-{wavelength_nm[-1]:g} nm does "
                f"not cover {lo:g}-{hi:g} nm."
            )
    return values


def _to_energy(wavelength_nm, values, kind):
    if kind == "photon":
        return values * PHOTON_TO_ENERGY_NM / wavelength_nm, "W m-2 nm-1"
    return values, "relative energy"


MAX_LINE_CHARS = 1000
"""Longest line the CSV and PRN readers take. A data line holds two numbers
(a float64 prints in at most 24 characters), a header or comment line a few
words; a longer line (a one-line file, a binary file) is refused naming the
file and line before it is held in memory."""

QUOTE_CHARS = 80
"""Error messages quote at most this much of a bad line."""


def _quote(text: str) -> str:
    """`text` for an error message: repr, cut to `QUOTE_CHARS` characters."""
    if len(text) <= QUOTE_CHARS:
        return repr(text)
    return repr(text[:QUOTE_CHARS]) + f"... ({len(text)} characters)"


def _lines(fh, path):
    """(line number, stripped line) of text file `fh`, each read with at most
    `MAX_LINE_CHARS` characters (a longer line raises `ValueError`)."""
    lineno = 0
    while True:
        line = fh.readline(MAX_LINE_CHARS + 1)
        if not line:
            return
        lineno += 1
        if len(line) > MAX_LINE_CHARS and not line.endswith("\n"):
            raise ValueError(
                f"{path}, line {lineno}: longer than {MAX_LINE_CHARS} characters "
                f"(starts {_quote(line)}); a spectrum file has one "
                "'wavelength value' pair per line."
            )
        yield lineno, line.strip()


CSV_CHUNK_ROWS = 100_000
"""Lines parsed per chunk by `read_csv` (numpy's C parser per chunk)."""

MAX_CSV_ROWS = 50_000_000
"""Largest CSV `read_csv` accepts: 50 million rows, 800 MB as float64
pairs (16 bytes per row; peak about twice that while the chunks are joined).
A longer file is refused with an error naming it."""


def _csv_fields(stripped: str) -> list[str]:
    """Split one data line on `,`, `;`, tab (quotes allowed) or spaces."""
    if '"' in stripped or "'" in stripped:
        fields = next(
            csv.reader(io.StringIO(stripped.replace(";", ",").replace("\t", ",")))
        )
    else:
        fields = stripped.replace(";", ",").replace("\t", ",").split(",")
    if len(fields) == 1:
        fields = stripped.split()
    return [f.strip() for f in fields if f.strip() != ""]


def _parse_chunk(lines: list[tuple[int, str]], path) -> np.ndarray:
    """(n, 2) floats of the numbered data lines; the first bad line is named."""
    text = "\n".join(",".join(_csv_fields(s)) for _, s in lines)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("error")  # a ragged chunk: report it below
            data = np.loadtxt(io.StringIO(text), delimiter=",", ndmin=2)
        if data.shape[1] == 2:
            return data
    except ValueError:
        pass
    for lineno, s in lines:  # slow path: find and name the first bad line
        fields = _csv_fields(s)
        try:
            row = [float(f) for f in fields]
        except ValueError:
            raise ValueError(
                f"{path}, line {lineno}: cannot read numbers from {_quote(s)}."
            ) from None
        if len(row) != 2:
            raise ValueError(
                f"{path}, line {lineno}: expected 2 columns (wavelength_nm,value), "
                f"found {len(row)}."
            )
    raise ValueError(
        f"{path}: cannot read the numbers of lines {lines[0][0]}-{lines[-1][0]}."
    )


def _parse_rows(rows, path, reader: str) -> np.ndarray | None:
    """(n, 2) floats of the numbered data lines `rows` (an iterator of
    (line number, text)), parsed `CSV_CHUNK_ROWS` lines at a time so memory
    grows with the numbers, not the text; None when there are none. More
    than `MAX_CSV_ROWS` rows raise `ValueError` (`reader`: whose limit)."""
    chunks: list[np.ndarray] = []
    pending: list[tuple[int, str]] = []
    n_rows = 0
    for row in rows:
        pending.append(row)
        if len(pending) >= CSV_CHUNK_ROWS:
            chunks.append(_parse_chunk(pending, path))
            n_rows += len(pending)
            pending = []
            if n_rows > MAX_CSV_ROWS:
                raise ValueError(
                    f"{path}: more than {MAX_CSV_ROWS:,} rows (the limit of "
                    f"{reader}); resample the spectrum first."
                )
    if pending:
        chunks.append(_parse_chunk(pending, path))
    if not chunks:
        return None
    return chunks[0] if len(chunks) == 1 else np.concatenate(chunks)


def read_csv(
    path: str | Path,
    *,
    unit: str = "relative",
    require_range_nm: tuple[float, float] | None = REQUIRED_RANGE_NM,
) -> LoadedSpectrum:
    """Two-column CSV `wavelength_nm,value`; a header line is optional.

    Separators `,`, `;`, tab or spaces; `#` starts a comment line. `unit` says
    what the values are (`UNITS`); photon units are converted to energy.

    Streamed: the file is read line by line and parsed `CSV_CHUNK_ROWS` lines
    at a time into float64 arrays (16 bytes per row), so memory grows with
    the numbers, not the text. Limit: `MAX_CSV_ROWS` rows.
    """
    path = Path(path)
    kind = _unit_kind(unit, f"{path}: argument unit")

    def rows(fh):
        first = True
        for lineno, stripped in _lines(fh, path):
            if not stripped or stripped.startswith("#"):
                continue
            if first:
                first = False
                try:
                    [float(f) for f in _csv_fields(stripped)]
                except ValueError:
                    continue  # header
            yield lineno, stripped

    with path.open(encoding="utf-8-sig", errors="strict") as fh:
        try:
            data = _parse_rows(rows(fh), path, "the CSV reader")
        except UnicodeDecodeError as err:
            raise ValueError(f"{path}: not a UTF-8 text file ({err}).") from None
    if data is None:
        raise ValueError(f"{path}: no data rows.")
    w = np.ascontiguousarray(data[:, 0])
    v = np.ascontiguousarray(data[:, 1])
    del data
    values = validate_spectrum(w, v, where=str(path), require_range_nm=require_range_nm)
    values, unit_out = _to_energy(w, values, kind)
    return LoadedSpectrum(w, values, unit_out, path.stem, str(path))


def read_prn(
    path: str | Path,
    *,
    max_wavelength_nm: float = 900.0,
    require_range_nm: tuple[float, float] | None = REQUIRED_RANGE_NM,
) -> LoadedSpectrum:
    """LI-COR LI-1800 PRN file: quoted header lines, then `wavelength value`.

    The `REM:` header line's trailing `(QNTM)` or `(ENER)` gives the unit: photon
    spectral irradiance [µmol m⁻² s⁻¹ nm⁻¹] is converted to energy [W m⁻² nm⁻¹].
    Samples beyond `max_wavelength_nm` are dropped (the LI-1800 files measure
    nothing beyond 900 nm whatever their `LIMS:` header says).
    """
    path = Path(path)
    kind = None

    def rows(fh):
        nonlocal kind
        for lineno, s in _lines(fh, path):
            if not s:
                continue
            if s.startswith('"'):
                upper = s.upper()
                if upper.startswith('"REM:'):
                    if "QNTM" in upper:
                        kind = "photon"
                    elif "ENER" in upper:
                        kind = "energy"
                continue
            yield lineno, s

    with path.open(errors="replace") as fh:
        data = _parse_rows(rows(fh), path, "the spectrum readers")
    if kind is None:
        raise ValueError(
            f"{path}: header field REM has no unit (QNTM or ENER); cannot tell "
            "photon from energy units."
        )
    if data is None:
        raise ValueError(f"{path}: no data rows.")
    data = data[data[:, 0] <= max_wavelength_nm]
    values = validate_spectrum(
        data[:, 0], data[:, 1], where=str(path), require_range_nm=require_range_nm
    )
    values, unit_out = _to_energy(data[:, 0], values, kind)
    return LoadedSpectrum(data[:, 0], values, unit_out, path.stem, str(path))


def read_tm27(
    path: str | Path,
    *,
    require_range_nm: tuple[float, float] | None = REQUIRED_RANGE_NM,
) -> LoadedSpectrum:
    """IES TM-27-14 XML spectral data, read with colour-science
    (`colour.SpectralDistribution_IESTM2714`). Photon units are converted."""
    # start-up time: colour takes ~1.5 s to import (only TM-27 files need it)
    import colour

    path = Path(path)
    try:
        sd = colour.SpectralDistribution_IESTM2714(str(path)).read()
    except Exception as err:  # colour raises several XML/parse errors
        raise ValueError(f"{path}: not a readable IES TM-27 file ({err}).") from err
    quantity = str(getattr(sd, "spectral_quantity", None) or "relative").lower()
    if quantity in (
        "absorptance",
        "transmittance",
        "reflectance",
        "r-factor",
        "t-factor",
    ):
        raise ValueError(
            f"{path}: field SpectralQuantity is {quantity!r}, not an emission spectrum."
        )
    kind = "photon" if "photon" in quantity else "energy"
    w = np.asarray(sd.wavelengths, float)
    values = validate_spectrum(
        w,
        np.asarray(sd.values, float),
        where=str(path),
        require_range_nm=require_range_nm,
    )
    values, unit_out = _to_energy(w, values, kind)
    name = getattr(sd.header, "description", None) or path.stem
    return LoadedSpectrum(w, values, unit_out, str(name), str(path))


def read_spectrum(
    path: str | Path,
    *,
    unit: str = "relative",
    require_range_nm: tuple[float, float] | None = REQUIRED_RANGE_NM,
) -> LoadedSpectrum:
    """Read a user spectrum, choosing the reader by file extension:
    `.csv`/`.txt` (two columns), `.prn` (LI-1800), `.xml`/`.spdx` (IES TM-27).
    `require_range_nm`: the range it must cover (None: any, e.g. a
    near-infrared part)."""
    path = Path(path)
    if path.is_dir():
        raise ValueError(f"{path}: is a folder; expected a spectrum file.")
    if path.exists() and not path.is_file():
        raise ValueError(f"{path}: not a regular file; expected a spectrum file.")
    if not path.is_file():
        raise FileNotFoundError(f"{path}: no such file.")
    try:
        return _read_by_suffix(path, unit, require_range_nm)
    except MemoryError:
        raise MemoryError(f"{path}: too large to read into memory") from None


def _read_by_suffix(path: Path, unit: str, require_range_nm) -> LoadedSpectrum:
    suffix = path.suffix.lower()
    if suffix in (".csv", ".txt", ".dat"):
        return read_csv(path, unit=unit, require_range_nm=require_range_nm)
    if suffix == ".prn":
        return read_prn(path, require_range_nm=require_range_nm)
    if suffix in (".xml", ".spdx"):
        return read_tm27(path, require_range_nm=require_range_nm)
    raise ValueError(
        f"{path}: unknown file type {suffix!r}; expected one of "
        "['.csv', '.dat', '.prn', '.spdx', '.txt', '.xml']."
    )


__all__ = [
    "MIN_POINTS",
    "UNITS",
    "LoadedSpectrum",
    "SpectrumWarning",
    "read_csv",
    "read_prn",
    "read_spectrum",
    "read_tm27",
    "validate_spectrum",
]
