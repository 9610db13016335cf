"""Monte Carlo check of the analytic renderer with Mitsuba 3 (`Jakob2022`).

One flat scene: an isotropic point light of intensity I [cd] at height h above
a Lambertian plane of reflectance ρ, seen by a nadir orthographic camera.
Mitsuba's `path` integrator (max depth 2: direct light only, as the analytic
renderer) with a box pixel filter returns the pixel-averaged radiance
`ρ/π · I cos³γ / h²` plus Monte Carlo noise. Mitsuba is optional
(`pip install mitsuba`); its CPU variant `scalar_rgb` is used, with the same
number in all three RGB channels (a grey, monochromatic check: the spectral
part of the pipeline is linear and tested elsewhere).

Scenes with buildings (occluders), which the flat analytic renderer does not
handle, go through the same Mitsuba scene with `buildings`: axis-aligned boxes
standing on the plane, Lambertian with the ground's reflectance, casting
shadows (`render_point_light(..., buildings=[(x0, y0, x1, y1, height_m)])`).
"""

import math

import numpy as np


def available() -> bool:
    """True when `mitsuba` imports and has the `scalar_rgb` variant."""
    try:
        import mitsuba as mi  # optional dependency (extra `render`)
    except ImportError:
        return False
    return "scalar_rgb" in mi.variants()


def render_point_light(
    *,
    intensity_cd: float,
    height_m: float,
    reflectance: float,
    extent_m: float,
    pixels: int,
    spp: int,
    seed: int = 0,
    buildings=(),
) -> np.ndarray:
    """(pixels, pixels) Mitsuba radiance of the plane `[-extent/2, extent/2]²`
    under an isotropic point light above its centre. [cd m⁻² sr⁻¹ per unit of
    `intensity_cd`, i.e. radiance in the light's unit per m²]

    `buildings`: boxes `(x0, y0, x1, y1, height_m)` [m] on the plane; they cast
    shadows and their roofs are seen by the nadir camera. Row 0 of the image is
    +y, column 0 is -x (Mitsuba's film orientation)."""
    import mitsuba as mi  # optional dependency (extra `render`)

    mi.set_variant("scalar_rgb")
    t = mi.ScalarTransform4f
    half = extent_m / 2
    desc = dict(
        {
            "type": "scene",
            "integrator": {"type": "path", "max_depth": 2},
            "sensor": {
                "type": "orthographic",
                "to_world": t().look_at(
                    origin=[0, 0, 10 * height_m], target=[0, 0, 0], up=[0, 1, 0]
                )
                @ t().scale([half, half, 1.0]),
                "sampler": {"type": "independent", "sample_count": spp, "seed": seed},
                "film": {
                    "type": "hdrfilm",
                    "width": pixels,
                    "height": pixels,
                    "rfilter": {"type": "box"},
                    "pixel_format": "rgb",
                },
            },
            "plane": {
                "type": "rectangle",
                "to_world": t().scale([half, half, 1.0]),
                "bsdf": {
                    "type": "diffuse",
                    "reflectance": {"type": "rgb", "value": [reflectance] * 3},
                },
            },
            "light": {
                "type": "point",
                "position": [0.0, 0.0, height_m],
                "intensity": {"type": "rgb", "value": [intensity_cd] * 3},
            },
        }
    )
    for k, (x0, y0, x1, y1, h) in enumerate(buildings):
        if not (x1 > x0 and y1 > y0 and h > 0):
            raise ValueError(
                f"buildings[{k}] = {(x0, y0, x1, y1, h)}: need x1 > x0, y1 > y0, "
                "height_m > 0."
            )
        cx, cy = (x0 + x1) / 2, (y0 + y1) / 2
        desc[f"building_{k}"] = {
            "type": "cube",
            "to_world": t().translate([cx, cy, h / 2])
            @ t().scale([(x1 - x0) / 2, (y1 - y0) / 2, h / 2]),
            "bsdf": {
                "type": "diffuse",
                "reflectance": {"type": "rgb", "value": [reflectance] * 3},
            },
        }
    scene = mi.load_dict(desc)
    img = mi.render(scene, seed=seed)
    return np.array(img)[:, :, 0].astype(float)


def analytic_point_light(
    *,
    intensity_cd: float,
    height_m: float,
    reflectance: float,
    extent_m: float,
    pixels: int,
    supersample: int = 8,
) -> np.ndarray:
    """The same image from the closed form `ρ/π I h / d³`, averaged over
    `supersample`² points per pixel (the box filter of the Monte Carlo run)."""
    n = pixels * supersample
    c = (np.arange(n) + 0.5) / n * extent_m - extent_m / 2
    x, y = np.meshgrid(c, c)
    d = np.sqrt(x * x + y * y + height_m**2)
    rad = reflectance / math.pi * intensity_cd * height_m / d**3
    return rad.reshape(pixels, supersample, pixels, supersample).mean(axis=(1, 3))
