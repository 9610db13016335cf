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

**At a fixed false-alarm rate** (`detect_lamps(..., variance=, false_alarms_per_km2=)`):
given the variance of each pixel's noise (the sensor's photon model on the
background, Moon and lamp light the pixel holds, plus quantisation), the DoG
response to noise alone has standard deviation
`σ_D(x) = sqrt(Σ_k h_k² var(x - k))` (`dog_noise_sigma`, h the DoG kernel),
and a local maximum counts when `D(x) > u σ_D(x)` with
`u = Φ⁻¹(1 - r GSD² / 10⁶)` (`cfar_factor`) for `r` false alarms per km².
A false detection at x needs `D(x) > u σ_D(x)`, which Gaussian noise exceeds
with probability `r GSD² / 10⁶`; over the `10⁶ / GSD²` pixels of a km² the
expected count of false detections is therefore at most `r` at every GSD
(an upper bound: a local maximum is rarer than an exceedance).

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
import math

import numpy as np
from scipy import ndimage
from scipy.optimize import linear_sum_assignment
from scipy.special import ndtri


DOG_SIGMA_M = 3.0
DOG_RATIO = 1.6
NOISE_SIGMAS = 5.0
RELATIVE_THRESHOLD = 0.05
MIN_MATCH_RADIUS_M = 5.0
FALSE_ALARMS_PER_KM2 = 0.1
"""Default false-alarm rate of the fixed-rate detector: at most one false lamp
per 10 km² of dark or moonlit ground. [km⁻²]"""


def cfar_factor(gsd_m: float, false_alarms_per_km2: float) -> float:
    """`u = Φ⁻¹(1 - r GSD² / 10⁶)`: the threshold in units of the DoG noise σ
    for `r` expected false alarms per km² at most (module docstring). [1]"""
    p = float(false_alarms_per_km2) * float(gsd_m) ** 2 / 1e6
    if not 0.0 < p < 0.5:
        raise ValueError(
            f"false_alarms_per_km2={false_alarms_per_km2!r} at GSD {gsd_m!r} m: the "
            f"per-pixel rate {p:g} must lie in (0, 0.5)."
        )
    return float(-ndtri(p))  # Φ⁻¹(1 - p) without the rounding of 1 - p


def dog_kernel(gsd_m: float, *, sigma_m: float = DOG_SIGMA_M, ratio: float = DOG_RATIO):
    """The DoG's impulse response `h` (`dog_response` of a unit impulse), out
    to 4 of its outer σ. [1]"""
    s2 = ratio * dog_sigma_px(gsd_m, sigma_m)
    half = math.ceil(4.0 * s2) + 1
    delta = np.zeros((2 * half + 1, 2 * half + 1))
    delta[half, half] = 1.0
    return dog_response(delta, gsd_m, sigma_m=sigma_m, ratio=ratio)


def dog_noise_sigma(
    variance: np.ndarray, gsd_m: float, *, sigma_m: float = DOG_SIGMA_M,
    ratio: float = DOG_RATIO,
) -> np.ndarray:  # fmt: skip
    """`σ_D(x) = sqrt(Σ_k h_k² var(x - k))`: the standard deviation of the DoG
    response to independent pixel noise of variance `variance` (2-D; the
    edge pixel's variance continued beyond the image, as the fixed-rate
    detector's `dog_response(mode="nearest")` continues the image).
    [unit of image]"""
    h2 = dog_kernel(gsd_m, sigma_m=sigma_m, ratio=ratio) ** 2
    var = ndimage.convolve(np.asarray(variance, float), h2, mode="nearest")
    return np.sqrt(np.maximum(var, 0.0))


def dog_sigma_px(gsd_m: float, sigma_m: float = DOG_SIGMA_M) -> float:
    """Inner DoG scale in pixels, `max(1, sigma_m / gsd_m)`. [px]"""
    return max(1.0, sigma_m / gsd_m)


def dog_response(
    image: np.ndarray,
    gsd_m: float,
    *,
    sigma_m: float = DOG_SIGMA_M,
    ratio: float = DOG_RATIO,
    mode: str = "constant",
) -> np.ndarray:
    """`G(σ₁) * image - G(ratio σ₁) * image` (2-D; edges padded by
    `scipy.ndimage` `mode`: "constant", zeros, dark surroundings; "nearest",
    the edge pixel continued, an image cut from a larger one).
    [unit of image]"""
    if not ratio > 1:
        raise ValueError(f"ratio must be > 1, got {ratio!r}.")
    s1 = dog_sigma_px(gsd_m, sigma_m)
    img = np.asarray(image, float)
    g1 = ndimage.gaussian_filter(img, s1, mode=mode)
    g2 = ndimage.gaussian_filter(img, ratio * s1, mode=mode)
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
    variance: np.ndarray | None = None,
    false_alarms_per_km2: float | None = None,
) -> Detections:
    """Detect lamps in a 2-D radiance image on `grid` (a `render.Grid` at the
    GSD). With `variance` (each pixel's noise variance) and
    `false_alarms_per_km2`, at that fixed false-alarm rate (module docstring;
    `threshold` and `noise_sigma` are then the darkest pixel's); else with
    the MAD and relative thresholds. The fixed-rate detector continues the
    image beyond its edges ("nearest": the ground goes on); the other pads
    with zeros."""
    mode = "constant" if variance is None else "nearest"
    d = dog_response(image, grid.dx_m, sigma_m=sigma_m, ratio=ratio, mode=mode)
    dmax = float(d.max()) if d.size else 0.0
    if (variance is None) != (false_alarms_per_km2 is None):
        raise ValueError(
            "detect_lamps: give both variance and false_alarms_per_km2, or neither."
        )
    if variance is not None:
        if np.shape(variance) != d.shape:
            raise ValueError(
                f"detect_lamps: variance {np.shape(variance)} for an image {d.shape}."
            )
        sd = dog_noise_sigma(variance, grid.dx_m, sigma_m=sigma_m, ratio=ratio)
        if not np.all(np.isfinite(sd)) or sd.min() <= 0:
            raise ValueError("detect_lamps: the noise variance must be finite and > 0.")
        thr_map = cfar_factor(grid.dx_m, false_alarms_per_km2) * sd
        thr, noise = float(thr_map.min()), float(sd.min())
    else:
        mad = float(np.median(np.abs(d - np.median(d))))
        noise = 1.4826 * mad
        thr = max(noise_sigmas * noise, relative * dmax)
        thr_map = thr
        if dmax <= 0 or thr <= 0:
            return Detections(np.zeros((0, 2)), np.zeros(0), thr, noise)
    mx = ndimage.maximum_filter(d, size=3, mode="constant", cval=-np.inf)
    peaks = (d == mx) & (d > thr_map)
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

