"""A rendered scene seen at a GSD: images, detections and scores.

`observe` turns a fine `SceneImage` into what a sensor at `gsd_m` records
(PSF, pixel box, noise, quantisation; `bandopt.spatial.resample_to_gsd`,
`sensor_image`), optionally with the pixel grid shifted by a sub-pixel phase
(the position of the lamps relative to the pixel grid is arbitrary in a real
image; scores are averaged over phases drawn from a seed). Detection runs on
the mean of the bands (a panchromatic image when there is one band).
"""

import dataclasses

import numpy as np

from ._detect import (
    Detections,
    Score,
    detect_lamps,
    dog_response as _dog,
    match,
    match_radius_m,
    unique_targets as _unique,
)
from ._imaging import (
    gsd_grid,
    noise_variance,
    psf_sigma_m,
    resample_to_gsd,
    sensor_image,
)
from ._render import Grid, SceneImage


DEFAULT_SATURATION_W_M2_SR_NM = 1e-3
"""Saturation of the simulated sensor, fixed in advance (all GSDs). [W m⁻² sr⁻¹ nm⁻¹]"""
DEFAULT_BIT_DEPTH = 14


@dataclasses.dataclass(frozen=True)
class Observation:
    """`image` (b, my, mx) radiance at the GSD [W m⁻² sr⁻¹ nm⁻¹], its `grid`,
    the noise-free `clean` image, `detections` and `score`."""

    gsd_m: float
    image: np.ndarray
    clean: np.ndarray
    grid: Grid
    detections: Detections
    score: Score
    phase_px: tuple[int, int]
    detected: np.ndarray | None = None
    """The 2-D image the detector ran on (None: the mean of the bands)."""


def true_targets(scene: SceneImage) -> np.ndarray:
    """(n, 2) distinct lamp positions (a twin pole counts once). [m]"""
    xy = np.stack([scene.lamps.x_m, scene.lamps.y_m], axis=1)
    return _unique(xy)


def observe(
    scene: SceneImage,
    bands,
    gsd_m: float,
    *,
    seed: int = 0,
    phase_px: tuple[int, int] = (0, 0),
    fwhm_gsd: float | None = 1.0,
    mtf_nyquist: float | None = None,
    noise: bool = True,
    bit_depth: int | None = DEFAULT_BIT_DEPTH,
    saturation_w_m2_sr_nm=DEFAULT_SATURATION_W_M2_SR_NM,
    detection_limit_w_m2_sr_nm=0.0,
    background: np.ndarray | None = None,
    false_alarms_per_km2: float | None = None,
    detection_band: str | None = None,
    known_background: bool = False,
) -> Observation:
    """Blur, resample, add noise, detect and score one scene at one GSD.
    `phase_px`: (rows, columns) of fine pixels cropped before resampling.
    `background`: (b, ny, nx) radiance on the scene's fine grid added to the
    lamps' (night sky, moonlit ground). `false_alarms_per_km2`: detect at
    that fixed false-alarm rate with each pixel's noise variance from the
    sensor model (`detect_lamps`), else with the MAD and relative
    thresholds. `detection_band`: the band detected on (default: the mean of
    the bands). Saturation and detection limit: scalars or one per band.
    `known_background`: the detector subtracts the lamp-free ground it is
    told (`background` seen at the GSD without noise: night sky and moonlit
    surfaces, as a lunar model and daytime reflectance give them) before
    the DoG, so the edges between surfaces are not taken for lamps; the
    noise it judges against still includes the background's."""
    oy, ox = phase_px
    g = scene.grid
    fine = scene.radiance if background is None else scene.radiance + background
    fine = fine[:, oy:, ox:]
    shifted = Grid(
        g.x0_m + ox * g.dx_m, g.y0_m + oy * g.dx_m, g.nx - ox, g.ny - oy, g.dx_m
    )
    sigma = psf_sigma_m(gsd_m, fwhm_gsd=fwhm_gsd, mtf_nyquist=mtf_nyquist)
    clean = resample_to_gsd(fine, g.dx_m, gsd_m, sigma_m=sigma)
    img = sensor_image(
        clean,
        bands,
        gsd_m,
        seed=seed,
        noise=noise,
        bit_depth=bit_depth,
        saturation_w_m2_sr_nm=saturation_w_m2_sr_nm,
        detection_limit_w_m2_sr_nm=detection_limit_w_m2_sr_nm,
    )
    grid = gsd_grid(shifted, gsd_m)
    told = 0.0
    if known_background and background is not None:
        told = resample_to_gsd(background[:, oy:, ox:], g.dx_m, gsd_m, sigma_m=sigma)
    seen = img - told
    if detection_band is None:
        pan, pick = seen.mean(axis=0), None
    else:
        if detection_band not in scene.band_names:
            raise ValueError(
                f"observe: detection_band {detection_band!r} is not one of "
                f"{list(scene.band_names)}."
            )
        pick = scene.band_names.index(detection_band)
        pan = seen[pick]
    cfar = {}
    if false_alarms_per_km2 is not None:
        var = noise_variance(
            img, bands, gsd_m, bit_depth=bit_depth,
            detection_limit_w_m2_sr_nm=detection_limit_w_m2_sr_nm,
            saturation_w_m2_sr_nm=saturation_w_m2_sr_nm,
        )  # fmt: skip
        var = var.mean(axis=0) / var.shape[0] if pick is None else var[pick]
        cfar = {"variance": var, "false_alarms_per_km2": false_alarms_per_km2}
    det = detect_lamps(pan, grid, **cfar)
    score = match(det.xy_m, true_targets(scene), match_radius_m(gsd_m))
    return Observation(float(gsd_m), img, clean, grid, det, score, (oy, ox), pan)


def phases(scene: SceneImage, gsd_m: float, n: int, seed: int) -> list[tuple[int, int]]:
    """`n` sub-pixel grid phases (fine-pixel offsets within one GSD pixel); the
    first is (0, 0)."""
    f = max(1, round(gsd_m / scene.grid.dx_m))
    rng = np.random.default_rng(seed)
    out = [(0, 0)]
    while len(out) < n:
        out.append((int(rng.integers(0, f)), int(rng.integers(0, f))))
    return out[:n]


def cross_section(
    obs: Observation, scene: SceneImage, axis: str, lamp: int = 0
) -> dict:
    """Radiance and DoG response along (`axis="along"`, the image row through
    lamp `lamp`) or across the road (`"across"`, its column). Positions [m]
    relative to the lamp."""
    x, y = scene.lamps.x_m[lamp], scene.lamps.y_m[lamp]
    j, i = obs.grid.pixel_of(x, y)
    pan = obs.image.mean(axis=0) if obs.detected is None else obs.detected
    dog = _dog(pan, obs.gsd_m)
    if axis == "along":
        pos, rad, resp = obs.grid.x_m - x, pan[j, :], dog[j, :]
    elif axis == "across":
        pos, rad, resp = obs.grid.y_m - y, pan[:, i], dog[:, i]
    else:
        raise ValueError(f"Unknown axis={axis!r}; expected one of ['across', 'along'].")
    return {
        "position_m": pos,
        "radiance": rad,
        "dog": resp,
        "threshold": obs.detections.threshold,
    }
