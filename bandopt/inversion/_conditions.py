"""Scene conditions the inversion knows besides lamp and surface: the
candidate atmospheres' transmittances, the lamp light's transmittance in the
pixel's neighbourhood and the Moon's irradiance and path radiance."""

import dataclasses

import numpy as np


@dataclasses.dataclass(frozen=True)
class Conditions:
    """What the inversion knows of the scene besides lamp and surface.

    - `wavelength_nm`: grid. (w,) [nm]
    - `t_up`: upward (total) transmittance of each candidate atmosphere; the
      Moon's light reaches the sensor through it (the whole neighbourhood is
      moonlit). (a, w) [1]
    - `moon`: Moon's irradiance on the ground `T_down E_moon cos θ` of its
      brightest state, or None for moonless scenes. (a, w) [W m⁻² nm⁻¹]
    - `path`: the Moon's path radiance, same state, or None. (a, w)
    - `labels`: atmosphere labels.
    - `t_lamp`: transmittance of the lamp light reflected in the pixel,
      `T_dir + k T_dif` for a neighbourhood whose lamp light is `k` times the
      pixel's (`scene.Factors.emission_transmittance`), or None for a uniform
      neighbourhood (`t_up`). (a, w) [1]
    """

    wavelength_nm: np.ndarray
    t_up: np.ndarray
    moon: np.ndarray | None
    path: np.ndarray | None
    labels: tuple[str, ...]
    t_lamp: np.ndarray | None = None

    @property
    def lamp_transmittance(self) -> np.ndarray:
        """`t_lamp`, or `t_up` for a uniform neighbourhood. (a, w) [1]"""
        return self.t_up if self.t_lamp is None else self.t_lamp

    @classmethod
    def from_scenarios(cls, scen) -> "Conditions":
        """Atmospheres, neighbourhood and the brightest Moon state of a
        `scene.ScenarioSet`. A neighbourhood with its own background surface
        is approximated by the pixel's surface (`T_dir + k T_dif`)."""
        f = scen.factors
        moon = path = None
        if f.moon_ground is not None:
            mg = np.asarray(f.moon_ground)
            k = int(np.argmax(mg.sum(axis=(0, 2))))
            if mg[:, k].max() > 0:
                moon = mg[:, k]
                path = None if f.path is None else np.asarray(f.path)[:, k]
        return cls(
            np.asarray(f.wavelength_nm, float),
            np.asarray(f.t_up, float),
            moon,
            path,
            tuple(scen.atmosphere_labels),
            None if f.t_dir is None else np.asarray(f.emission_transmittance(), float),
        )

    @classmethod
    def clear(cls, wavelength_nm) -> "Conditions":
        """No atmosphere (T = 1), no Moon."""
        w = np.asarray(wavelength_nm, float)
        return cls(w, np.ones((1, w.size)), None, None, ("none",))
