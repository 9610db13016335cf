"""Single-lamp detection with a Difference of Gaussians (`Lowe2004`).

`D = G(σ₁) * L - G(k σ₁) * L` on a band (or band-sum) radiance image, with
`σ₁ = max(1 px, DOG_SIGMA_M / GSD)` and `k = DOG_RATIO`: at fine GSDs the
inner scale stays near the size of a light pool's bright core, at coarse ones
it is one pixel. A lamp is detected at each local maximum (3 x 3; a plateau
of equal maxima counts once, at its centre) of D above

    threshold = max(NOISE_SIGMAS · σ_D, RELATIVE_THRESHOLD · max D),

with σ_D = 1.4826 · MAD(D) (a robust estimate of the response to noise in
the mostly dark image). The constants are fixed in advance and the same at
every GSD, arrangement and layout: nothing is tuned on the results.

Matching: detections and true lamp positions are paired one-to-one by the
Hungarian algorithm on distance, pairs farther apart than
`match_radius_m = MIN_MATCH_RADIUS_M + GSD / √2` do not count: a lamp is seen
through its light pool, whose brightest part (the kerb or sidewalk beside the
pole) lies up to `MIN_MATCH_RADIUS_M` from the pole, and a detection can only be
placed at a pixel centre, up to half a pixel diagonal from where the pool peaks
(a radius of `max(GSD, 5 m)` is shorter than the two together at a 5 m GSD
and misses every lamp of the shipped layouts there). At GSDs of 5 m and finer
the pool on the far side of the road is resolved as a second peak and counts
as a false detection: precision there is about 0.5 for single-sided rows.
Precision =
TP / detections, recall = TP / lamps, F1 their harmonic mean (0 when
undefined). Lamps at the same position (a central twin) are one target.
"""

import dataclasses

import numpy as np
from scipy import ndimage
from scipy.optimize import linear_sum_assignment


DOG_SIGMA_M = 3.0
DOG_RATIO = 1.6
NOISE_SIGMAS = 5.0
RELATIVE_THRESHOLD = 0.05
MIN_MATCH_RADIUS_M = 5.0


def dog_sigma_px(gsd_m: float, sigma_m: float = DOG_SIGMA_M) -> float:
    """Inner DoG scale in pixels, `max(1, sigma_m / gsd_m)`. [px]"""
    return max(1.0, sigma_m / gsd_m)


def dog_response(
    image: np.ndarray,
    gsd_m: float,
    *,
    sigma_m: float = DOG_SIGMA_M,
    ratio: float = DOG_RATIO,
) -> np.ndarray:
    """`G(σ₁) * image - G(ratio σ₁) * image` (2-D, zero padding).
    [unit of image]"""
    if not ratio > 1:
        raise ValueError(f"ratio must be > 1, got {ratio!r}.")
    s1 = dog_sigma_px(gsd_m, sigma_m)
    img = np.asarray(image, float)
    g1 = ndimage.gaussian_filter(img, s1, mode="constant")
    g2 = ndimage.gaussian_filter(img, ratio * s1, mode="constant")
    return g1 - g2


@dataclasses.dataclass(frozen=True)
class Detections:
    """Detected lamps: `xy_m` (n, 2) positions [m], `response` (n,) DoG values,
    `threshold` the threshold used, `noise_sigma` σ_D."""

    xy_m: np.ndarray
    response: np.ndarray
    threshold: float
    noise_sigma: float


def detect_lamps(
    image: np.ndarray,
    grid,
    *,
    sigma_m: float = DOG_SIGMA_M,
    ratio: float = DOG_RATIO,
    noise_sigmas: float = NOISE_SIGMAS,
    relative: float = RELATIVE_THRESHOLD,
) -> Detections:
    """Detect lamps in a 2-D radiance image on `grid` (a `render.Grid` at the GSD)."""
    d = dog_response(image, grid.dx_m, sigma_m=sigma_m, ratio=ratio)
    mad = float(np.median(np.abs(d - np.median(d))))
    noise = 1.4826 * mad
    dmax = float(d.max()) if d.size else 0.0
    thr = max(noise_sigmas * noise, relative * dmax)
    if dmax <= 0 or thr <= 0:
        return Detections(np.zeros((0, 2)), np.zeros(0), thr, noise)
    mx = ndimage.maximum_filter(d, size=3, mode="constant", cval=-np.inf)
    peaks = (d == mx) & (d > thr)
    # a flat top (equal neighbours, e.g. after quantisation) is one detection at
    # the centre of its connected plateau
    labels, n = ndimage.label(peaks, structure=np.ones((3, 3)))
    if n == 0:
        return Detections(np.zeros((0, 2)), np.zeros(0), thr, noise)
    idx = np.arange(1, n + 1)
    cj, ci = np.array(ndimage.center_of_mass(peaks, labels, idx)).reshape(-1, 2).T
    x0, y0 = grid.x_m[0], grid.y_m[0]
    xy = np.stack([x0 + ci * grid.dx_m, y0 + cj * grid.dx_m], axis=1)
    resp = np.asarray(ndimage.maximum(d, labels, idx), float)
    return Detections(xy, resp, thr, noise)


@dataclasses.dataclass(frozen=True)
class Score:
    tp: int
    fp: int
    fn: int
    precision: float
    recall: float
    f1: float

    def as_dict(self) -> dict:
        return dataclasses.asdict(self)


def unique_targets(xy_m: np.ndarray, tol_m: float = 1.5) -> np.ndarray:
    """Lamp positions merged when closer than `tol_m` (a twin pole is one target)."""
    out: list[np.ndarray] = []
    for p in np.asarray(xy_m, float):
        if not any(np.hypot(*(p - q)) < tol_m for q in out):
            out.append(p)
    return np.array(out).reshape(-1, 2)


def match(detected_xy: np.ndarray, true_xy: np.ndarray, radius_m: float) -> Score:
    """One-to-one matching within `radius_m`; precision, recall, F1."""
    det = np.asarray(detected_xy, float).reshape(-1, 2)
    tru = np.asarray(true_xy, float).reshape(-1, 2)
    tp = 0
    if det.size and tru.size:
        dist = np.hypot(
            det[:, None, 0] - tru[None, :, 0], det[:, None, 1] - tru[None, :, 1]
        )
        cost = np.where(dist <= radius_m, dist, 1e12)
        r, c = linear_sum_assignment(cost)
        tp = int(np.sum(dist[r, c] <= radius_m))
    fp = det.shape[0] - tp
    fn = tru.shape[0] - tp
    p = tp / det.shape[0] if det.shape[0] else 0.0
    r_ = tp / tru.shape[0] if tru.shape[0] else 0.0
    f1 = 2 * p * r_ / (p + r_) if p + r_ > 0 else 0.0
    return Score(tp, fp, fn, p, r_, f1)


def match_radius_m(gsd_m: float) -> float:
    """`MIN_MATCH_RADIUS_M + GSD / √2`: the pool offset plus half a pixel
    diagonal. [m]"""
    return MIN_MATCH_RADIUS_M + float(gsd_m) / np.sqrt(2.0)

