"""The judge's instrument check: every judged band set through the radiometry
of `make radiometry` (its scene distribution, photon model and limit rule,
`bandopt.radiometry`), so the choice among the search's candidates can be
made under the instrument.

Per band set: the limiting band (lowest SNR at its detection limit), that
SNR, the exposure factor it needs to reach the SNR target, and whether every
band meets the target. The choice under the instrument applies the judge's
own rule (`judge.choose`) to the candidates that meet the target; when none
does, it says so and names the candidate needing the least exposure and what
the judged choice needs, so the instrument change (`results/radiometry`
instrument_changes) is read against the estimate it buys.
"""

from collections.abc import Callable, Sequence

import numpy as np

from ..forward import cropped
from ..radiometry import (
    LimitRule,
    RadiometryConfig,
    distribution_set,
    radiance_groups,
    recommend_limits,
)
from ..sensor import SensorParams
from ..sensor.reference import load_band_set


def instrument_check(
    band_sets: Sequence[tuple[str, str]],
    *,
    config: RadiometryConfig | None = None,
    params: SensorParams | None = None,
    rule: LimitRule | None = None,
    log: Callable[[str], None] = lambda msg: None,
) -> dict:
    """Each (label, band-set source) of `band_sets` under the radiometry's
    scene distribution (`config`, default `make radiometry`'s), photon model
    (`params`, the thesis Table 2.3 sensor) and limit rule (`rule`): the
    limiting band, its SNR at the detection limit, the exposure factor for
    the SNR target and whether every band meets it; and the target."""
    config = RadiometryConfig() if config is None else config
    params = SensorParams() if params is None else params
    rule = LimitRule() if rule is None else rule
    scen, _ = distribution_set(config)
    out = {}
    for label, src in band_sets:
        bands = load_band_set(src)
        f, resp = cropped(scen, bands)
        limits = recommend_limits(
            radiance_groups(scen, bands), resp, f.wavelength_nm, params, rule
        )
        rows = limits.rows(band_set=label)
        worst = min(rows, key=lambda r: r["snr_at_limit"])
        out[label] = {
            "limiting_band": worst["band"],
            "snr_at_limit": worst["snr_at_limit"],
            "exposure_factor": float(
                np.max([r["exposure_factor_for_snr_target"] for r in rows])
            ),
            "meets_snr_target": all(r["meets_snr_target"] for r in rows),
        }
        log(f"{label}: SNR {worst['snr_at_limit']:.2f} at the limit ({worst['band']})")
    return {
        "snr_target": float(rule.snr_target),
        "band_sets": out,
        "note": "radiometry of make radiometry (its scene distribution, the "
        "thesis Table 2.3 photon model, its limit rule): per band set the "
        "band with the lowest SNR at its detection limit, and the factor "
        "integration time, TDI stages or aperture area must grow by for "
        "every band to reach the target",
    }


def choose_under_instrument(
    instrument: dict,
    candidates: Sequence[str],
    choose: Callable[[Sequence[str]], str],
    chosen: str,
) -> dict:
    """The judged choice among the `candidates` that meet the SNR target
    (`choose(meeting)` returns it: the judge's rule on those), or, when none
    does, None with the candidate that needs the least exposure and the
    exposure the judged choice `chosen` needs."""
    sets = instrument["band_sets"]
    meeting = [c for c in candidates if sets[c]["meets_snr_target"]]
    if meeting:
        pick = choose(meeting)
        return {
            "meeting_target": meeting,
            "chosen": pick,
            "same_as_judged": pick == chosen,
        }
    least = min(candidates, key=lambda c: sets[c]["exposure_factor"])
    return {
        "meeting_target": [],
        "chosen": None,
        "least_exposure": least,
        "least_exposure_factor": sets[least]["exposure_factor"],
        "judged_exposure_factor": sets[chosen]["exposure_factor"],
        "note": "no candidate reaches the SNR target at its detection limit "
        "with the instrument assumed: the judged choice stands on the "
        "estimate, and the instrument must change by its exposure factor "
        "(or the candidate needing the least exposure is taken)",
    }
