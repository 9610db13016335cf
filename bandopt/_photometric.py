"""Photometric files: EULUMDAT (.ldt), IES LM-63 (.ies) and Illumina .lop profiles.

Every reader returns an `IntensityTable`: luminous intensity on the angles the
file gives, in the Type C system used by road lighting:

- `gamma_deg`: vertical angle from straight *down* (nadir, 0) to straight up
  (180). [deg]
- `c_deg`: azimuth of the C-plane, 0-360, counted from C0 towards C90; in a
  road luminaire C0 runs along the road and C90 points across it. [deg]
- `intensity`: (c, g) intensity in the file's own unit (`unit`).

Symmetric files are expanded to the full 0-360 range (the planes the file
omits are mirrored), so every table covers 0-360 and ends with C = 360 equal
to C = 0.

Formats (references `Stockmar1990` for EULUMDAT and `IESNA2002` for LM-63):

- **EULUMDAT**: fixed line positions (26 header lines, lamp sets, 10 direct
  ratios, C and G angles, then the intensities in cd/1000 lm of the stored
  C-planes `Mc1..Mc2` given by the symmetry indicator Isym 0-4).
- **IES LM-63** (1986, 1991, 1995, 2002 layouts): keyword lines, `TILT=NONE`
  (a TILT table is refused), then whitespace- or comma-separated numbers over
  any number of lines. Photometric type C (1) only. The last horizontal angle
  selects the symmetry: 0 (rotational), 90 (quadrant), 180 (bilateral about
  C0-C180), 360 (none); 90-270 (bilateral about C90-C270).
- **.lop** (Illumina `Aube2018`): two columns, relative intensity and zenith
  angle (0 = straight up .. 180 = straight down), azimuth-averaged.

A malformed file raises `ValueError` naming the file and the line.
"""

import dataclasses
import re
from pathlib import Path

import numpy as np


@dataclasses.dataclass(frozen=True)
class IntensityTable:
    """Intensity on a (C, γ) grid read from a file.

    - `c_deg`: C-plane azimuths, increasing, 0-360 inclusive. [deg]
    - `gamma_deg`: vertical angles from nadir, increasing within 0-180. [deg]
    - `intensity`: (c, g) intensity. [`unit`]
    - `unit`: `"cd/klm"` (EULUMDAT), `"cd"` (IES) or `"relative"` (.lop).
    - `lamp_flux_lm`: lamp flux the file states (None if not given). [lm]
    - `name`: luminaire name from the file; `source`: the path.
    """

    c_deg: np.ndarray
    gamma_deg: np.ndarray
    intensity: np.ndarray
    unit: str
    lamp_flux_lm: float | None
    name: str
    source: str


def _to_number(tok: str, label: str, line: int, what: str, integer: bool):
    """`tok` as a finite number (an `int` with `integer`); a malformed one
    raises `ValueError` naming file `label`, `line` and the field `what`."""
    try:
        value = float(tok)
    except ValueError:
        raise ValueError(
            f"{label}: line {line}: {what}: expected a number, got {tok!r}."
        ) from None
    if not np.isfinite(value):
        raise ValueError(f"{label}: line {line}: {what}: not finite ({tok!r}).")
    if integer and value != int(value):
        raise ValueError(
            f"{label}: line {line}: {what}: expected an integer, got {tok!r}."
        )
    return int(value) if integer else value


class _Tokens:
    """Numbers of a text with the line each came from (1-based)."""

    def __init__(self, lines: list[str], first_line: int, label: str):
        self.items: list[tuple[str, int]] = []
        for k, line in enumerate(lines):
            for tok in re.split(r"[\s,]+", line.strip()):
                if tok:
                    self.items.append((tok, first_line + k))
        self.pos = 0
        self.label = label
        self.last_line = first_line + max(len(lines) - 1, 0)

    def number(self, what: str, *, integer: bool = False) -> float | int:
        if self.pos >= len(self.items):
            raise ValueError(
                f"{self.label}: line {self.last_line}: file ends before {what}."
            )
        tok, line = self.items[self.pos]
        self.pos += 1
        return _to_number(tok, self.label, line, what, integer)

    def line(self) -> int:
        return self.items[min(self.pos, len(self.items) - 1)][1] if self.items else 1


def _read_lines(path) -> tuple[list[str], str]:
    label = str(path)
    try:
        raw = Path(path).read_bytes()
    except OSError as err:
        raise ValueError(f"{label}: cannot read photometric file ({err}).") from err
    text = raw.decode("utf-8", errors="replace")
    return text.splitlines(), label


def _check_angles(values, label, line, what, lo, hi):
    a = np.asarray(values, float)
    if a.size and (np.any(np.diff(a) <= 0) or a[0] < lo - 1e-9 or a[-1] > hi + 1e-9):
        raise ValueError(
            f"{label}: line {line}: {what} must increase strictly within "
            f"[{lo:g}, {hi:g}], got {a[:6].tolist()}{'...' if a.size > 6 else ''}."
        )
    return a


def _read_angles(t, n: int, what: str, label: str, hi: float):
    """The next `n` numbers of token reader `t`, angles called `what` (an
    error names "`what` k"), checked by `_check_angles` within [0, `hi`]
    [deg]; and the line they start on."""
    line = t.line()
    values = [t.number(f"{what} {k + 1}") for k in range(n)]
    return _check_angles(values, label, line, f"{what}s", 0.0, hi), line


def _check_intensity(values, label, line):
    a = np.asarray(values, float)
    if np.any(a < 0):
        raise ValueError(f"{label}: line {line}: negative luminous intensity.")
    return a


def _expand(c_deg, intensity, symmetry: str):
    """Mirror the stored planes to 0-360 (inclusive). `symmetry`: `"none"`,
    `"rotational"`, `"c0-c180"`, `"c90-c270"`, `"both"`."""
    c = np.asarray(c_deg, float)
    i = np.asarray(intensity, float)
    if symmetry == "rotational":
        return np.array([0.0, 360.0]), np.stack([i[0], i[0]])
    if symmetry == "both":  # stored 0..90: mirror to 0..180, then to 0..360
        c = np.concatenate([c, 180.0 - c[-2::-1]])
        i = np.concatenate([i, i[-2::-1]])
        symmetry = "c0-c180"
    if symmetry == "c0-c180":  # stored 0..180
        c = np.concatenate([c, 360.0 - c[-2::-1]])
        i = np.concatenate([i, i[-2::-1]])
    elif symmetry == "c90-c270":  # stored 90..270 (increasing)
        # I(C) = I(180 - C): 270..360 from 270..180, 0..90 from 180..90
        left = 180.0 - c[::-1]  # -90..90
        c_full = np.concatenate([left[1:-1], c])  # (-90, 90) and [90, 270]
        i_full = np.concatenate([i[::-1][1:-1], i])
        c_full = np.where(c_full < 0, c_full + 360.0, c_full)
        order = np.argsort(c_full, kind="stable")
        c, i = c_full[order], i_full[order]
        if c[0] > 0:  # no plane at C0: interpolate across the 360 wrap
            w = c[0] / (c[0] + 360.0 - c[-1])
            c = np.concatenate([[0.0], c])
            i = np.concatenate([(w * i[-1] + (1 - w) * i[0])[None], i])
    if c[-1] < 360.0:
        if c[0] != 0.0:
            raise ValueError("C-planes must start at 0 deg.")
        c = np.concatenate([c, [360.0]])
        i = np.concatenate([i, i[:1]])
    return c, i


# -- EULUMDAT -------------------------------------------------------------------


def read_ldt(path) -> IntensityTable:
    """Read a EULUMDAT file (`Stockmar1990`). Intensities stay in cd/1000 lm of
    lamp flux; `lamp_flux_lm` is the flux of the first lamp set. Raises
    `ValueError` naming the file and line when the file is malformed."""
    lines, label = _read_lines(path)

    def field(n: int, what: str, *, integer=False) -> float | int:
        if n > len(lines):
            raise ValueError(f"{label}: line {n}: file ends before {what}.")
        tok = lines[n - 1].strip().replace(",", ".")
        return _to_number(tok, label, n, what, integer)

    isym = field(3, "symmetry indicator Isym", integer=True)
    if isym not in (0, 1, 2, 3, 4):
        raise ValueError(f"{label}: line 3: Isym must be 0-4, got {isym}.")
    mc = field(4, "number of C-planes Mc", integer=True)
    field(5, "distance between C-planes Dc")
    ng = field(6, "number of intensities per C-plane Ng", integer=True)
    field(7, "distance between intensities Dg")
    if mc < 1 or ng < 2:
        raise ValueError(
            f"{label}: lines 4/6: need Mc >= 1 and Ng >= 2, got {mc}, {ng}."
        )
    if (isym in (2, 3) and mc % 2) or (isym == 4 and mc % 4):
        raise ValueError(f"{label}: line 4: Mc={mc} does not fit symmetry Isym={isym}.")
    name = lines[8].strip() if len(lines) >= 9 else ""
    n_sets = field(26, "number of lamp sets n", integer=True)
    if not 1 <= n_sets <= 20:
        raise ValueError(
            f"{label}: line 26: number of lamp sets must be 1-20, got {n_sets}."
        )
    flux = field(26 + 1 + 2 * n_sets, "total luminous flux of lamps")
    start = 26 + 6 * n_sets + 10 + 1  # first C angle (1-based line number)
    c_all = [field(start + k, f"C angle {k + 1}") for k in range(mc)]
    g = [field(start + mc + k, f"G angle {k + 1}") for k in range(ng)]
    c_all = _check_angles(c_all, label, start, "C angles", 0.0, 360.0)
    g = _check_angles(g, label, start + mc, "G angles", 0.0, 180.0)
    mc1, mc2 = {
        0: (1, mc),
        1: (1, 1),
        2: (1, mc // 2 + 1),
        3: (3 * mc // 4 + 1, 3 * mc // 4 + 1 + mc // 2),
        4: (1, mc // 4 + 1),
    }[isym]
    n_planes = mc2 - mc1 + 1
    first = start + mc + ng
    values = [
        field(first + k, f"intensity {k + 1} (plane {k // ng + 1}, angle {k % ng + 1})")
        for k in range(n_planes * ng)
    ]
    inten = _check_intensity(values, label, first).reshape(n_planes, ng)
    # C angles of the stored planes (index modulo Mc for Isym 3, which wraps)
    c_stored = np.array([c_all[(k - 1) % mc] for k in range(mc1, mc2 + 1)])
    sym = {0: "none", 1: "rotational", 2: "c0-c180", 3: "c90-c270", 4: "both"}[isym]
    if isym == 3:  # stored C270..C360(=C0)..C90: reorder as C90..C270 by mirroring
        c_stored = np.where(c_stored >= 270.0, c_stored - 360.0, c_stored)  # -90..90
        # I(C) = I(180 - C) maps stored -90..90 onto 90..270
        c_stored = (180.0 - c_stored)[::-1]
        inten = inten[::-1]
    if sym == "none" and c_stored[0] != 0.0:
        raise ValueError(
            f"{label}: line {start}: first C angle must be 0, got {c_stored[0]}."
        )
    expected_last = {"c0-c180": 180.0, "both": 90.0, "c90-c270": 270.0}.get(sym)
    if expected_last is not None and abs(c_stored[-1] - expected_last) > 1e-6:
        raise ValueError(
            f"{label}: line {start}: stored C-planes end at {c_stored[-1]:g} deg, "
            f"Isym={isym} needs {expected_last:g} deg."
        )
    c, i = _expand(c_stored, inten, sym)
    return IntensityTable(c, g, i, "cd/klm", flux, name, label)


# -- IES LM-63 ------------------------------------------------------------------


def read_ies(path) -> IntensityTable:
    """Read an IES LM-63 file (`IESNA2002`; 1986-2002 layouts), `TILT=NONE`,
    photometric type C. Intensities in candela times the candela multiplier;
    `lamp_flux_lm` is lamps x lumens per lamp (None for absolute photometry,
    -1). Raises `ValueError` naming the file and line when malformed."""
    lines, label = _read_lines(path)
    tilt = None
    for k, line in enumerate(lines):
        s = line.strip()
        if s.upper().startswith("TILT"):
            tilt = k
            break
    if tilt is None:
        raise ValueError(f"{label}: line {len(lines)}: no TILT= line found.")
    value = lines[tilt].split("=", 1)[-1].strip().upper()
    if value != "NONE":
        raise ValueError(
            f"{label}: line {tilt + 1}: only TILT=NONE is supported, got TILT={value}."
        )
    name = ""
    for line in lines[:tilt]:
        m = re.match(r"\s*\[(LUMINAIRE|LUMCAT)\]\s*(.*)", line, re.IGNORECASE)
        if m and not name:
            name = m.group(2).strip()
    t = _Tokens(lines[tilt + 1 :], tilt + 2, label)
    n_lamps = t.number("number of lamps", integer=True)
    lm_per_lamp = t.number("lumens per lamp")
    mult = t.number("candela multiplier")
    line_nv = t.line()
    nv = t.number("number of vertical angles", integer=True)
    nh = t.number("number of horizontal angles", integer=True)
    line_type = t.line()
    ptype = t.number("photometric type", integer=True)
    t.number("units type", integer=True)
    for what in (
        "width",
        "length",
        "height",
        "ballast factor",
        "ballast-lamp photometric factor / future use",
        "input watts",
    ):
        t.number(what)
    if ptype != 1:
        raise ValueError(
            f"{label}: line {line_type}: photometric type {ptype} is not supported "
            "(only type C = 1)."
        )
    if nv < 2 or nh < 1:
        raise ValueError(
            f"{label}: line {line_nv}: need >= 2 vertical and >= 1 horizontal angles, "
            f"got {nv} and {nh}."
        )
    v, _ = _read_angles(t, nv, "vertical angle", label, 180.0)
    h, line_h = _read_angles(t, nh, "horizontal angle", label, 360.0)
    line_c = t.line()
    cand = [t.number(f"candela value {k + 1}") for k in range(nv * nh)]
    cand = _check_intensity(cand, label, line_c).reshape(nh, nv) * mult
    if t.pos < len(t.items):
        tok, line = t.items[t.pos]
        raise ValueError(f"{label}: line {line}: unexpected extra value {tok!r}.")
    if not mult > 0:
        raise ValueError(f"{label}: line {line_nv}: candela multiplier must be > 0.")
    # vertical angles 0-90 (down only) or 90-180 (up only): pad the rest with 0
    if v[0] > 0:
        v = np.concatenate([[0.0], v])
        cand = np.concatenate([np.zeros((nh, 1)), cand], axis=1)
    if v[-1] < 180:
        v = np.concatenate([v, [180.0]])
        cand = np.concatenate([cand, np.zeros((nh, 1))], axis=1)
    if nh == 1:
        if h[0] != 0:
            raise ValueError(
                f"{label}: line {line_h}: a single horizontal angle must be 0."
            )
        sym = "rotational"
    elif h[0] == 0 and h[-1] == 90:
        sym = "both"
    elif h[0] == 0 and h[-1] == 180:
        sym = "c0-c180"
    elif h[0] == 0 and h[-1] == 360:
        sym = "none"
    elif h[0] == 90 and h[-1] == 270:
        sym = "c90-c270"
    else:
        raise ValueError(
            f"{label}: line {line_h}: horizontal angles {h[0]:g}-{h[-1]:g} are not a "
            "valid LM-63 range (0, 0-90, 0-180, 0-360 or 90-270)."
        )
    c, i = _expand(h, cand, sym)
    flux = n_lamps * lm_per_lamp if lm_per_lamp > 0 else None
    return IntensityTable(c, v, i, "cd", flux, name, label)


# -- Illumina .lop -------------------------------------------------------------


def read_lop(path) -> IntensityTable:
    """Read an Illumina azimuth-averaged profile (`Aube2018`): columns relative
    intensity and zenith angle (0 up .. 180 down) turned into γ = 180 - zenith."""
    lines, label = _read_lines(path)
    rows = []
    for k, line in enumerate(lines, start=1):
        s = line.strip()
        if not s:
            continue
        parts = s.split()
        if len(parts) != 2:
            raise ValueError(
                f"{label}: line {k}: expected 2 columns, got {len(parts)}."
            )
        try:
            rows.append((float(parts[0]), float(parts[1]), k))
        except ValueError:
            raise ValueError(f"{label}: line {k}: not a number: {s!r}.") from None
    if len(rows) < 2:
        raise ValueError(f"{label}: line {len(lines)}: fewer than two data lines.")
    arr = np.array([(a, b) for a, b, _ in rows])
    if np.any(arr[:, 0] < 0):
        bad = rows[int(np.argmax(arr[:, 0] < 0))][2]
        raise ValueError(f"{label}: line {bad}: negative intensity.")
    zen = _check_angles(arr[:, 1], label, rows[0][2], "zenith angles", 0.0, 180.0)
    gamma = 180.0 - zen[::-1]
    inten = arr[::-1, 0]
    c, i = _expand(np.array([0.0]), inten[None, :], "rotational")
    return IntensityTable(c, gamma, i, "relative", None, Path(path).stem, label)


def read_photometry(path) -> IntensityTable:
    """Dispatch on the suffix: `.ldt`, `.ies` or `.lop`."""
    suffix = Path(path).suffix.lower()
    readers = {".ldt": read_ldt, ".ies": read_ies, ".lop": read_lop}
    if suffix not in readers:
        raise ValueError(
            f"{path}: unknown photometric file type {suffix!r}; expected one of "
            f"{sorted(readers)}."
        )
    return readers[suffix](path)
