"""Spatial sampling of road lighting (thesis section 4.3, `DeMeester2019`).

Luminaires (intensity distributions from EULUMDAT / IES files, Illumina
profiles or parametric shapes) placed in road layouts are rendered
analytically to top-of-atmosphere band radiance images on a fine grid
(`render`), blurred and resampled to a sensor's GSD with noise and
quantisation (`imaging`), and searched for single lamps with a Difference of
Gaussians (`detect`). `bandopt.spatial.montecarlo` checks the renderer
against Mitsuba 3.

The studies: `GsdStudy` and `run_gsd_study` (the GSD needed to detect single
lamps per arrangement, key "spatial" of results/recommendation.json;
`_study`, figures in `_study_figures`) and `run_overlap_study` (lamp types
where two share pixels; `_overlap_study`), run by `make spatial`.
"""

from .._photometric import (
    IntensityTable as IntensityTable,
    read_ies as read_ies,
    read_ldt as read_ldt,
    read_lop as read_lop,
    read_photometry as read_photometry,
)
from ._background import background_image as background_image
from ._detect import (
    DOG_RATIO as DOG_RATIO,
    DOG_SIGMA_M as DOG_SIGMA_M,
    FALSE_ALARMS_PER_KM2 as FALSE_ALARMS_PER_KM2,
    MIN_MATCH_RADIUS_M as MIN_MATCH_RADIUS_M,
    NOISE_SIGMAS as NOISE_SIGMAS,
    RELATIVE_THRESHOLD as RELATIVE_THRESHOLD,
    Detections as Detections,
    Score as Score,
    cfar_factor as cfar_factor,
    detect_lamps as detect_lamps,
    dog_kernel as dog_kernel,
    dog_noise_sigma as dog_noise_sigma,
    dog_response as dog_response,
    match as match,
    match_radius_m as match_radius_m,
    unique_targets as unique_targets,
)
from ._evaluate import (
    Observation as Observation,
    cross_section as cross_section,
    observe as observe,
    phases as phases,
    true_targets as true_targets,
)
from ._imaging import (
    GSDS_M as GSDS_M,
    block_mean as block_mean,
    gsd_grid as gsd_grid,
    mtf_at_nyquist as mtf_at_nyquist,
    noise_variance as noise_variance,
    psf_sigma_m as psf_sigma_m,
    resample_to_gsd as resample_to_gsd,
    sensor_image as sensor_image,
)
from ._layout import (
    ARRANGEMENTS as ARRANGEMENTS,
    LampPlacement as LampPlacement,
    Layout as Layout,
    arrangement as arrangement,
    layout_from_dict as layout_from_dict,
    layout_names as layout_names,
    load_layout as load_layout,
    read_layout as read_layout,
)
from ._luminaire import (
    LOP_UPLIGHT_PERCENT as LOP_UPLIGHT_PERCENT,
    LUMINAIRE_NAMES as LUMINAIRE_NAMES,
    Luminaire as Luminaire,
    cutoff as cutoff,
    from_file as from_file,
    from_lop as from_lop,
    lambertian as lambertian,
    lookup_cd_per_lm as lookup_cd_per_lm,
    luminaire as luminaire,
    road_optic as road_optic,
    uniform as uniform,
)
from ._overlap import (
    OverlapScore as OverlapScore,
    lamp_type_f1_when_overlapping as lamp_type_f1_when_overlapping,
    per_type_radiance as per_type_radiance,
)
from ._overlap_study import (
    OVERLAP_ATMOSPHERE as OVERLAP_ATMOSPHERE,
    overlap_bands as overlap_bands,
    run_overlap_study as run_overlap_study,
)
from ._render import (
    DEFAULT_CULL_FRACTION as DEFAULT_CULL_FRACTION,
    SURFACE_ROLES as SURFACE_ROLES,
    Grid as Grid,
    LampArrays as LampArrays,
    SceneImage as SceneImage,
    band_factors as band_factors,
    cull_radius_m as cull_radius_m,
    illuminance_images as illuminance_images,
    lamp_arrays as lamp_arrays,
    point_illuminance_lx as point_illuminance_lx,
    radiance_image as radiance_image,
    render as render,
    resolve_flux as resolve_flux,
    scene_grid as scene_grid,
    surface_index as surface_index,
    uplight_images as uplight_images,
)
from ._study import (
    GsdStudy as GsdStudy,
    assumptions as assumptions,
    recommend_from_summary as recommend_from_summary,
    recommend_spatial as recommend_spatial,
    run_gsd_study as run_gsd_study,
    study_atmosphere as study_atmosphere,
    study_bands as study_bands,
    study_scenes as study_scenes,
    study_sensor as study_sensor,
)
from ._sweep import (
    F1_NEEDED as F1_NEEDED,
    CoarsestGsd as CoarsestGsd,
    GsdScore as GsdScore,
    GsdSweep as GsdSweep,
    coarsest_gsd as coarsest_gsd,
    gsd_sweep as gsd_sweep,
)
