"""Lamp-type identification where two lamp types share pixels.

At a given GSD each lamp type's band-radiance image is resampled separately
(the sensor is linear, so they add up to the scene), the total gets photon
noise and quantisation, and every lit pixel is classified with the spectral
lamp-type classifier of `bandopt.classify` (one-vs-all KNN trained on the
built-in library for the same band set). A pixel's true type is the type that
contributes most of its radiance (summed over bands); its *mixing* is the
share of the other types. F1 (per level-2 class, macro over the classes that
dominate some pixel of the subset) is scored over the lit pixels, and
separately over pure (mixing < 10 %) and mixed (>= 10 %) pixels.
"""

import dataclasses

import jax.numpy as jnp
import numpy as np

from ..classify import predict_lamp_types
from ..datasets.lamps import library
from ..spectra import GRID_1NM
from ._imaging import resample_to_gsd, sensor_image
from ._render import (
    SceneImage,
    band_factors,
    illuminance_images,
    radiance_image,
    uplight_images,
)


LIT_FRACTION = 0.02
"""A pixel is lit when its total radiance (all bands) is at least this fraction
of the brightest pixel's at that GSD (fixed in advance, not tuned per GSD)."""
MIXED_SHARE = 0.10
"""A pixel is mixed when types other than its dominant one give >= 10 % of it."""


@dataclasses.dataclass(frozen=True)
class OverlapScore:
    """Lamp-type identification at one GSD.

    - `gsd_m`, `n_lit` (lit pixels), `mixed_fraction` (of lit pixels),
      `mean_minority_share` (mean share of non-dominant types) [1],
    - `macro_f1`, `accuracy` over lit pixels; `f1_pure`, `f1_mixed` (macro F1
      on pure and mixed pixels, NaN when there are none); `f1_per_class`,
      `n_per_class` (lit pixels whose dominant type is the class: the F1's
      support) and `n_predicted_per_class` (pixels called that class).
    """

    gsd_m: float
    n_lit: int
    mixed_fraction: float
    mean_minority_share: float
    macro_f1: float
    accuracy: float
    f1_pure: float
    f1_mixed: float
    f1_per_class: dict
    n_per_class: dict = dataclasses.field(default_factory=dict)
    n_predicted_per_class: dict = dataclasses.field(default_factory=dict)

    def as_dict(self) -> dict:
        return dataclasses.asdict(self)


def per_type_radiance(scene: SceneImage, bands) -> np.ndarray:
    """(t, b, ny, nx) TOA band radiance of each lamp type of `scene`."""
    lamps, grid = scene.lamps, scene.grid
    e = illuminance_images(lamps, grid, cull_fraction=scene.config["cull_fraction"])
    up = uplight_images(lamps, grid)
    wl = np.asarray(GRID_1NM, float)
    resp = np.asarray(bands.response(jnp.asarray(wl)))
    atm = scene.config.get("atmosphere")
    kg, ku = band_factors(
        lamps.lamp_types,
        scene.layout.surface_map,
        resp,
        wavelength_nm=wl,
        atmosphere=None if atm is None else tuple(atm),
    )
    out = []
    for t in range(len(lamps.lamp_types)):
        out.append(
            np.asarray(
                radiance_image(
                    e[t : t + 1],
                    jnp.asarray(up[t : t + 1], e.dtype),
                    scene.surface_idx,
                    kg[t : t + 1],
                    ku[t : t + 1],
                )
            )
        )
    return np.stack(out)


def _macro_f1(truth, pred):
    """Macro F1 over the classes present in `truth` (NaN when empty)."""
    from sklearn.metrics import f1_score  # sklearn: start-up time

    if len(truth) == 0:
        return float("nan")
    labels = sorted(set(truth.tolist()))
    return float(f1_score(truth, pred, labels=labels, average="macro", zero_division=0))


def lamp_type_f1_when_overlapping(
    scene: SceneImage,
    bands,
    gsd_m: float,
    *,
    seed: int = 0,
    per_type: np.ndarray | None = None,
    noise: bool = True,
) -> OverlapScore:
    """Level-2 lamp-type F1 over the lit pixels of `scene` seen at `gsd_m`.

    `per_type` (from `per_type_radiance`) can be passed to reuse it across GSDs.
    """
    from sklearn.metrics import f1_score  # sklearn: start-up time

    per_type = per_type_radiance(scene, bands) if per_type is None else per_type
    dx = scene.grid.dx_m
    coarse = np.stack([resample_to_gsd(img, dx, gsd_m) for img in per_type])
    total = coarse.sum(axis=0)  # (b, Ny, Nx)
    seen = sensor_image(total, bands, gsd_m, seed=seed, noise=noise)
    signal = coarse.sum(axis=1)  # (t, Ny, Nx)
    lit = total.sum(axis=0) >= LIT_FRACTION * total.sum(axis=0).max()
    share = signal[:, lit] / np.maximum(signal[:, lit].sum(axis=0), 1e-300)
    dominant = np.argmax(share, axis=0)
    minority = 1.0 - share.max(axis=0)
    lib = library()
    level2 = {r.id: r.level2 for r in lib.records}
    names = np.asarray([level2[t] for t in scene.lamps.lamp_types], dtype=object)
    truth = names[dominant]
    pixels = seen[:, lit].T  # (n, b); negative noisy bands count as 0 (classifier)
    _, pred = predict_lamp_types(pixels, bands)
    pred = np.asarray(pred, dtype=object)
    labels = sorted(set(truth.tolist()))
    mixed = minority >= MIXED_SHARE
    per_class = f1_score(truth, pred, labels=labels, average=None, zero_division=0)
    return OverlapScore(
        gsd_m=float(gsd_m),
        n_lit=int(lit.sum()),
        mixed_fraction=float(mixed.mean()) if lit.any() else float("nan"),
        mean_minority_share=float(minority.mean()) if lit.any() else float("nan"),
        macro_f1=_macro_f1(truth, pred),
        accuracy=float(np.mean(truth == pred)) if lit.any() else float("nan"),
        f1_pure=_macro_f1(truth[~mixed], pred[~mixed]),
        f1_mixed=_macro_f1(truth[mixed], pred[mixed]),
        f1_per_class={lab: float(v) for lab, v in zip(labels, per_class, strict=True)},
        n_per_class={lab: int(np.sum(truth == lab)) for lab in labels},
        n_predicted_per_class={
            str(lab): int(np.sum(pred == lab)) for lab in sorted(set(pred.tolist()))
        },
    )
