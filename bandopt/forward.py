"""Scenario set + band set -> band radiances (optionally with photon noise and
quantisation), and their table with every scenario label.

This is the glue between `bandopt.scene` (factor arrays, contraction) and
`bandopt.sensor` (responses, photon model, quantisation). The wavelength grid
is cropped statically to the union of the bands' supports (response >= `tail`
of each band's peak) before contracting.
"""

import dataclasses

import jax
import jax.numpy as jnp
import numpy as np

from .scene import BandTerms, ScenarioSet, band_terms, band_weights, lamp_scenes
from .sensor import (
    SensorParams,
    add_photon_noise,
    crop_to_support,
    photon_weights,
    quantise,
)


DEFAULT_TAIL = 1e-6
"""Responses below this fraction of a band's peak are cropped away (changes
band averages by about this much, relative)."""


@dataclasses.dataclass(frozen=True)
class Simulation:
    """Band radiances of a scenario set.

    - `radiance`: (lamp, surface, atmosphere, moon, class, band)
      [W m⁻² sr⁻¹ nm⁻¹], noisy and/or quantised (then dequantised) if asked.
    - `electrons`: signal electrons (same shape) when `noise=True`, else None.
    - `terms`: the noise-free `BandTerms` (for moon-only and fire scenes).
    - `band_names`, `config`.
    """

    radiance: np.ndarray
    electrons: np.ndarray | None
    terms: BandTerms
    band_names: tuple[str, ...]
    config: dict


def cropped(scen: ScenarioSet, bands, *, tail: float = DEFAULT_TAIL):
    """(factors, response) on the grid cropped to the bands' support."""
    w = scen.factors.wavelength_nm
    resp = bands.response(w)
    sl = crop_to_support(w, resp, tail=tail)
    f = scen.factors.crop(float(w[sl.start]), float(w[sl.stop - 1]))
    return f, bands.response(f.wavelength_nm)


def simulate(
    scen: ScenarioSet,
    bands,
    *,
    noise: bool = False,
    params: SensorParams | None = None,
    seed: int = 0,
    bits: int | None = None,
    limits: tuple[np.ndarray, np.ndarray] | None = None,
    crop: bool = True,
) -> Simulation:
    """Band-averaged TOA radiance of every lamp scene of `scen` for `bands`.

    `noise`: photon model of `bandopt.sensor` with `params` (default the
    thesis's Table 2.3): signal electrons from the exact ∫ L R η λ/(hc) dλ,
    Gaussian shot/read/dark noise drawn from `seed`, back to radiance with the
    flat-field responsivity. `bits`: quantise between `limits = (L_min, L_max)`
    per band (default: the noise-free minimum and maximum of this set, stated
    in `config`) and dequantise.
    """
    params = SensorParams() if params is None else params
    if crop:
        f, resp = cropped(scen, bands)
    else:
        f, resp = scen.factors, bands.response(scen.factors.wavelength_nm)
    weights = band_weights(resp, f.wavelength_nm)
    terms = band_terms(f, weights)
    radiance = lamp_scenes(terms)
    config = {
        "noise": noise,
        "seed": seed,
        "bits": bits,
        "crop": crop,
        "grid_nm": [float(f.wavelength_nm[0]), float(f.wavelength_nm[-1])],
    }
    electrons = None
    if noise:
        pw = photon_weights(resp, f.wavelength_nm, params, None)
        electrons = lamp_scenes(band_terms(f, pw))
        resp_e = jnp.sum(pw, axis=-1)
        noisy = add_photon_noise(jax.random.PRNGKey(seed), electrons, params)
        radiance = noisy / resp_e.reshape((1,) * (noisy.ndim - 1) + (-1,))
        config["sensor"] = {
            fld.name: np.asarray(getattr(params, fld.name)).tolist()
            for fld in dataclasses.fields(params)
        }
    if bits is not None:
        if limits is None:
            clean = lamp_scenes(terms)
            lo = jnp.min(clean, axis=tuple(range(clean.ndim - 1)))
            hi = jnp.max(clean, axis=tuple(range(clean.ndim - 1)))
            config["limits_rule"] = (
                "noise-free min and max of this scenario set per band"
            )
        else:
            lo, hi = (jnp.asarray(x) for x in limits)
        lead = (1,) * (radiance.ndim - 1)
        lo, hi = lo.reshape((*lead, -1)), hi.reshape((*lead, -1))
        dn = quantise(radiance, lo, hi, bits)
        radiance = lo + dn * (hi - lo) / (2**bits - 1)
        config["limits"] = [
            np.asarray(lo).ravel().tolist(),
            np.asarray(hi).ravel().tolist(),
        ]
    names = tuple(getattr(bands, "names", ())) or tuple(
        f"B{i + 1}" for i in range(radiance.shape[-1])
    )
    return Simulation(
        np.asarray(radiance),
        None if electrons is None else np.asarray(electrons),
        terms,
        names,
        config,
    )


def to_frame(scen: ScenarioSet, sim: Simulation):
    """A pandas DataFrame: one row per lamp scene, label columns (lamp id,
    level1, level2, surface, atmosphere, moon, class, illuminance) and one
    radiance column per band [W m⁻² sr⁻¹ nm⁻¹]."""
    import pandas as pd

    from .datasets.lamps import library

    lib = library()
    rec = {r.id: r for r in lib.records}
    shape = sim.radiance.shape[:-1]
    idx = np.indices(shape).reshape(len(shape), -1)
    frame = {
        "lamp": np.asarray(scen.lamp_ids, dtype=object)[idx[0]],
        "level1": np.asarray([rec[i].level1 for i in scen.lamp_ids], dtype=object)[
            idx[0]
        ],
        "level2": np.asarray([rec[i].level2 for i in scen.lamp_ids], dtype=object)[
            idx[0]
        ],
        "surface": np.asarray(scen.surface_labels, dtype=object)[idx[1]],
        "atmosphere": np.asarray(scen.atmosphere_labels, dtype=object)[idx[2]],
        "moon": np.asarray(scen.moon_labels, dtype=object)[idx[3]],
        "lighting_class": np.asarray(scen.class_labels, dtype=object)[idx[4]],
        "illuminance_lx": np.asarray(scen.factors.illuminance_lx)[idx[4]],
    }
    flat = sim.radiance.reshape(-1, sim.radiance.shape[-1])
    for j, name in enumerate(sim.band_names):
        frame[f"L_{name}"] = flat[:, j]
    return pd.DataFrame(frame)
