"""The technology scores of a spectrum's features, and its identification.

`technology_scores` multiplies soft thresholds (logistic steps of width
`SOFTNESS`) at the values named by the constants here, one product per
technology; `identify_technology` normalises the scores and names the best
technology unless the second is within `AMBIGUITY_RATIO` of it. Apart from the
feature measurement (`_features`) so that each threshold sits next to the
rule that uses it; `bandopt.datasets.technology` re-exports every public name
here.
"""

import dataclasses

import numpy as np

from ._features import (
    BLUE_NM,
    EU_RED_NM,
    HG_LINES_NM,
    HG_YELLOW_NM,
    HPS_BAND_NM,
    NA_CORE_HALF_WIDTH_NM,
    NARROW_PEAK_MAX_FWHM_NM,
    NARROW_PEAK_MIN_PROMINENCE,
    PROMINENCE_GUARD,
    TL_GREEN_NM,
    SpectralFeatures,
    spectral_features,
)


HG_MIN_PROMINENCE = 0.5
"""An Hg line is present when it stands at least half its continuum level
above it (and `NARROW_PEAK_MIN_PROMINENCE` above it in absolute terms): 90 %
of the library's fluorescent lamps show Hg 436 at >= 2 and halophosphate
tubes keep >= 0.5 at 10 nm resolution; 90 % of its LEDs read <= 0.35 at
436 nm, and an LED's pump can mimic one Hg line, never the two of three that
are required. [1]"""

YELLOW_GREEN_MERCURY = 0.35
"""Hg 578 / Hg 546 height ratio above which the lamp is a high-pressure
mercury lamp: pressure broadening and self-absorption raise the yellow
doublet to 0.6-1.2 of the green line in high-pressure mercury, while a
low-pressure (fluorescent) discharge keeps it near 0.05-0.15 of the green
line plus the Tb 545 nm phosphor line under it. [1]"""

EU_MIN_PROMINENCE = 1.0
"""Eu 611 nm line present (tri-phosphor fluorescent): prominence >= 1. [1]"""

LPS_MIN_CORE_FRACTION = 0.6
"""Low-pressure sodium: at least this fraction of the visible power within
`NA_CORE_HALF_WIDTH_NM` of 589 nm (measured LPS: 0.95-1.0; HPS <= 0.31; the
fraction stays >= 0.9 at 10 nm resolution and drops by the background's
share). [1]"""

LPS_MAX_FWHM_NM = 13.0
"""LPS's single band is narrower than this (3-8 nm measured, ~11 nm at 10 nm
resolution); a direct amber LED at 589 nm is wider (>= 14 nm). [nm]"""

HPS_MIN_BAND_FRACTION = 0.45
"""HPS: at least this fraction of the visible power in `HPS_BAND_NM` (measured
HPS 0.30-0.74, half of them above 0.57; white LEDs 0.3-0.5). The blue
fraction and the missing Hg lines carry the rest of the decision. [1]"""

HPS_MAX_BLUE_FRACTION = 0.14
"""HPS: below this fraction of the visible power in `BLUE_NM` (measured HPS
0.07-0.10; metal halide >= 0.17). [1]"""

SODIUM_MIN_LINE_FRACTION = 0.03
"""HPS: at least this fraction of its power in structure narrower than the
baseline (the self-reversal, the Na 568/616 nm lines; measured >= 0.04), which
a smooth phosphor-converted amber LED lacks. [1]"""

PLANCK_MAX_RESIDUAL = 0.12
"""Incandescent: median of the absolute log ratio of the spectrum to its best
Planck curve over
`PLANCK_RANGE_NM` below this (filaments <= 0.09, neodymium glass with its
580 nm notch included; phosphor LEDs >= 0.2 but for two built to imitate a
filament, which `INCANDESCENT_MAX_BLUE_FRACTION` separates). The median
ignores notches and absorption bands. [1]"""

INCANDESCENT_MAX_BLUE_FRACTION = 0.11
"""Incandescent: below this fraction in `BLUE_NM` (filaments at <= 3200 K:
<= 0.094; the two filament-imitating LEDs: >= 0.12). [1]"""

MAX_LINE_FRACTION_SMOOTH = 0.03
"""A continuum lamp (filament) has less than this fraction of its power above
the local baseline (measured filaments <= 0.015). [1]"""

LED_MAX_NARROW_PEAKS = 1.5
"""An LED has at most one peak narrower than `NARROW_PEAK_MAX_FWHM_NM`
(noise, a sharp phosphor edge): discharge lamps have several lines. [1]"""

MH_MIN_OTHER_LINES = 2.5
"""Metal halide: at least this many lines in `MH_LINES_RANGE_NM` at
wavelengths where no mercury or fluorescent-phosphor line lies (In 410/451,
Sc, Tl 535, Na 498/515, Li, Dy, ... lines; fluorescent lamps show none
there, metal halide lamps with a line spectrum 3-14). [1]"""

TL_MIN_PROMINENCE = 1.0
"""A Tl 535 nm line at least this prominent, in a spectrum without Hg lines,
marks a ceramic metal halide lamp (LEDs <= 0.55). [1]"""

MERCURY_MIN_LINE_FRACTION = 0.4
"""A high-pressure mercury lamp emits at least this fraction of its visible
power in lines (measured 0.62-0.77, coated lamps included); a halophosphate
fluorescent lamp, whose Hg 578 nm doublet can look strong on its broad
phosphor band, 0.1-0.2. [1]"""

NA_BLUE_MIN_PROMINENCE = 0.3
"""Na 498 nm present: prominence >= 0.3 (a weak line on the sodium lamp's low
blue continuum). [1]"""

SOFTNESS = 0.15
"""Width of every soft threshold, as a fraction of the threshold (a feature
15 % beyond its threshold scores 0.73 / 0.27 on either side). [1]"""

AMBIGUITY_RATIO = 0.5
"""The evidence is ambiguous when the second-best technology scores at least
this fraction of the best: every technology within it is a candidate. [1]"""

NA_IR_MIN_PROMINENCE = 1.0
"""Na 819 nm present (sodium lamps 1.7-11 in the library's spectra measured
to 900 nm; LEDs <= 0.5). [1]"""


@dataclasses.dataclass(frozen=True)
class TechnologyEvidence:
    """Which technology a spectrum is, and why.

    - `technology`: the best-scoring technology, or None when ambiguous.
    - `candidates`: the technologies within `AMBIGUITY_RATIO` of the best,
      best first (one when not ambiguous).
    - `scores`: technology -> score, summing to 1 [1].
    - `evidence`: human-readable findings ("Hg 436 nm line, prominence 8.1x").
    - `ambiguous`: more than one candidate.
    - `features`: the measured features.
    """

    technology: str | None
    candidates: tuple[str, ...]
    scores: dict[str, float]
    evidence: tuple[str, ...]
    ambiguous: bool
    features: SpectralFeatures

    def to_json(self) -> dict:
        """JSON-ready summary (scores rounded to 3 decimals)."""
        return {
            "technology": self.technology,
            "candidates": list(self.candidates),
            "ambiguous": self.ambiguous,
            "scores": {k: round(v, 3) for k, v in self.scores.items()},
            "evidence": list(self.evidence),
        }


def _above(value: float, threshold: float) -> float:
    """Soft step: 0.5 at `threshold`, width `SOFTNESS` x |threshold|."""
    scale = SOFTNESS * max(abs(threshold), 1e-9)
    return float(1.0 / (1.0 + np.exp(-(value - threshold) / scale)))


def _below(value: float, threshold: float) -> float:
    return 1.0 - _above(value, threshold)


def technology_scores(f: SpectralFeatures) -> dict[str, float]:
    """Unnormalised score of every technology (a product of soft thresholds,
    each named in the module constants) from the features `f`."""
    p = f.line_prominence
    h = f.line_height

    def line(name, min_prominence):  # prominent over its continuum and above noise
        return _above(p[name], min_prominence) * _above(
            h[name], NARROW_PEAK_MIN_PROMINENCE
        )

    hg_each = [line(k, HG_MIN_PROMINENCE) for k in HG_LINES_NM]
    hg = sorted(hg_each)[1]  # two of the three lines (an LED's violet pump at
    # 405 nm or its blue pump at 436 nm is at most one)
    yellow = h["Hg 578"] / max(h["Hg 546"], PROMINENCE_GUARD)
    single = _below(float(len(f.narrow_peaks)), LED_MAX_NARROW_PEAKS)
    lps = _above(f.na_core_fraction, LPS_MIN_CORE_FRACTION) * _below(
        f.main_fwhm_nm, LPS_MAX_FWHM_NM
    )
    na_blue = line("Na 498", NA_BLUE_MIN_PROMINENCE)
    if f.na_ir_prominence is not None:
        na_blue = max(na_blue, _above(f.na_ir_prominence, NA_IR_MIN_PROMINENCE))
    hps = (
        max(_above(f.hps_band_fraction, HPS_MIN_BAND_FRACTION), na_blue)
        * _below(f.blue_fraction, HPS_MAX_BLUE_FRACTION)
        * _above(f.line_fraction, SODIUM_MIN_LINE_FRACTION)
        * _below(f.na_core_fraction, LPS_MIN_CORE_FRACTION)
        * na_blue
        * (1.0 - hg)
    )
    incandescent = (
        _below(f.planck_residual, PLANCK_MAX_RESIDUAL)
        * _below(f.blue_fraction, INCANDESCENT_MAX_BLUE_FRACTION)
        * _below(f.line_fraction, MAX_LINE_FRACTION_SMOOTH)
    )
    mh_lines = _above(float(len(f.other_lines)), MH_MIN_OTHER_LINES)
    metal_halide = (
        _above(f.blue_fraction, HPS_MAX_BLUE_FRACTION)
        * (1.0 - lps)
        * max(mh_lines, line("Tl 535", TL_MIN_PROMINENCE) * (1.0 - hg))
    )
    mercury_like = _above(yellow, YELLOW_GREEN_MERCURY) * _above(
        f.line_fraction, MERCURY_MIN_LINE_FRACTION
    )
    return {
        "hps": hps,
        "lps": lps,
        "metal_halide": metal_halide,
        "mercury": hg * mercury_like * (1.0 - mh_lines),
        "fluorescent": hg * (1.0 - mercury_like) * (1.0 - mh_lines),
        "incandescent": incandescent,
        "led": (1.0 - hg)
        * single
        * (1.0 - lps)
        * (1.0 - incandescent)
        * (1.0 - hps)
        * (1.0 - metal_halide),
    }


def _evidence_text(f: SpectralFeatures) -> tuple[str, ...]:
    """Human-readable findings, strongest first."""
    out = []
    for name, c in {
        **HG_LINES_NM,
        "Hg 578": HG_YELLOW_NM,
        "Eu 611": EU_RED_NM,
        "Tl 535": TL_GREEN_NM,
    }.items():
        pr = f.line_prominence[name]
        if pr >= HG_MIN_PROMINENCE:
            out.append(f"{name.split()[0]} {c:.0f} nm line, prominence {pr:.1f}x")
    if f.na_core_fraction >= LPS_MIN_CORE_FRACTION / 2:
        out.append(
            f"{f.na_core_fraction:.0%} of visible power within "
            f"{NA_CORE_HALF_WIDTH_NM:g} nm of Na 589 nm"
        )
    out.append(
        f"{f.hps_band_fraction:.0%} of visible power in "
        f"{HPS_BAND_NM[0]:g}-{HPS_BAND_NM[1]:g} nm, {f.blue_fraction:.0%} in "
        f"{BLUE_NM[0]:g}-{BLUE_NM[1]:g} nm"
    )
    out.append(
        f"{len(f.narrow_peaks)} narrow lines (<= {NARROW_PEAK_MAX_FWHM_NM:g} nm), "
        f"{len(f.other_lines)} away from Hg/Na/phosphor lines"
    )
    out.append(f"highest band {f.main_fwhm_nm:.0f} nm wide")
    out.append(
        f"Planck fit {f.planck_temperature_k:.0f} K, median |log residual| "
        f"{f.planck_residual:.3f}"
    )
    if f.na_ir_prominence is not None:
        out.append(f"Na 819 nm line, prominence {f.na_ir_prominence:.1f}x")
    return tuple(out)


def identify_technology(wavelength_nm, values) -> TechnologyEvidence:
    """The technology (a key of `bandopt.datasets.nir.TECHNOLOGIES`) of a
    spectrum covering 380-780 nm, from `spectral_features`; ambiguous when the
    second-best score is at least `AMBIGUITY_RATIO` of the best.
    (`wavelength_nm` [nm], `values` any spectral unit.)"""
    f = spectral_features(wavelength_nm, values)
    raw = technology_scores(f)
    total = sum(raw.values())
    if not total > 0:  # nothing fits: every technology is as plausible
        raw = dict.fromkeys(raw, 1.0)
        total = float(len(raw))
    scores = {k: v / total for k, v in raw.items()}
    order = sorted(scores, key=scores.get, reverse=True)
    best = scores[order[0]]
    cands = tuple(k for k in order if scores[k] >= AMBIGUITY_RATIO * best)
    return TechnologyEvidence(
        technology=cands[0] if len(cands) == 1 else None,
        candidates=cands,
        scores=scores,
        evidence=_evidence_text(f),
        ambiguous=len(cands) > 1,
        features=f,
    )
