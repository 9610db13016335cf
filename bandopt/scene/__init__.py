"""Scenario sets and the factorised top-of-atmosphere radiance model.

A scenario is one lamp x surface x atmosphere x Moon state x lighting class,
seen in a neighbourhood. The top-of-atmosphere spectral radiance of a pixel
[W m⁻² sr⁻¹ nm⁻¹] is

    L_toa = T_dir · L_pixel + T_dif · L_neighbourhood + L_path,moon

    L_pixel = ρ/π · ( E_c · S_l + T_down · E_moon · cos θ_moon )
              + f_up · E_c · S_l + f_fire · ε · B(T_fire)

    L_neighbourhood = ρ_n/π · ( k · E_c · S_l + T_down · E_moon · cos θ_moon )
                      + k · ( f_up · E_c · S_l + f_fire · ε · B(T_fire) )

with, per term:

- `T_dir(λ)`, `T_dif(λ)`: the direct (unscattered, gas x `exp(-τ/cos θv)`) and
  diffuse parts of the one-way upward transmittance at the view zenith (6S
  tables, `bandopt.datasets.atmosphere`; `T_dir + T_dif = T_up`, the total).
  A pixel of 10-100 m sees its own ground through the direct part; the diffuse
  part is light scattered into the view from a footprint of about 1 km
  (aerosol) to tens of km (Rayleigh) around it, the adjacency effect (6S's
  pixel/background split, `Vermote1997`). With a **uniform neighbourhood**
  (`L_neighbourhood = L_pixel`) this is `T_up · L_pixel`, the model of the
  thesis (section 2.4) and of coarse sensors (VIIRS, 750 m).
- The neighbourhood (`Neighbourhood`): a fraction `lit_fraction` of it is lit
  by lamps like the pixel's at `relative_illuminance` times the pixel's class
  illuminance, the rest only by the Moon; `k = lit_fraction x
  relative_illuminance`. Its ground `ρ_n` is the pixel's surface or a stated
  background surface; the whole neighbourhood is moonlit. Luminaire uplight
  and fires scale with `k` like the lamp light (a stated simplification).
  ``"lit_street_dark_district"`` (k = 0.1, the pixel's surface) is a lit
  street at the ~10 m GSD this project recommends in a dark district, and
  the default (`DEFAULT_NEIGHBOURHOOD`); ``"uniform"`` reproduces the
  total-transmittance model of the thesis exactly and is what a coarse
  sensor (VIIRS, 750 m) over a uniformly lit city sees.
- `ρ(λ)`: Lambertian surface reflectance (`bandopt.datasets.surfaces`); a
  mixed pixel (`surfaces` entry ``(a, b, fraction)``) has the area-weighted
  mean reflectance.
- `E_c · S_l(λ)`: the lamp's spectral irradiance on the ground. `S_l` is the
  library spectrum per lumen [W nm⁻¹ lm⁻¹] and `E_c` the average horizontal
  illuminance [lx] of EN 13201-2 lighting class `c`; M classes (road luminance
  seen by a driver) become illuminance with the road's average luminance
  coefficient, `E = L / Q0`. So the lamp scale factor depends on lamp x class
  only and the same illuminance lights every surface of the scene. A pixel lit
  by two lamp types (`lamps` entry ``(a, b, fraction)``) has the
  illuminance-weighted mean spectrum.
- `T_down · E_moon · cos θ_moon`: moonlight on the ground (ROLO irradiance at
  the top of the atmosphere, `bandopt.datasets.moon`, times the one-way
  downward total transmittance at the Moon's zenith).
- `f_up · E_c · S_l`: light the luminaires send towards the sensor, seen
  directly. The luminaires of the pixel emit `Φ/A = E_c / d` lumen per ground
  area (their downward fraction `d` lands in the pixel at `E_c`) with the
  intensity per lumen `i(θ)` of a measured azimuth-averaged profile
  (Illumina's `*_pcUPLIGHT.lop`, `Aube2018`, by nominal uplight percentage,
  linear mixing between files), so at view zenith θv (the zenith angle of the
  direction towards the sensor) `f_up = i(θv) / (d cos θv)` [sr⁻¹]
  (`uplight_factor`). The old Lambertian shortcut `u / (1 - u) / π` is
  available as `uplight_model="lambertian"`.
- `f_fire · ε · B(T_fire)`: blackbody emission (Planck) of a burning fraction
  of the pixel with emissivity ε (fire scenes only).
- `L_path,moon`: path radiance of moonlight scattered by the atmosphere
  (6S intrinsic reflectance x lunar irradiance). Path radiance of *lamp* light
  is neglected (thesis section 2.4), as is the coupling of ground and
  atmosphere (multiple reflections, a factor `1/(1 - ρ_n S)`: 1-3 % for ρ
  0.1-0.3 with 6S's spherical albedo S = 0.10 at 550 nm, mid-latitude summer,
  urban, 23 km); the diffuse transmittance is 6S's for a Lambertian source,
  also for uplight.

**Cost.** Band radiance is linear in every factor, so the band radiance of
every combination is a contraction over wavelength of small factor arrays
(`band_terms`), never the full lamp x surface x atmosphere x moon x class x
wavelength array. The neighbourhood only changes the transmittance the lamp
terms are contracted with (`T_dir + k T_dif`, one array per atmosphere), and a
background surface adds one (lamp, atmosphere, band) and one (atmosphere, moon,
band) contraction. A term a scenario set lacks (no Moon, no uplight, no fire,
no atmosphere, uniform neighbourhood) is `None` and costs nothing.

Modules: `_conditions` (lighting classes, atmospheres, neighbourhoods),
`_uplight` (the luminaires' uplight factor from Illumina's profiles),
`_model` (the factor arrays, their contraction into band terms and the
scenes' band radiance) and `_build` (`ScenarioSet`, `build_scenarios`);
this package re-exports their names.
"""

from ..spectra import GRID_1NM as GRID_1NM, planck_radiance as planck_radiance
from ._build import (
    DEFAULT_ATMOSPHERES as DEFAULT_ATMOSPHERES,
    DEFAULT_CLASSES as DEFAULT_CLASSES,
    DEFAULT_MOONS as DEFAULT_MOONS,
    DEFAULT_SURFACES as DEFAULT_SURFACES,
    PHYSICS_VERSION as PHYSICS_VERSION,
    MixSpec as MixSpec,
    ScenarioSet as ScenarioSet,
    build_scenarios as build_scenarios,
    mix_label as mix_label,
)
from ._conditions import (
    DEFAULT_NEIGHBOURHOOD as DEFAULT_NEIGHBOURHOOD,
    LIGHTING_CLASSES as LIGHTING_CLASSES,
    NEIGHBOURHOODS as NEIGHBOURHOODS,
    NO_ATMOSPHERE as NO_ATMOSPHERE,
    Q0_DRY_R3_PER_SR as Q0_DRY_R3_PER_SR,
    AtmosphereSpec as AtmosphereSpec,
    Neighbourhood as Neighbourhood,
    class_illuminance_lx as class_illuminance_lx,
    resolve_neighbourhood as resolve_neighbourhood,
)
from ._model import (
    BandTerms as BandTerms,
    Factors as Factors,
    band_terms as band_terms,
    band_weights as band_weights,
    fire_scenes as fire_scenes,
    full_toa_radiance as full_toa_radiance,
    lamp_scenes as lamp_scenes,
    moon_scenes as moon_scenes,
)
from ._uplight import (
    _LOP_DIR as _LOP_DIR,
    UPLIGHT_MODELS as UPLIGHT_MODELS,
    UPLIGHT_PROFILE_PERCENT as UPLIGHT_PROFILE_PERCENT,
    uplight_factor as uplight_factor,
    uplight_profiles as uplight_profiles,
)
