"""The lamp library: real measured spectra with a two-level typology.

Sources (keys in `references.bib`):

- colour-science's NIST CQS sets (`Ohno2008a` traditional and Philips,
  `Ohno2008b` LED), 380-780 nm at 5 nm;
- the CIE 015:2018 illuminants FL1-FL12, FL3.1-FL3.15, HP1-HP5, LED-B1..B5,
  LED-BH1, LED-RGB1, LED-V1/V2 (`CIE2018`), labelled as CIE *typical* spectra,
  380-780 nm at 5 nm;
- 13 LI-1800 measurements (`Aphalo2023`), 300-900 nm, photon units converted
  to energy;
- the LSPDD (`LSPDD2016`): about 200 lamps measured 273-899.5 nm (LED incl.
  outdoor road, wall-pack and step luminaires, CFL, halogen, incandescent,
  metal halide), vendored verbatim (CC BY-NC-ND 2.5 CA) and parsed in memory;
  switchable: `library(lspdd=False)` or the environment variable
  `BANDOPT_LSPDD=0` builds the library without it (`LSPDD_ENV`);
- the photobiology R data (`Aphalo2025lamps`, `Aphalo2025leds`, GPL >= 2):
  CFLs, linear fluorescents, household LED bulbs and tubes, white LED packages,
  incandescent/halogen and amber LED emitters, ~251-899 nm, converted by
  `_lamps_build` (the 13 LI-1800 lamps it also holds are not taken twice);
- the color-pollution outdoor set (`Robinson2016`, MIT): LPS, HPS, metal
  halide, mercury, field LEDs, a measured PC-amber LED, 380-930 nm. The
  provenance of most of its files is not documented (`provenance_documented`
  False); their line positions are checked in `tests/test_lamps.py`;
- modelled spectra from Planck's law (`Planck1901`): incandescent 2400-3200 K
  and fire 700-1200 K, labelled `modelled` and not counted as lamps.

Reserved for independent validation, never loaded here: the IES TM-30 sample
spectra (luxpy) and the LSPDD records absent from the vendored set.

**Grid and units.** Every spectrum is linearly interpolated onto the library
grid (default `GRID_1NM`, 380-900 nm at 1 nm) and normalised to one lumen:
`683 ∫_380^780 V S dλ = 1`, so `values` are spectral radiant flux per lumen
[W nm⁻¹ lm⁻¹]; multiplied by an illuminance [lx] they give spectral irradiance
[W m⁻² nm⁻¹]. Beyond a spectrum's measured range the values are the
near-infrared extension of `bandopt.datasets.nir` (flag `extended`), or NaN
when the extension is switched off (`library(extend_nir=False)`). A spectrum
measured to within `EDGE_HOLD_NM` of the grid end (LSPDD to 899.5 nm,
photobiology to ~899 nm) is measured, not extended: its last sample is held
over the remaining < `EDGE_HOLD_NM` (flag `nir_measured`).

**What is kept as measured** (`usable_range`, flag `cut_reason`): trailing
zeros (or samples below `TRUNCATION_LEVEL` of the peak) end a measurement
(`measured_end`); near-infrared that
`nir_quality` rejects as evidence (clipped, rising edge) is not simulated but
replaced by the technology's extension from 780 nm; a rising background that
reaches into the visible (`contamination_start`) is fitted where it dominates
and subtracted (a lamp contaminated below `CUT_MIN_NM` is excluded from
scoring); the 765-780 nm plateau artefact of a
mercury spectrum (`plateau_start`) is cut. `measured_range_nm` is the kept
part, `source_range_nm` the source's own range when they differ. The mercury
extension is an upper bound (`nir.UPPER_BOUND`), said in its note.

**Typology** (fixed identifiers): level 1 `LEVEL1`, level 2 `LEVEL2`. White
phosphor LEDs are `led_warm` for CCT <= 3500 K and `led_cool` above. A
level-2 class with fewer than `MIN_LAMPS_FOR_SCORING` distinct measured lamps is
"insufficient for scoring". Research RGB mixes are `led_rgb` (their own class,
never scored); coloured fluorescent tubes (|Duv| > 0.02) have no level-2 class
and are excluded from scoring, as are fluorescent tubes whose CCT lies
outside 1000-25000 K (the red TL-D /15). An LED whose chromaticity has an
excitation purity >= `AMBER_MIN_PURITY` (against illuminant E) and a dominant
wavelength in `AMBER_DOMINANT_NM` (amber and yellow-filtered light for dark-sky
areas) is `led_amber`, subtype `direct_amber` (AlInGaP emitters: spectral
width at half maximum < `DIRECT_AMBER_MAX_WIDTH_NM`), `pc_amber` (broad, and a
blue pump leaks: >= `PC_AMBER_MIN_BLUE` of its visible power below 500 nm) or
`broad_amber` (broad without blue: a phosphor or a filtered white luminaire,
the spectrum cannot tell); the source's own label wins where it has one. Any
other LED off the white region
(|Duv| > 0.02 or CCT outside 1000-25000 K) is a coloured LED: no level-2
class, never scored. HPS lamps with CCT >= `WHITE_SON_MIN_CCT_K` are subtype
`white_son` (high-CRI HPS): their NIR extension is never flagged validated (no
measured White SON reaches 900 nm here).

**Deduplication rule** (`DUPLICATE_RMS`): two spectra, each normalised to unit
visible power and compared on 380-780 nm at 5 nm, are the same lamp when the
RMS of their difference is below 3 % of their mean value; the copy from the
source listed first in `SOURCE_PRIORITY` is kept (within a source, a copy with
documented provenance first). The rule runs across all sources, including
colour-science's CIE and NIST sets.
"""

import dataclasses
import functools
from collections.abc import Sequence

import numpy as np

from ..photometry import K_M_LM_PER_W
from ..spectra import GRID_1NM, planck_radiance
from . import nir

# The measured spectra, their typology and deduplication, and the lamps measured
# to 900 nm live in `_lamp_sources` (below `nir`, which calibrates on them);
# every public name is re-exported here.
from ._lamp_sources import (
    AMBER_DOMINANT_NM as AMBER_DOMINANT_NM,
    AMBER_MIN_PURITY as AMBER_MIN_PURITY,
    COLOURED_DUV as COLOURED_DUV,
    CONTAMINATION_FIT_NM as CONTAMINATION_FIT_NM,
    CONTAMINATION_MAX_FRACTION as CONTAMINATION_MAX_FRACTION,
    CUT_MIN_NM as CUT_MIN_NM,
    DATASHEET_LIKE as DATASHEET_LIKE,
    DIRECT_AMBER_MAX_WIDTH_NM as DIRECT_AMBER_MAX_WIDTH_NM,
    DUPLICATE_RMS as DUPLICATE_RMS,
    EDGE_HOLD_NM,
    LED_WARM_MAX_CCT_K as LED_WARM_MAX_CCT_K,
    LEVEL1,
    LEVEL2,
    LEVEL2_PARENT,
    LSPDD_ENV as LSPDD_ENV,
    MERCURY_PLATEAU_FROM_NM as MERCURY_PLATEAU_FROM_NM,
    MERCURY_PLATEAU_RATIO as MERCURY_PLATEAU_RATIO,
    NIR_CLIPPED_MAX as NIR_CLIPPED_MAX,
    NIR_RISING_EDGE as NIR_RISING_EDGE,
    PC_AMBER_MIN_BLUE as PC_AMBER_MIN_BLUE,
    SOURCE_PRIORITY as SOURCE_PRIORITY,
    TRUNCATION_LEVEL as TRUNCATION_LEVEL,
    TRUNCATION_MIN_NM as TRUNCATION_MIN_NM,
    WHITE_SON_MIN_CCT_K as WHITE_SON_MIN_CCT_K,
    UsableRange as UsableRange,
    _classified,
    classes_with_measured_nir,
    color_pollution_measured as color_pollution_measured,
    contamination_start as contamination_start,
    lspdd_enabled,
    measured_end as measured_end,
    measured_nir_spectra as measured_nir_spectra,
    nir_quality as nir_quality,
    parse_lspdd_spectrum as parse_lspdd_spectrum,
    plateau_start as plateau_start,
    rising_component as rising_component,
    usable_range,
)


MIN_LAMPS_FOR_SCORING = 3
NEVER_SCORED = ("led_rgb",)


LICENCES = {
    "li1800": "GPL (>= 2)",
    "photobiology": "GPL (>= 2)",
    "lspdd": "CC BY-NC-ND 2.5 CA (verbatim, switchable)",
    "color_pollution": "MIT",
    "nist_philips": "NIST data via colour-science (BSD-3-Clause)",
    "nist_traditional": "NIST data via colour-science (BSD-3-Clause)",
    "nist_led": "NIST data via colour-science (BSD-3-Clause)",
    "cie015": "CIE 015:2018 data via colour-science (BSD-3-Clause)",
    "planck": "modelled",
    "ies_tm30": "GPL-3.0 (IES TM-30-15 spectra via LuxPy, verbatim)",
}


@dataclasses.dataclass(frozen=True)
class LampRecord:
    """What the library knows about one spectrum.

    - `id`: stable identifier, e.g. `nist_philips_c100s54_hps`.
    - `name`: the name in its source.
    - `level1`, `level2`: typology (`LEVEL1`, `LEVEL2`; `level2` may be None).
    - `source`: bibliography key; `source_set`: the collection.
    - `unit`: unit of the library values.
    - `measured_range_nm`: the part of the source spectrum kept as measured
      (`usable_range`); beyond it the values are extended. [nm]
    - `extended`: values beyond the measured range come from `bandopt.datasets.nir`.
    - `extension_validated`: the extension's technology was checked against a
      measurement (None when not extended).
    - `modelled`: from Planck's law, not a measurement (never counted as a lamp).
    - `cie_typical`: a CIE 015 typical spectrum, not a specific product.
    - `excluded`: reason the lamp is kept out of scored classes (or None).
    - `duplicates`: ids of near-duplicates removed in its favour.
    - `licence`: licence of the source data.
    - `provenance_documented`: the source documents instrument and lamp (False
      for most color-pollution files: line positions checked instead).
    - `subtype`: finer type where it matters (`pc_amber`, `direct_amber`,
      `white_son`) or None.
    - `nir_measured`: the spectrum itself is measured to the grid end (within
      `EDGE_HOLD_NM`), so nothing beyond 780 nm is modelled.
    - `nir_note`: where its values beyond 780 nm come from, and whether the
      extension of its technology has measured evidence.
    - `cut_reason`: why the kept part ends before the source's last sample
      (trailing zeros, near-infrared rejected as evidence, a contaminated
      red end, the mercury plateau artefact), or None.
    - `source_range_nm`: the source spectrum's own range when the library
      keeps less of it (else None). [nm]
    """

    id: str
    name: str
    level1: str
    level2: str | None
    source: str
    source_set: str
    unit: str
    measured_range_nm: tuple[float, float]
    extended: bool
    extension_validated: bool | None
    modelled: bool
    cie_typical: bool
    excluded: str | None
    duplicates: tuple[str, ...] = ()
    licence: str = ""
    provenance_documented: bool = True
    subtype: str | None = None
    nir_measured: bool = False
    nir_note: str = ""
    cut_reason: str | None = None
    source_range_nm: tuple[float, float] | None = None

    def as_dict(self) -> dict:
        d = dataclasses.asdict(self)
        d["measured_range_nm"] = list(self.measured_range_nm)
        if self.source_range_nm is not None:
            d["source_range_nm"] = list(self.source_range_nm)
        d["duplicates"] = list(self.duplicates)
        return d


@dataclasses.dataclass(frozen=True)
class LampLibrary:
    """Lamp spectra on one grid with their records (row i of `values` is `records[i]`).

    - `wavelength_nm`: the grid. [nm]
    - `values`: spectral radiant flux per lumen. [W nm⁻¹ lm⁻¹]
    - `records`: one `LampRecord` per row.
    - `insufficient`: level-2 classes with fewer than `MIN_LAMPS_FOR_SCORING`
      distinct measured lamps ("insufficient for scoring").
    - `removed`: near-duplicates removed, as (removed id, kept id).
    - `source_sets`: the collections the library was built from.
    """

    wavelength_nm: np.ndarray
    values: np.ndarray
    records: tuple[LampRecord, ...]
    insufficient: tuple[str, ...]
    removed: tuple[tuple[str, str], ...]
    source_sets: tuple[str, ...] = ()

    def __len__(self) -> int:
        return len(self.records)

    @property
    def ids(self) -> list[str]:
        return [r.id for r in self.records]

    def index(self, lamp_id: str) -> int:
        ids = self.ids
        if lamp_id not in ids:
            raise ValueError(f"Unknown lamp id {lamp_id!r}; see `bandopt library`.")
        return ids.index(lamp_id)

    def is_scored(self, record: LampRecord) -> bool:
        """Counted in a scored level-2 class: measured, not excluded, in a
        sufficient class."""
        return (
            not record.modelled
            and record.excluded is None
            and record.level2 is not None
            and record.level2 not in self.insufficient
            and record.level2 not in NEVER_SCORED
        )

    def select(
        self, *, lamps_only: bool = True, scored_only: bool = False
    ) -> "LampLibrary":
        """A sub-library: `lamps_only` drops modelled spectra; `scored_only`
        keeps only lamps in scored classes."""
        keep = [
            i
            for i, r in enumerate(self.records)
            if (not lamps_only or not r.modelled)
            and (not scored_only or self.is_scored(r))
        ]
        return dataclasses.replace(
            self,
            values=self.values[keep],
            records=tuple(self.records[i] for i in keep),
        )

    def counts(self) -> list[dict]:
        """Distinct measured lamps per level-2 class, with the scoring status."""
        rows = []
        lamps = [r for r in self.records if not r.modelled]
        for l2 in LEVEL2:
            members = [r for r in lamps if r.level2 == l2]
            n_excl = sum(r.excluded is not None for r in members)
            n = len(members) - n_excl
            if l2 in NEVER_SCORED:
                status = "own type, never scored (research mixes)"
            elif l2 in self.insufficient:
                status = "insufficient for scoring"
            else:
                status = "scored"
            rows.append(
                {
                    "level1": LEVEL2_PARENT[l2],
                    "level2": l2,
                    "lamps": n,
                    "excluded": n_excl,
                    "cie_typical": sum(r.cie_typical for r in members),
                    "nir_measured": sum(
                        r.nir_measured and r.excluded is None for r in members
                    ),
                    "status": status,
                }
            )
        for l1 in LEVEL1:
            unclassed = [r for r in lamps if r.level2 is None and r.level1 == l1]
            if not unclassed:
                continue
            kinds = sorted({r.excluded.split(" (")[0] for r in unclassed if r.excluded})
            rows.append(
                {
                    "level1": l1,
                    "level2": None,
                    "lamps": len(unclassed),
                    "cie_typical": sum(r.cie_typical for r in unclassed),
                    "nir_measured": sum(r.nir_measured for r in unclassed),
                    "status": "excluded: " + "; ".join(kinds),
                }
            )
        return rows


def planck_spectrum(wavelength_nm: np.ndarray, temperature_k: float) -> np.ndarray:
    """Planck's law: `bandopt.spectra.planck_radiance`. [W m⁻² sr⁻¹ nm⁻¹]"""
    return planck_radiance(np.asarray(wavelength_nm, float), temperature_k)


MODELLED_INCANDESCENT_K = (2400.0, 2600.0, 2800.0, 3000.0, 3200.0)
MODELLED_FIRE_K = (700.0, 800.0, 900.0, 1000.0, 1100.0, 1200.0)


def _per_lumen(wavelength_nm, values):
    # start-up time: colour takes ~1.5 s to import
    from colour import SDS_LEFS

    v = SDS_LEFS["CIE 1924 Photopic Standard Observer"]
    vis = (wavelength_nm >= 380.0) & (wavelength_nm <= 780.0)
    w = wavelength_nm[vis]
    # With the extension off, a spectrum cut below 780 nm is unknown (NaN) up
    # to 780 nm: that part counts 0 in its lumen (V < 3e-4 there).
    lum = K_M_LM_PER_W * np.trapezoid(np.nan_to_num(values[vis]) * v[w], w)
    return values / lum


LOW_FILL_MAX = 0.01
"""A spectrum that starts after 380 nm is filled with 0 below its first sample
only when that sample is below this fraction of its peak (PC_Amber.csv starts
at 400 nm at 0.1 % of peak); otherwise the build fails."""


def _nir_note(extended, measured, tech, validated, end_nm, cut_reason=None):
    if measured:
        return f"measured to {end_nm:g} nm"
    if not extended:
        note = "beyond the measured range: unknown (NaN), extension off"
    elif validated:
        note = (
            f"extended beyond {end_nm:g} nm ({tech}); the extension of this "
            "technology is validated leave-one-out on measured spectra"
        )
    else:
        note = (
            f"extended beyond {end_nm:g} nm ({tech}); no leave-one-out validation "
            "on measured spectra of this class (see `nir.extension_error`)"
        )
    if extended and tech in nir.UPPER_BOUND:
        note += f"; the {tech} extension is an upper bound, not a measurement"
    if cut_reason:
        note += f"; source cut: {cut_reason}"
    return note


@functools.cache
def _build(
    extend_nir: bool,
    grid_key: tuple[float, float, float],
    lspdd: bool = True,
    tm30: bool = False,
) -> LampLibrary:
    lo, hi, step = grid_key
    grid = np.arange(lo, hi + step / 2, step)
    raws, classified, kept, dup_of, removed = _classified(lspdd, tm30)
    with_nir = classes_with_measured_nir(lspdd)

    values, records = [], []
    for i in kept:
        r = raws[i]
        level1, level2, subtype, excluded = classified[i]
        use = usable_range(r.wavelength_nm, r.values, level2)
        keep = r.wavelength_nm <= use.end_nm
        w, s = r.wavelength_nm[keep], use.values[keep]
        excluded = excluded or use.excluded
        start, end = float(w[0]), float(w[-1])
        source_end = float(r.wavelength_nm[-1])
        row = np.full(grid.shape, np.nan)
        inside = (grid >= start) & (grid <= end)
        row[inside] = np.interp(grid[inside], w, s)
        below = grid < start
        if below.any():
            if s[0] > LOW_FILL_MAX * s.max():
                raise ValueError(
                    f"{r.id}: spectrum starts at {start:g} nm at "
                    f"{s[0] / s.max():.1%} of peak; cannot fill 380-{start:g} nm."
                )
            row[below] = 0.0
        beyond = grid > end
        measured_nir = bool(end >= hi - EDGE_HOLD_NM and hi > nir.EXTENSION_START_NM)
        extended, validated = False, None
        tech = nir.technology_of(level2, level1)
        if beyond.any() and measured_nir:
            row[beyond] = s[-1]  # hold the last sample over < EDGE_HOLD_NM
        elif beyond.any() and extend_nir:
            row[beyond] = nir.extend_spectrum(w, s, tech, grid[beyond], lspdd=lspdd)
            extended = True
            validated = (
                nir.is_validated(tech) and subtype != "white_son" and level2 in with_nir
            )
        note = (
            _nir_note(extended, measured_nir, tech, validated, end, use.reason)
            if beyond.any() or measured_nir
            else ""
        )
        if subtype == "white_son" and extended:
            note += "; White SON (high-CRI HPS): the HPS calibration is standard HPS"
        elif extended and level2 not in with_nir:
            note += f"; no measured near-infrared for class {level2} here"
        values.append(_per_lumen(grid, row))
        records.append(
            LampRecord(
                id=r.id,
                name=r.name,
                level1=level1,
                level2=level2,
                source=r.source,
                source_set=r.source_set,
                unit="W nm-1 lm-1",
                measured_range_nm=(start, end),
                extended=extended,
                extension_validated=validated,
                modelled=False,
                cie_typical=r.cie_typical,
                excluded=excluded,
                duplicates=tuple(dup_of.get(i, ())),
                licence=LICENCES[r.source_set],
                provenance_documented=r.provenance_documented,
                subtype=subtype,
                nir_measured=measured_nir,
                nir_note=note,
                cut_reason=use.reason,
                source_range_nm=(start, source_end) if end < source_end else None,
            )
        )

    modelled = [
        (
            f"planck_incandescent_{int(t)}k",
            f"Planck {int(t)} K",
            "incandescent",
            "incandescent_halogen",
            t,
        )
        for t in MODELLED_INCANDESCENT_K
    ] + [
        (f"planck_fire_{int(t)}k", f"Fire (blackbody) {int(t)} K", "fire", None, t)
        for t in MODELLED_FIRE_K
    ]
    for lamp_id, name, level1, level2, t in modelled:
        values.append(_per_lumen(grid, planck_spectrum(grid, t)))
        records.append(
            LampRecord(
                id=lamp_id,
                name=name,
                level1=level1,
                level2=level2,
                source="Planck1901",
                source_set="planck",
                unit="W nm-1 lm-1",
                measured_range_nm=(float(grid[0]), float(grid[-1])),
                extended=False,
                extension_validated=None,
                modelled=True,
                cie_typical=False,
                excluded=None,
                licence=LICENCES["planck"],
                nir_note="modelled (Planck's law)",
            )
        )

    # Classes with too few distinct measured lamps.
    measured = [rec for rec in records if not rec.modelled and rec.excluded is None]
    insufficient = tuple(
        l2
        for l2 in LEVEL2
        if sum(rec.level2 == l2 for rec in measured) < MIN_LAMPS_FOR_SCORING
    )
    values_arr = np.asarray(values)
    values_arr.setflags(write=False)
    sets = tuple(dict.fromkeys(r.source_set for r in raws))
    return LampLibrary(
        grid, values_arr, tuple(records), insufficient, tuple(removed), sets
    )


def library(
    *,
    extend_nir: bool = True,
    wavelength_nm: Sequence[float] | np.ndarray = GRID_1NM,
    lspdd: bool | None = None,
    tm30: bool = False,
) -> LampLibrary:
    """The lamp library on a uniform grid (default 380-900 nm at 1 nm).

    `extend_nir=False` leaves values beyond each spectrum's measured range NaN
    (unknown), so a band reaching there fails loudly rather than reading zeros.
    `lspdd=False` (or the environment variable `BANDOPT_LSPDD=0` when `lspdd`
    is None) builds it without the LSPDD set (CC BY-NC-ND). `tm30=True` adds
    the measured lamps of the IES TM-30-15 set (`IES2015`, source set
    `ies_tm30`, 380-780 nm, NIR extended) that are not duplicates of the
    others; off by default, so the scored library and every committed result
    are without them (`bandopt.inversion.tm30_lamps` gives them as prior
    lamps that train and never score). Built once per argument set and cached
    in memory.
    """
    w = np.asarray(wavelength_nm, float)
    step = np.diff(w)
    if w.ndim != 1 or w.size < 2 or not np.allclose(step, step[0]):
        raise ValueError("wavelength_nm must be a uniform 1-D grid.")
    if w[0] < 380.0 or w[-1] > nir.EXTENSION_END_NM:
        raise ValueError(
            f"wavelength_nm must lie in 380-900 nm (got {w[0]:g}-{w[-1]:g}): no lamp "
            "data exist outside it."
        )
    return _build(
        bool(extend_nir),
        (float(w[0]), float(w[-1]), float(step[0])),
        lspdd_enabled(lspdd),
        bool(tm30),
    )
