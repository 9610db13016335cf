"""Which instrument change buys the SNR target at the detection limit.

`Limits.exposure_factor` says how many times more signal electrons a band
needs at its detection limit to reach the SNR target with `SensorParams`
(σ0 held fixed). Signal electrons grow with the detector area, the projected
solid angle `π / (4 (f/#)² + 1)`, the transmittance, the quantum efficiency,
the time per TDI stage and the number of stages (thesis Eq. 2.18). This
module turns the largest factor over the bands (the band that limits the
instrument) into the change of one knob at a time that reaches it:

- `tdi_stages`: stages x F (charge-domain TDI: read noise counted once);
- `f_number`: the f/# whose solid angle is F times larger; none faster than
  f/0.5 exists (numerical aperture 1 in air, `F_NUMBER_LIMIT`);
- `pixel_pitch_m`: at fixed focal length the ground sample distance grows
  with the pitch and so does the time per stage (`t = GSD / v`), so the
  signal grows with pitch³: pitch and GSD x F^(1/3);
- `binning`: b x b pixels summed (on chip, σ0 once), signal x b², GSD x b.

Each is exact for the photon model with σ0 = 0 (the thesis's shot-noise
sensor): applying it reaches the target at every band's limit, and 1 %
less does not (tested). With read noise or dark current the factors hold σ0
fixed, as `exposure_factor` does. Which knob a mission turns is a design
decision; the numbers say what each costs.
"""

import dataclasses
import math

import numpy as np

from ..sensor import SensorParams, ground_track_speed_m_s


F_NUMBER_LIMIT = 0.5
"""The fastest f-number in air: f/# = 1 / (2 NA) with numerical aperture
NA <= 1 (the Abbe sine condition). [1]"""

ALTITUDE_M = 600e3
"""Orbit altitude for the ground speed that turns integration time into a
ground sample distance (`SensorParams.for_gsd`'s default). [m]"""


def gsd_m(params: SensorParams, altitude_m: float = ALTITUDE_M) -> float:
    """The ground sample distance the sensor's time per TDI stage implies,
    `t · v` with `v` the ground-track speed at `altitude_m`. [m]"""
    return float(params.integration_time_s) * float(ground_track_speed_m_s(altitude_m))


def f_number_for(params: SensorParams, factor: float) -> float | None:
    """The f-number whose projected solid angle is `factor` times the
    sensor's; None if it would be faster than `F_NUMBER_LIMIT`."""
    f = float(params.f_number)
    q = (4.0 * f * f + 1.0) / factor
    if q < 4.0 * F_NUMBER_LIMIT**2 + 1.0:
        return None
    return math.sqrt((q - 1.0) / 4.0)


def instrument_changes(
    params: SensorParams,
    exposure_factor,
    band_names,
    *,
    altitude_m: float = ALTITUDE_M,
) -> dict:
    """The single-knob changes that reach the SNR target at every band's
    detection limit (module docstring). `exposure_factor` per band (<= 1:
    met). JSON-ready: the limiting band and its factor, the sensor's GSD, and
    per knob the value now, the value needed and what else it changes."""
    factor = np.asarray(exposure_factor, float)
    j = int(np.argmax(factor))
    big = float(factor[j])
    gsd = gsd_m(params, altitude_m)
    out = {
        "limiting_band": str(band_names[j]),
        "exposure_factor": big,
        "met": bool(big <= 1.0),
        "gsd_m": gsd,
        "altitude_m": altitude_m,
        "changes": {},
    }
    if big <= 1.0:
        return out
    stages = params.tdi_stages
    f_new = f_number_for(params, big)
    scale = big ** (1.0 / 3.0)
    b = math.ceil(math.sqrt(big) - 1e-12)
    out["changes"] = {
        "tdi_stages": {
            "now": stages,
            "needed": math.ceil(stages * big - 1e-9),
            "also": "no other in the photon model "
            "(a TDI sensor's stages are bounded by its design)",
        },
        "f_number": {
            "now": float(params.f_number),
            "needed": f_new,
            "also": (
                f"not reachable: faster than f/{F_NUMBER_LIMIT:g} (NA = 1)"
                if f_new is None
                else "aperture diameter x f/# now / f/# needed at the same focal length"
            ),
        },
        "pixel_pitch_m": {
            "now": float(params.pixel_pitch_m),
            "needed": float(params.pixel_pitch_m) * scale,
            "also": f"GSD {gsd:.3g} m -> {gsd * scale:.3g} m",
            "gsd_m": gsd * scale,
        },
        "binning": {
            "now": 1,
            "needed": b,
            "also": f"{b} x {b} pixels summed: GSD {gsd:.3g} m -> {gsd * b:.3g} m",
            "gsd_m": gsd * b,
        },
    }
    return out


def apply_change(params: SensorParams, knob: str, value) -> tuple[SensorParams, float]:
    """The sensor with one change of `instrument_changes` applied, and the
    factor on the signal electrons not carried by `SensorParams` (binning's
    b²; 1 otherwise)."""
    if knob == "tdi_stages":
        return dataclasses.replace(params, tdi_stages=int(value)), 1.0
    if knob == "f_number":
        return dataclasses.replace(params, f_number=value), 1.0
    if knob == "pixel_pitch_m":
        k = float(value) / float(params.pixel_pitch_m)
        return (
            dataclasses.replace(
                params,
                pixel_pitch_m=value,
                integration_time_s=params.integration_time_s * k,
            ),
            1.0,
        )
    if knob == "binning":
        return params, float(value) ** 2
    raise ValueError(
        f"knob {knob!r}: one of tdi_stages, f_number, pixel_pitch_m, binning"
    )
