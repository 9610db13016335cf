"""De-duplication of scenarios whose scale-free features (`bandopt.knn.
features`) coincide."""

import numpy as np
from jaxtyping import ArrayLike, Float


def deduplicate(
    feats: Float[ArrayLike, "n p"], groups: ArrayLike, *, rtol: float = 1e-9
) -> np.ndarray:
    """Indices (sorted) of the first row of every group of identical feature
    rows within each `groups` value (e.g. the lamp).

    Scenarios that differ only by the lighting-class scale factor (no Moon,
    no path radiance) have identical noise-free features; a nearest-neighbour
    classifier fed all of them sees copies of one point. Rows count as equal
    when they agree after rounding to `rtol` of the largest absolute feature.
    """
    x = np.asarray(feats, float)
    g = np.asarray(groups)
    if x.ndim != 2 or g.shape != (x.shape[0],):
        raise ValueError(
            f"feats must be (n, p) and groups (n,), got {x.shape} and {g.shape}."
        )
    if x.shape[0] == 0:
        return np.zeros(0, int)
    step = rtol * max(float(np.max(np.abs(x))), 1e-300)
    q = np.round(x / step).astype(np.int64)
    _, gi = np.unique(g, return_inverse=True)
    key = np.concatenate([gi[:, None].astype(np.int64), q], axis=1)
    _, first = np.unique(key, axis=0, return_index=True)
    return np.sort(first)
