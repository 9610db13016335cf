"""What a night-time sensor sees where no lamp shines: the natural night-sky
background and, with the Moon up, moonlit ground and moonlight scattered by
the atmosphere, as band radiance images on a rendered scene's grid.

- **Night sky**: the band-averaged natural background of the radiometry
  (`bandopt.radiometry.background_band_radiance`: airglow, zodiacal light
  and starlight of a dark site), the same everywhere; the radiometry's
  detection limits use the same floor.
- **Moon** (`moon`: a named phase of `bandopt.datasets.moon.named_phase`, at
  `moon_zenith_deg`): per surface of the scene (`SURFACE_ROLES`, the
  layout's `surface_map`), `T_up ρ/π T_down E_moon cos θ` plus the 6S
  moonlight path radiance, as `bandopt.scene` builds its Moon terms
  (thesis Eq. 2.14); without an atmosphere `T = 1` and no path radiance.
"""

import math

import jax.numpy as jnp
import numpy as np

from ..datasets import atmosphere as atm, moon as moon_mod
from ..datasets.surfaces import mean_reflectance
from ..forward import band_radiance
from ..radiometry import background_band_radiance
from ..spectra import GRID_1NM
from ._render import SURFACE_ROLES, SceneImage


def background_image(
    scene: SceneImage,
    bands,
    *,
    moon: str | None = None,
    moon_zenith_deg: float = 30.0,
    atmosphere: tuple[str, str, float] | None = None,
    wavelength_nm: np.ndarray = GRID_1NM,
) -> np.ndarray:
    """(b, ny, nx) band radiance of the scene's grid without its lamps: night
    sky plus, with `moon`, moonlit ground and path radiance (module
    docstring). [W m⁻² sr⁻¹ nm⁻¹]"""
    wl = np.asarray(wavelength_nm, float)
    response = np.asarray(bands.response(jnp.asarray(wl)))
    sky = np.asarray(background_band_radiance(response, wl))  # (b,)
    out = np.broadcast_to(sky[:, None, None], (len(sky), *scene.grid.shape)).copy()
    if moon is None:
        return out
    state = moon_mod.named_phase(moon, moon_zenith_deg)
    e_toa = np.asarray(state.irradiance_toa(wl))
    cos = math.cos(math.radians(state.zenith_deg))
    if atmosphere is None:
        t_up, ground, path = np.ones_like(wl), e_toa * cos, np.zeros_like(wl)
    else:
        name, aerosol, vis = atmosphere
        t_up = atm.transmittance("up", name, aerosol, vis, 0.0, wl)
        t_down = atm.transmittance("down", name, aerosol, vis, state.zenith_deg, wl)
        ground = t_down * e_toa * cos
        path = atm.path_radiance(e_toa, state.zenith_deg, name, aerosol, vis, 0.0, wl)
    _, rho = mean_reflectance([scene.layout.surface_map[r] for r in SURFACE_ROLES], wl)
    spectra = rho / math.pi * (t_up * ground)[None, :] + np.asarray(path)[None, :]
    per_surface = np.asarray(band_radiance(spectra, response, wavelength_nm=wl))
    return out + per_surface[scene.surface_idx].transpose(2, 0, 1)
