"""Out-of-library check for the regression baselines (`estimate`'s ridge and
kernel ridge): is a pixel's band-ratio pattern unlike every training pixel?

A regression answers for any input, so a spectrum unlike every lamp it was
trained on (a 450 nm line, a lamp type the library lacks) gets a confident
number. The inversion flags such pixels by its misfit (`inversion`'s
`unexplained`); the baselines have no misfit, so they get the nearest-
neighbour analogue: the distance of the pixel's standardised centred log band
ratios (the features the baselines regress on, `estimate.log_ratio_features`)
to the nearest training pixel. The threshold is a split-conformal novelty
test (`Vovk2005`) on lamp-grouped folds: each fold's held-out lamps' pixels
are measured against the fold's training pixels, and the class-balanced
`QUANTILE` of those distances is the threshold, so lamps of the library's
types are flagged at a rate of about 1 - `QUANTILE` (the same level as the
inversion's flag). Like any such test, it flags what is far from the training
pixels in these features; a new type that resembles a known one in the bands
is not flagged.
"""

import dataclasses
from collections.abc import Sequence

import numpy as np
from scipy.spatial import cKDTree

from .estimate import LampTable, log_ratio_features


QUANTILE = 0.95
"""Class-balanced quantile of held-out lamps' nearest-neighbour distances
above which a pixel is flagged (false-flag rate about 5 % on lamps of known
types; `inversion.UNEXPLAINED_QUANTILE`)."""


def _features(radiance) -> np.ndarray:
    """Centred log band ratios `(n, p)` of band radiances `(n, b)`."""
    return np.asarray(log_ratio_features(np.asarray(radiance, float), 1), float)


def _weighted_quantile(values, weights, q: float) -> float:
    order = np.argsort(values)
    c = np.cumsum(weights[order])
    c = c / c[-1]
    return float(values[order][min(int(np.sum(c < q)), values.size - 1)])


@dataclasses.dataclass(frozen=True)
class RatioNovelty:
    """A fitted check: feature mean and scale `(p,)` of the training pixels,
    their standardised features `train (n, p)` and the `threshold` distance
    (with the `quantile` it stands for and the held-out `rows` it was taken
    from). `flags(radiance)` is True where a pixel is unlike every training
    pixel; `distance(radiance)` the nearest-neighbour distance itself."""

    mean: np.ndarray
    scale: np.ndarray
    train: np.ndarray
    threshold: float
    quantile: float
    rows: int

    def distance(self, radiance) -> np.ndarray:
        """Per pixel: the distance to the nearest training pixel in
        standardised features (inf where a radiance or feature is not
        finite)."""
        rad = np.atleast_2d(np.asarray(radiance, float))
        z = (_features(rad) - self.mean) / self.scale
        bad = ~np.all(np.isfinite(z), axis=1) | ~np.all(np.isfinite(rad), axis=1)
        d, _ = cKDTree(self.train).query(np.where(bad[:, None], 0.0, z), k=1)
        return np.where(bad, np.inf, np.asarray(d, float))

    def flags(self, radiance) -> np.ndarray:
        """Per pixel: True where the nearest training pixel is farther than
        `threshold`."""
        return self.distance(radiance) > self.threshold


def fit_ratio_novelty(
    radiance,
    table: LampTable,
    train_lamps: Sequence[int] | np.ndarray,
    inner: Sequence[tuple[np.ndarray, np.ndarray]],
    *,
    quantile: float = QUANTILE,
) -> RatioNovelty:
    """The check on the pixels of `train_lamps` (rows of `radiance (n, b)`,
    lamps by `table.lamp_of`), its threshold from the lamp-grouped `inner`
    (train, validation) splits: each validation lamp's pixels against the
    split's training pixels, weighted class-balanced per lamp
    (`LampTable.scenario_weights`)."""
    if not 0.0 < quantile < 1.0:
        raise ValueError(f"quantile {quantile}: need 0 < quantile < 1.")
    if not inner:
        raise ValueError("inner: need at least one (train, validation) split.")
    x = _features(radiance)
    lamp_of = np.asarray(table.lamp_of)
    rows = np.flatnonzero(np.isin(lamp_of, train_lamps))
    ok = np.all(np.isfinite(x), axis=1)
    mean = x[rows[ok[rows]]].mean(axis=0)
    scale = x[rows[ok[rows]]].std(axis=0)
    scale = np.where(scale > 0, scale, 1.0)
    z = (x - mean) / scale
    dist, wts = [], []
    for tr, va in inner:
        r_tr = np.flatnonzero(np.isin(lamp_of, tr) & ok)
        r_va = np.flatnonzero(np.isin(lamp_of, va) & ok)
        if r_tr.size == 0 or r_va.size == 0:
            continue
        d, _ = cKDTree(z[r_tr]).query(z[r_va], k=1)
        dist.append(np.asarray(d, float))
        wts.append(table.scenario_weights(va)[r_va])
    if not dist:
        raise ValueError("inner: no split has both training and validation pixels.")
    d, w = np.concatenate(dist), np.concatenate(wts)
    keep = rows[ok[rows]]
    return RatioNovelty(
        mean=mean,
        scale=scale,
        train=z[keep],
        threshold=_weighted_quantile(d, w, quantile),
        quantile=float(quantile),
        rows=int(d.size),
    )
