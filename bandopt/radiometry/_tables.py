"""The radiometry analysis's tables for one band set: SNR and NER per band at
the limits and at lamp-scene levels (`snr_rows`), the quantisers of the
bit-depth table (`quantisers_for`), each quantiser's step against the photon
noise (`quantisation_noise_rows`) and the bit-depth rule (`recommend_bits`).
Apart from `compute`, which runs the analysis, so the rows and the rule can
be read and tested on their own."""

import numpy as np

from ..sensor import SensorParams
from ._distributions import RadianceGroups
from ._limits import Limits, snr_ner
from ._quantisers import LinearQuantiser, SqrtQuantiser, TwoGainQuantiser


THESIS_MIN_BITS = 12
"""Thesis Table 4.7 conclusion: 12 bits or more (`DeMeester2019`, abstract). [bit]"""


def snr_rows(
    groups: RadianceGroups, limits: Limits, params: SensorParams, *, band_set: str
) -> list[dict]:
    """SNR and NER per band at the background, the scene requirement, the
    detection limit, lamp-scene percentiles, the median moonlit surface and
    saturation."""
    lamp = groups.flat("lamp")
    levels = {
        "background": limits.background,
        "scene_requirement": limits.scene_requirement,
        "detection_limit": limits.detection_limit,
        "lamp_p5": np.percentile(lamp, 5, axis=0),
        "lamp_median": np.median(lamp, axis=0),
        "lamp_p95": np.percentile(lamp, 95, axis=0),
        "saturation": limits.saturation,
    }
    if groups.moon is not None:
        levels["moonlit_median"] = np.median(groups.flat("moon"), axis=0)
    rows = []
    for level, L in levels.items():
        res = {
            k: np.asarray(v)
            for k, v in snr_ner(L, limits.responsivity_e, params).items()
        }
        for j, b in enumerate(limits.band_names):
            rows.append(
                {
                    "band_set": band_set,
                    "level": level,
                    "band": b,
                    "radiance_w_m2_sr_nm": float(L[j]),
                    "signal_e": float(res["signal_e"][j]),
                    "noise_e": float(res["noise_e"][j]),
                    "snr": float(res["snr"][j]),
                    "ner_w_m2_sr_nm": float(res["ner_w_m2_sr_nm"][j]),
                }
            )
    return rows


def quantisers_for(
    limits: Limits, params: SensorParams, bit_depths, companding_bits
) -> dict:
    """label -> (scheme, bits, quantiser) for the bit-depth table."""
    lo, hi, r = limits.detection_limit, limits.saturation, limits.responsivity_e
    qs: dict = {
        "noise-free": ("none-clean", None, None),
        "noise, no quantisation": ("none", None, None),
        "noise, clipped to limits, no quantisation": (
            "clip",
            None,
            LinearQuantiser(lo, hi, 16),  # carries the limits only
        ),
    }
    for n in bit_depths:
        qs[f"linear {n} bit"] = ("linear", n, LinearQuantiser(lo, hi, n))
    for n in companding_bits:
        qs[f"two-gain {n} bit"] = (
            "two-gain",
            n,
            TwoGainQuantiser.geometric_knee(lo, hi, n),
        )
        qs[f"sqrt {n} bit"] = (
            "sqrt",
            n,
            SqrtQuantiser.for_sensor(lo, hi, r, params, n),
        )
    return qs


def quantisation_noise_rows(
    groups: RadianceGroups,
    limits: Limits,
    params: SensorParams,
    quantisers: dict,
    *,
    band_set: str,
) -> list[dict]:
    """Per quantiser and band: radiance step over photon-model noise and the
    SNR with quantisation noise (`step²/12` added) at the detection limit,
    the median lamp scene and saturation."""
    levels = {
        "detection_limit": limits.detection_limit,
        "lamp_median": np.median(groups.flat("lamp"), axis=0),
        "saturation": limits.saturation,
    }
    rows = []
    for label, (scheme, bits, q) in quantisers.items():
        if q is None or scheme == "clip":
            continue
        for level, L in levels.items():
            step = np.asarray(q.step(L))
            base = {
                k: np.asarray(v)
                for k, v in snr_ner(L, limits.responsivity_e, params).items()
            }
            withq = np.asarray(
                snr_ner(
                    L,
                    limits.responsivity_e,
                    params,
                    electrons_per_dn=step * limits.responsivity_e,
                )["snr"]
            )
            for j, b in enumerate(limits.band_names):
                rows.append(
                    {
                        "band_set": band_set,
                        "quantiser": label,
                        "scheme": scheme,
                        "bits": bits,
                        "level": level,
                        "band": b,
                        "radiance_w_m2_sr_nm": float(L[j]),
                        "step_w_m2_sr_nm": float(step[j]),
                        "step_over_noise": float(step[j] / base["ner_w_m2_sr_nm"][j]),
                        "snr_photon": float(base["snr"][j]),
                        "snr_with_quantisation": float(withq[j]),
                    }
                )
    return rows


def recommend_bits(
    rows: list[dict], *, rel_tol: float = 0.05, f1_tol: float = 0.01
) -> dict:
    """Smallest linear bit depth whose LER, G and CCT test MAE are within
    `rel_tol` (relative) of the unquantised reference (photon noise clipped to
    the limits, row scheme "clip"; else photon noise alone, "none") and whose
    macro F1 is at most `f1_tol` below it, for it and every larger depth. The
    same rule per companding scheme (two gain stages, square root); the
    companded recommendation is the scheme needing the fewest bits."""
    refs = {r["scheme"]: r for r in rows if r["scheme"] in ("clip", "none")}
    ref = refs.get("clip", refs.get("none"))

    def passes(r) -> bool:
        ok = all(
            r[f"{m}_mae"] <= ref[f"{m}_mae"] * (1 + rel_tol)
            for m in ("LER", "G", "CCT")
        )
        return ok and r["macro_f1"] >= ref["macro_f1"] - f1_tol

    def smallest(scheme) -> tuple[int | None, list[int]]:
        """The smallest depth from which every larger tested depth passes."""
        tested = sorted(
            (r for r in rows if r["scheme"] == scheme), key=lambda r: r["bits"]
        )
        ok = [r["bits"] for r in tested if passes(r)]
        bits = [r["bits"] for r in tested]
        return next((n for n in bits if all(m in ok for m in bits if m >= n)), None), ok

    rec, ok_bits = smallest("linear")
    schemes = sorted(
        {r["scheme"] for r in rows} - {"linear", "clip", "none", "none-clean"}
    )
    companded = {s: smallest(s)[0] for s in schemes}
    found = {k: v for k, v in companded.items() if v is not None}
    best = min(found, key=lambda k: (found[k], k)) if found else None
    return {
        "recommended_linear_bits": rec,
        "recommended_companded_bits": None if best is None else found[best],
        "recommended_companding": best,
        "companded_bits_per_scheme": companded,
        "rule": (
            "smallest linear bit depth from which LER, G and CCT class-balanced "
            f"test MAE stay within {100 * rel_tol:g} % of the unquantised "
            f"reference ({ref.get('label', ref['scheme'])}) and level-2 macro F1 "
            f"within {f1_tol:g} of it"
        ),
        "passing": ok_bits,
        "agrees_with_thesis_ge_12_bits": None
        if rec is None
        else bool(rec >= THESIS_MIN_BITS),
    }
