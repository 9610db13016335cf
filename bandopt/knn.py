"""One-vs-all k-nearest-neighbour primitives shared by the band search and
the lamp-type classifier (`bandopt.search` scores designs with them,
`bandopt.classify` builds on them and re-exports every name): scale-free
features of band radiances, the scikit-learn model, neighbour queries and
votes, k chosen by inner cross-validation, and the macro F1 it maximises.

Features: a pixel's band radiances scale with the lamp's illuminance, the
albedo and the pixel fill; only their *shape* tells the lamp type. Two
scale-free feature kinds:

- `"log_ratio"` (default): centred log band ratios (the centred log-ratio
  transform, `Aitchison1982`), `x_j = log(L_j/L̄ + δ) - mean_k log(L_k/L̄ + δ)`
  with `L̄` the mean band radiance of the pixel and
  `δ = bandopt.estimate.LOG_FLOOR`. Chosen because Euclidean distance
  between log ratios weighs a ratio change of 2x the same whether the bands
  are bright or dim: a sodium lamp's weak blue band (1 % of its red) and a
  warm LED's (20 %) are far apart, while in sum-normalised radiance both sit
  near 0 and their difference is swamped by the bright bands. It is
  `bandopt.estimate.log_ratio_features` (one copy).
- `"sum_normalised"`: `L_j / Σ_k L_k` (compositional, bounded in [0, 1]; more
  robust to a noisy band near zero, less sensitive to weak bands).

Both are invariant to multiplying the radiance by any positive factor. Band
radiance below zero (photon noise on a dark band) counts as 0.

Classifier: one-vs-all KNN (scikit-learn, `Pedregosa2011`). The reported
models are `OneVsRestClassifier(KNeighborsClassifier(k))` (`make_classifier`),
as in the thesis (one binary KNN per lamp type, the type with the highest
normalised score wins). With uniform weights every binary KNN sees the same k
neighbours, so its probability for class c is the fraction of neighbours of
class c; the inner-fold choice of k and the band searches use that identity
(`neighbour_labels` + `vote_proba`): one neighbour query serves every k of the
grid. A test checks that both give the same predictions.
"""

from collections.abc import Sequence

import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike, Float

from .estimate import log_ratio_features
from .names import validate_method


FEATURE_KINDS = ("log_ratio", "sum_normalised")


def resolve_kind(kind: str) -> str:
    """Canonical feature kind (case and separators ignored)."""
    return validate_method(kind, FEATURE_KINDS, "feature kind")


def features(
    radiance: Float[ArrayLike, "*batch b"], kind: str = "log_ratio"
) -> Float[Array, "*batch b"]:
    """Scale-free features of band radiances (see module docstring). [1]

    Works in JAX (differentiable; double-where at a dark pixel, whose
    features are all 0 / uniform).
    """
    kind = resolve_kind(kind)
    r = jnp.maximum(jnp.asarray(radiance), 0.0)
    if kind == "sum_normalised":
        total = jnp.sum(r, axis=-1, keepdims=True)
        ok = total > 0
        return jnp.where(ok, r / jnp.where(ok, total, 1.0), 1.0 / r.shape[-1])
    return log_ratio_features(r)


def macro_f1_int(y_true: np.ndarray, y_pred: np.ndarray, labels: np.ndarray) -> float:
    """Macro F1 over integer `labels` (fast path for searches): per class c,
    `2 TP / (2 TP + FP + FN)`, 0 when c is neither true nor predicted."""
    f = []
    for c in labels:
        t, p = y_true == c, y_pred == c
        tp = np.sum(t & p)
        d = np.sum(t) + np.sum(p)
        f.append(2.0 * tp / d if d else 0.0)
    return float(np.mean(f)) if f else 0.0


K_GRID: tuple[int, ...] = (1, 3, 5, 9, 15, 25)
"""Candidate k, chosen by macro F1 on the inner folds (ties: smaller k)."""


def make_classifier(k: int):
    """`OneVsRestClassifier(KNeighborsClassifier(n_neighbors=k))`, kd-tree."""
    # start-up time: scikit-learn takes ~1.4 s to import
    from sklearn.multiclass import OneVsRestClassifier
    from sklearn.neighbors import KNeighborsClassifier

    return OneVsRestClassifier(
        KNeighborsClassifier(n_neighbors=int(k), algorithm="kd_tree")
    )


def neighbour_labels(
    train_x: np.ndarray, train_y: np.ndarray, test_x: np.ndarray, k_max: int
) -> np.ndarray:
    """Integer labels of the `k_max` nearest training rows of every test row,
    nearest first, `(n_test, k_max)` (Euclidean, kd-tree).

    When every training row has the same features (a one-band sensor: its
    centred log ratio is 0 for every pixel), all training rows are equally
    near and the kd-tree degenerates to a full scan per query (minutes for
    the 1e5-row evaluation set). The tie is then broken evenly across classes
    instead of by tree order: every test row gets the same label sequence, the
    training labels interleaved so that the first `k` of them follow the
    class frequencies to within one vote."""
    # start-up time: scikit-learn takes ~1.4 s to import
    from sklearn.neighbors import NearestNeighbors

    k = min(int(k_max), len(train_x))
    train_x = np.asarray(train_x)
    if len(train_x) and np.all(train_x == train_x[:1]):
        y = np.asarray(train_y)
        _, inv, counts = np.unique(y, return_inverse=True, return_counts=True)
        order = np.argsort(inv, kind="stable")
        rank = np.empty(len(y))
        start = np.concatenate([[0], np.cumsum(counts)[:-1]])
        rank[order] = np.arange(len(y)) - np.repeat(start, counts)
        key = (rank + 0.5) / counts[inv]  # position within its class, in [0, 1)
        seq = y[np.lexsort((inv, key))][:k]
        return np.broadcast_to(seq, (len(test_x), k)).copy()
    nn = NearestNeighbors(n_neighbors=k, algorithm="kd_tree").fit(train_x)
    idx = nn.kneighbors(test_x, return_distance=False)
    return np.asarray(train_y)[idx]


def vote_proba(nbr: np.ndarray, k: int, n_classes: int) -> np.ndarray:
    """Fraction of the first `k` neighbours in each class, `(n, n_classes)`."""
    k = min(int(k), nbr.shape[1])
    out = np.zeros((nbr.shape[0], n_classes))
    rows = np.repeat(np.arange(nbr.shape[0]), k)
    np.add.at(out, (rows, nbr[:, :k].ravel()), 1.0)
    return out / k


def choose_k(
    x: np.ndarray,
    y: np.ndarray,
    lamp: np.ndarray,
    inner,
    n_classes: int,
    k_grid: Sequence[int] | np.ndarray = K_GRID,
    rows: np.ndarray | None = None,
) -> tuple[int, dict]:
    """k with the best mean inner-fold macro F1.

    `x (n, p)`, integer labels `y (n,)`, lamp of each row `lamp (n,)`,
    `inner`: (train lamps, validation lamps) pairs; `rows`: optional boolean
    mask of usable rows. Returns (k, {k: mean macro F1}).
    """
    rows = np.ones(len(y), bool) if rows is None else rows
    scores = {int(k): 0.0 for k in k_grid}
    for tr, va in inner:
        t = rows & np.isin(lamp, tr)
        v = rows & np.isin(lamp, va)
        nbr = neighbour_labels(x[t], y[t], x[v], max(k_grid))
        present = np.unique(y[v])
        for k in k_grid:
            pred = np.argmax(vote_proba(nbr, k, n_classes), axis=1)
            scores[int(k)] += macro_f1_int(y[v], pred, present) / len(inner)
    best = max(scores.items(), key=lambda kv: (round(kv[1], 12), -kv[0]))[0]
    return best, scores
