"""`simulate`: band radiance of every lamp scene of a scenario set, with
photon noise and quantisation if asked, and its export as a table."""

import dataclasses

import jax.numpy as jnp
import numpy as np

from ..datasets.lamps import library
from ..scene import BandTerms, ScenarioSet, mix_label
from ..sensor import SensorParams, quantise
from ._measure import band_measurement


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
    thesis's Table 2.3) as in `band_measurement`, draws from `seed`
    (`noise_draws`). `bits`: quantise between `limits = (L_min, L_max)` per
    band (default: the noise-free minimum and maximum of this set, stated in
    `config`) and dequantise.
    """
    params = SensorParams() if params is None else params
    m = band_measurement(scen, bands, sensor=params, noise=noise, key=seed, crop=crop)
    radiance = m.radiance
    config = {
        "noise": noise,
        "seed": seed,
        "bits": bits,
        "crop": crop,
        "grid_nm": list(m.grid_nm),
    }
    if noise:
        config["noise_draws"] = "bandopt.forward.noise_draws(seed, scenes, bands)"
        config["sensor"] = {
            fld.name: np.asarray(getattr(params, fld.name)).tolist()
            for fld in dataclasses.fields(params)
        }
    if bits is not None:
        if limits is None:
            clean = m.clean
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
        None if m.electrons is None else np.asarray(m.electrons),
        m.terms,
        names,
        config,
    )


def lamp_levels(scen: ScenarioSet) -> tuple[list, list]:
    """Level-1 and level-2 label of every lamp of `scen`: a library lamp's
    classes; a mixed lamp (`build_scenarios` entry ``(a, b, f)``, id
    ``"a+b@f"``) gets its components' shared class, or ``"class_a+class_b@f"``
    (`scene.mix_label`) when they differ. Raises `ValueError` naming a lamp
    that is neither (a lamp given by `ScenarioSet.with_lamps`: its classes are
    the caller's)."""
    rec = {r.id: r for r in library().records}
    mixes = {
        mix_label(a, b, float(f)): (a, b, float(f))
        for a, b, f in scen.config.get("lamp_mixtures", ())
    }
    level1, level2 = [], []
    for lamp_id in scen.lamp_ids:
        if lamp_id in rec:
            level1.append(rec[lamp_id].level1)
            level2.append(rec[lamp_id].level2)
        elif lamp_id in mixes and all(x in rec for x in mixes[lamp_id][:2]):
            a, b, f = mixes[lamp_id]
            for out, level in ((level1, "level1"), (level2, "level2")):
                la, lb = getattr(rec[a], level), getattr(rec[b], level)
                out.append(la if la == lb else mix_label(str(la), str(lb), f))
        else:
            raise ValueError(
                f"Lamp {lamp_id!r} is neither a library lamp nor a mix of two: its "
                "classes are unknown (give them to scenario_table)."
            )
    return level1, level2


def to_frame(scen: ScenarioSet, sim: Simulation):
    """A pandas DataFrame: one row per lamp scene, label columns (lamp id,
    level1, level2 as in `lamp_levels`, surface, atmosphere, moon, class,
    illuminance) and one radiance column per band [W m⁻² sr⁻¹ nm⁻¹]."""
    import pandas as pd  # pandas only for this export (start-up time)

    level1, level2 = lamp_levels(scen)
    shape = sim.radiance.shape[:-1]
    idx = np.indices(shape).reshape(len(shape), -1)
    frame = {
        "lamp": np.asarray(scen.lamp_ids, dtype=object)[idx[0]],
        "level1": np.asarray(level1, dtype=object)[idx[0]],
        "level2": np.asarray(level2, dtype=object)[idx[0]],
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
