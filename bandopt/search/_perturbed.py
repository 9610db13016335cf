"""Measurement effects on the lamp spectra of a search's scenes: the kinds
(`KINDS`), their settings (`ScenePerturbations`, `MEASURED_SPECTRA`), the
perturbed per-lumen lamp spectra and the scenes repeated under them.

Apart from `_context` (which builds a preset's scenes and calls
`perturbed_scenes` when the preset has perturbations) because what a
perturbed spectrum is, and how the copies of a scene are laid out, is a
question of its own: wavelengths [nm], per-lumen spectra, seeded draws.
"""

import dataclasses

import numpy as np

from .. import perturb
from ..forward import dense_spectra
from ..inversion import LampSet, nir_variants


KINDS = ("clean", "nir-low", "nir-high", "background-flat", "noise", "shift")
"""Kinds of a scene's lamp spectrum: the library's (`clean`) or one
measurement effect of `ScenePerturbations` (the `scene_kind` of a row)."""


@dataclasses.dataclass(frozen=True)
class ScenePerturbations:
    """Measurement effects on each lamp's spectrum under which a context
    repeats that lamp's scenes, so a band search and its judge cannot lean on
    the library's modelled near-infrared or on clean laboratory spectra.

    Every effect acts on the lamp's per-lumen spectrum before the scene (the
    surface, atmosphere, Moon and lighting class are the clean scene's); the
    result is renormalised to one lumen, the library's convention. Each row
    keeps its lamp's index and so its labels (LER, G, CCT and types of the
    clean visible spectrum): the effects are what a spectrum holds beyond the
    lamp, not a different lamp.

    - `nir_error`: a lamp whose 780-900 nm part is modelled
      (`LampRecord.extended`) is repeated with that part at the low and at
      the high end of its class's measured extension error
      (`inversion.nir_variants`, `datasets.nir.extension_error`; kinds
      `nir-low`, `nir-high`); a lamp measured to 900 nm is repeated unchanged.
    - `background_fraction`: a flat background whose visible power is this
      share of the lamp's (`perturb.add_flat_background`), None for none. [1]
    - `noise_snr`: spectrometer noise at this SNR per nm against the mean
      visible level (`perturb.add_spectrometer_noise`, one seeded draw per
      lamp, the same in every scene of the lamp), None for none. [1]
    - `shift_nm`: a wavelength-calibration error (`perturb.shift_wavelength`),
      None for none. [nm]
    - `copies`: perturbed copies of each clean scene. None: one per kind
      (every kind under every scene). An integer `k` smaller than the number
      of kinds: `k` copies whose kinds are drawn for each lamp (a seeded
      permutation of the kinds, walked cyclically over the lamp's scenes and
      copies, so the kinds of one scene differ and each kind covers a share
      `k / kinds` of the lamp's scenes, within one scene).
    - `seed`: seed of the noise draw and of the kind permutations.
    """

    nir_error: bool = True
    background_fraction: float | None = 0.01
    noise_snr: float | None = 100.0
    shift_nm: float | None = 1.0
    copies: int | None = None
    seed: int = 0

    def __post_init__(self):
        if self.background_fraction is not None and not self.background_fraction > 0:
            raise ValueError(
                f"background_fraction {self.background_fraction!r}: need a share > 0 "
                "of the visible power, or None for no background."
            )
        if self.noise_snr is not None and not self.noise_snr > 0:
            raise ValueError(
                f"noise_snr {self.noise_snr!r}: need an SNR > 0, or None for no noise."
            )
        if self.shift_nm is not None and not (
            np.isfinite(self.shift_nm) and self.shift_nm != 0
        ):
            raise ValueError(
                f"shift_nm {self.shift_nm!r}: need a finite shift != 0 [nm], or "
                "None for no shift."
            )
        if not self.kinds:
            raise ValueError("ScenePerturbations: every effect is off; use no config.")
        if self.copies is not None and not 1 <= self.copies <= len(self.kinds):
            raise ValueError(
                f"copies {self.copies!r}: need 1..{len(self.kinds)} (the number of "
                "kinds), or None for every kind under every scene."
            )

    @property
    def kinds(self) -> tuple[str, ...]:
        """The perturbation kinds switched on, in `KINDS` order."""
        on = {
            "nir-low": self.nir_error,
            "nir-high": self.nir_error,
            "background-flat": self.background_fraction is not None,
            "noise": self.noise_snr is not None,
            "shift": self.shift_nm is not None,
        }
        return tuple(k for k in KINDS[1:] if on[k])

    @property
    def n_copies(self) -> int:
        """Perturbed copies of each clean scene."""
        return len(self.kinds) if self.copies is None else int(self.copies)

    def to_dict(self) -> dict:
        """The settings and the kinds, JSON-ready (a context's provenance)."""
        return {**dataclasses.asdict(self), "kinds": list(self.kinds)}


MEASURED_SPECTRA = ScenePerturbations(copies=2)
"""The perturbations of the `search_perturbed` preset: the modelled NIR at
its measured error bounds (the search must not rest on a model's 780-900 nm
part), a 1 % flat background (stray light and dark level, the middle of the
0.5-2 % a field or satellite spectrum holds; flat, because it lifts the NIR
where lamps are weakest), noise at SNR 100 per nm (an ordinary
spectrometer) and a 1 nm shift (a calibrated spectrometer's wavelength
error; a band edge on a line must not depend on the line's exact place).
Two perturbed copies of each clean scene, not five: the study's run time
grows with the rows, and two copies already give every lamp every kind
(the study's 8 clean scenes per lamp x 2 copies over 5 kinds: each kind
under 3 or 4 of them)."""


def perturbed_lamp_spectra(
    lamps: LampSet, wavelength_nm, config: ScenePerturbations
) -> dict[str, np.ndarray]:
    """Each kind of `config.kinds` applied to the library lamps `lamps`
    (per-lumen spectra `(l, w)` on the 1 nm grid `wavelength_nm`), by kind,
    each `(l, w)` per lumen (see `ScenePerturbations`). A lamp without a
    modelled NIR part keeps its spectrum in `nir-low` and `nir-high`."""
    grid = np.asarray(wavelength_nm, float)
    clean = np.asarray(lamps.spectra, float)
    out = {}
    if config.nir_error:
        var = nir_variants(lamps, grid)
        row = {lamp_id: k for k, lamp_id in enumerate(var.ids)}
        for tag in ("nir-low", "nir-high"):
            s = clean.copy()
            for i, lamp_id in enumerate(lamps.ids):
                k = row.get(f"{tag}:{lamp_id}")
                if k is not None:
                    s[i] = var.spectra[k]
            out[tag] = s
    rest = {
        "background-flat": lambda: perturb.add_flat_background(
            clean, grid, config.background_fraction
        ),
        "noise": lambda: perturb.add_spectrometer_noise(
            clean, grid, config.noise_snr, seed=config.seed
        ),
        "shift": lambda: perturb.shift_wavelength(clean, grid, config.shift_nm),
    }
    for kind in config.kinds:
        if kind in rest:
            s = rest[kind]()
            out[kind] = s / perturb.luminous_flux_lm(s, grid)[:, None]
    return out


def perturbed_scenes(
    scen, lamps: LampSet, config: ScenePerturbations
) -> tuple[np.ndarray, np.ndarray]:
    """TOA spectra `(l, q, w)` of the scenes of `scen` (a `ScenarioSet` of
    the lamps `lamps`) with each scene repeated under `config`, and the kind
    of each scene `(l, q)` (indices into `KINDS`). Layout of a lamp's `q`
    scenes: surface x copy x atmosphere x Moon x class (C order), copy 0 the
    clean scene and copies 1.. the perturbed ones (`ScenePerturbations`)."""
    if tuple(scen.lamp_ids) != tuple(lamps.ids):
        raise ValueError(
            "perturbed_scenes: the scenario set's lamps and `lamps` differ."
        )
    grid = np.asarray(scen.factors.wavelength_nm, float)
    spectra = {"clean": lamps.spectra, **perturbed_lamp_spectra(lamps, grid, config)}
    kinds = ("clean", *config.kinds)
    dense = np.stack(
        [
            np.asarray(dense_spectra(scen.with_lamps(lamps.ids, spectra[k])))
            for k in kinds
        ]
    )  # (kinds, l, s, a, m, c, w)
    n_k, n_l, n_s, n_a, n_m, n_c, n_w = dense.shape
    n_copy = 1 + config.n_copies
    # kind index (into `kinds`) of every (lamp, surface, copy, atm, moon, class)
    pick = np.zeros((n_l, n_s, n_copy, n_a, n_m, n_c), int)
    if config.copies is None:
        pick[:] = np.arange(n_copy)[None, None, :, None, None, None]
    else:
        per_lamp = n_s * n_a * n_m * n_c
        scene = np.arange(per_lamp).reshape(n_s, n_a, n_m, n_c)
        rng = np.random.default_rng([config.seed, 1])
        for i in range(n_l):
            order = 1 + rng.permutation(n_k - 1)
            start = rng.integers(n_k - 1)
            for c in range(config.n_copies):
                walk = (scene * config.n_copies + c + start) % (n_k - 1)
                pick[i, :, 1 + c] = order[walk]
    idx = np.indices(pick.shape)
    lamp_i, s_i, _, a_i, m_i, c_i = idx
    toa = dense[pick, lamp_i, s_i, a_i, m_i, c_i]  # (l, s, copy, a, m, c, w)
    kind_of = np.asarray([KINDS.index(k) for k in kinds])
    return (
        toa.reshape(n_l, -1, n_w),
        kind_of[pick].reshape(n_l, -1),
    )
