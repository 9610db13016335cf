"""The measurement: spectra or a scenario set + a band set -> band radiance
(optionally with photon noise and quantisation), and the scenario table with
every label.

Every part of bandopt (search, classify, radiometry, `simulate`, the
inversion) measures band radiance through this module, so the same inputs and
the same `key` give the same numbers everywhere:

- `band_values`: the one contraction, spectra `(*batch, w)` x band weights
  `(b, w)` -> `(*batch, b)`, for callers that hold the weights
  (`band_weights_on`) or weight the spectra themselves;
- `radiance_from_response`: the pure-JAX core, spectra `(n, w)` x responses
  `(b, w)` -> `(n, b)`, differentiable in the responses (searches jit it);
- `measure`: a `ScenarioTable`'s rows -> `BandMeasurement` (radiance, noise
  draws, and each row's lamp, type and scene);
- `band_measurement` / `band_radiance`: the same for a `ScenarioSet`
  (factorised contraction, grid cropped to the bands' support), a
  `ScenarioTable` or dense spectra, and any band set;
- `noise_draws`: the one rule for photon-noise draws (common random numbers);
- `ScenarioTable` / `scenario_table`: every lamp scene as a labelled row.

**Noise model** (`bandopt.sensor`, thesis Eqs. 2.16-2.19, Table 2.3): signal
electrons from the exact photon integral `e = L @ photon_weightsᵀ`, Gaussian
shot/dark/read noise `e + σ(e) z`, back to radiance with the flat-field
responsivity `Σ_w photon_weights`. A band with zero responsivity on the grid
(no response, or response where the QE is zero) reads 0, not NaN.

**Draws** (`noise_draws`): `z[:, j] = normal(fold_in(key, j), (n,))`, one
standard normal per scene row and band, with `key = jax.random.PRNGKey(seed)`
for an integer seed. Rows are the scenes in C order over (lamp, surface,
atmosphere, Moon, class), so a scene gets the same draw whichever caller
measures it, and band j's draws do not depend on how many bands there are.

The grid of a scenario set is cropped statically to the union of the bands'
supports (response >= `tail` of each band's peak) before contracting.
"""

from ._core import band_values, noise_draws, prng_key, radiance_from_response
from ._measure import (
    DEFAULT_TAIL,
    BandMeasurement,
    band_measurement,
    band_radiance,
    band_weights_on,
    cropped,
    measure,
)
from ._simulate import Simulation, lamp_levels, simulate, to_frame
from ._table import (
    CONDITIONS,
    LEVELS,
    ScenarioTable,
    dense_spectra,
    resolve_level,
    scenario_table,
)


__all__ = [
    "CONDITIONS",
    "DEFAULT_TAIL",
    "LEVELS",
    "BandMeasurement",
    "ScenarioTable",
    "Simulation",
    "band_measurement",
    "band_radiance",
    "band_values",
    "band_weights_on",
    "cropped",
    "dense_spectra",
    "lamp_levels",
    "measure",
    "noise_draws",
    "prng_key",
    "radiance_from_response",
    "resolve_level",
    "scenario_table",
    "simulate",
    "to_frame",
]
