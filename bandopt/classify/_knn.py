"""One-vs-all k-nearest-neighbour classification (scikit-learn, `Pedregosa2011`),
k chosen by inner cross-validation, and a reject option.

The reported models are `OneVsRestClassifier(KNeighborsClassifier(k))`
(`make_classifier`), as in the thesis (one binary KNN per lamp type, the type
with the highest normalised score wins). With uniform weights every binary
KNN sees the same k neighbours, so its probability for class c is the
fraction of neighbours of class c; the inner-fold choice of k and the band
search use that identity (`neighbour_labels` + `vote_proba`): one neighbour
query serves every k of the grid. A test checks that both give the same
predictions.
"""

from collections.abc import Sequence

import numpy as np

from ._metrics import macro_f1_int


K_GRID: tuple[int, ...] = (1, 3, 5, 9, 15, 25)
"""Candidate k, chosen by macro F1 on the inner folds (ties: smaller k)."""

REJECT_THRESHOLD = 0.6
"""Default confidence below which a prediction is "unknown": the winning
class holds less than 60 % of the (normalised) one-vs-all votes. [1]"""


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
