"""Lamp-grouped, class-stratified cross-validation and lamp-level bootstrap.

Lamps, not scenarios, are the unit of generalisation: every split assigns
whole lamps to a side, so a lamp's scenarios (surfaces, atmospheres, Moon,
classes) never sit on both sides. Splits are stratified by level-2 class:
within each class the lamps are shuffled (seeded) and dealt round-robin to
the folds, starting at a random fold, so every fold gets ⌊n/k⌋ or ⌈n/k⌉ lamps
of every class. Model choices are made on the inner folds of an outer
training set; outer test folds give the reported errors.
"""

import dataclasses
from collections.abc import Sequence

import numpy as np


Labels = Sequence[str] | np.ndarray
"""Class labels, one per lamp."""

N_OUTER_FOLDS = 3
"""Outer folds of every nested split in bandopt (search, classification,
radiometry): each scored lamp is tested once, on a third of the lamps."""
N_INNER_FOLDS = 2
"""Inner folds (model choices) within each outer training set."""


def stratified_lamp_folds(classes: Labels, n_folds: int, seed: int) -> list[np.ndarray]:
    """Deal lamps (indices into `classes`) into `n_folds` test folds, stratified
    by class. Returns the sorted lamp indices of each fold."""
    classes = np.asarray(classes, dtype=object)
    if n_folds < 2:
        raise ValueError(f"n_folds must be >= 2, got {n_folds}.")
    if len(classes) < n_folds:
        raise ValueError(f"{len(classes)} lamps cannot fill {n_folds} folds.")
    rng = np.random.default_rng(seed)
    folds: list[list[int]] = [[] for _ in range(n_folds)]
    offset = 0
    for c in sorted(set(classes.tolist())):
        members = np.flatnonzero(classes == c)
        rng.shuffle(members)
        for j, lamp in enumerate(members):
            folds[(offset + j) % n_folds].append(int(lamp))
        offset = (offset + len(members)) % n_folds  # balance fold sizes across classes
    return [np.sort(np.asarray(f, dtype=int)) for f in folds]


@dataclasses.dataclass(frozen=True)
class NestedSplit:
    """One outer fold: `train` and `test` lamp indices, and the inner
    (train, validation) splits of `train` for model choices."""

    outer: int
    train: np.ndarray
    test: np.ndarray
    inner: tuple[tuple[np.ndarray, np.ndarray], ...]


def nested_lamp_splits(
    classes: Labels,
    *,
    n_outer: int = N_OUTER_FOLDS,
    n_inner: int = N_INNER_FOLDS,
    seed: int = 0,
) -> list[NestedSplit]:
    """Nested lamp-grouped, class-stratified splits (indices into `classes`).

    With the smallest scored classes holding 3 lamps, 3 outer x 2 inner folds
    keep at least one lamp of every class on each side of every split.
    """
    classes = np.asarray(classes, dtype=object)
    out = []
    for k, test in enumerate(stratified_lamp_folds(classes, n_outer, seed)):
        train = np.setdiff1d(np.arange(len(classes)), test)
        inner_folds = stratified_lamp_folds(classes[train], n_inner, seed + 1000 + k)
        inner = tuple(
            (np.setdiff1d(train, train[v]), np.sort(train[v])) for v in inner_folds
        )
        out.append(NestedSplit(k, train, test, inner))
    return out


@dataclasses.dataclass(frozen=True, eq=False)
class Folds(Sequence):
    """The nested lamp splits of one scenario table: a sequence of
    `NestedSplit` (outer fold k at index k) with the rule that made them.

    - `splits`: the outer folds, each with its inner (train, validation) splits.
    - `seed`, `n_outer`, `n_inner`: `nested_lamp_splits`'s arguments.
    """

    splits: tuple[NestedSplit, ...]
    seed: int
    n_outer: int
    n_inner: int

    def __getitem__(self, k):
        return self.splits[k]

    def __len__(self) -> int:
        return len(self.splits)

    def outer(self) -> list[tuple[np.ndarray, np.ndarray]]:
        """(train, test) lamp indices of every outer fold."""
        return [(s.train, s.test) for s in self.splits]


def lamp_folds(
    classes: Labels,
    *,
    n_outer: int = N_OUTER_FOLDS,
    n_inner: int = N_INNER_FOLDS,
    seed: int = 0,
) -> Folds:
    """`nested_lamp_splits` as a typed `Folds` record."""
    splits = nested_lamp_splits(classes, n_outer=n_outer, n_inner=n_inner, seed=seed)
    return Folds(tuple(splits), seed, n_outer, n_inner)


def class_balanced_weights(classes: Labels) -> np.ndarray:
    """Per-item weights so every class weighs the same and weights sum to 1."""
    classes = np.asarray(classes, dtype=object)
    uniq, inv, counts = np.unique(classes, return_inverse=True, return_counts=True)
    return 1.0 / (len(uniq) * counts[inv])


def class_balanced_mae(abs_errors: np.ndarray, classes: Labels) -> float:
    """Mean over classes of the mean absolute error within each class."""
    w = class_balanced_weights(classes)
    return float(np.sum(w * np.asarray(abs_errors)))


def lamp_bootstrap_ci(
    lamp_abs_errors: np.ndarray,
    lamp_classes: Labels,
    *,
    n_boot: int = 2000,
    level: float = 0.95,
    seed: int = 0,
) -> tuple[float, float, float]:
    """Class-balanced MAE and its percentile bootstrap interval, resampling
    lamps with replacement within each class (lamp-level bootstrap).

    `lamp_abs_errors` is one mean absolute error per lamp (over its scenarios).
    Returns (estimate, lower, upper).
    """
    err = np.asarray(lamp_abs_errors, float)
    classes = np.asarray(lamp_classes, dtype=object)
    if err.shape != classes.shape:
        raise ValueError("lamp_abs_errors and lamp_classes differ in length.")
    groups = [np.flatnonzero(classes == c) for c in sorted(set(classes.tolist()))]
    rng = np.random.default_rng(seed)
    stats = np.empty(n_boot)
    for i in range(n_boot):
        stats[i] = np.mean([err[rng.choice(g, size=g.size)].mean() for g in groups])
    est = float(np.mean([err[g].mean() for g in groups]))
    a = (1 - level) / 2
    return est, float(np.quantile(stats, a)), float(np.quantile(stats, 1 - a))


def paired_lamp_ci(
    values: Sequence[float] | np.ndarray,
    lamps: Labels,
    classes: Labels,
    groups: Sequence | np.ndarray | None = None,
    *,
    n_boot: int = 2000,
    level: float = 0.95,
    seed: int = 0,
) -> tuple[float, float, float]:
    """A study's class-balanced mean and its percentile bootstrap interval,
    lamps resampled with replacement within each class.

    One value per observation: `values[i]` belongs to lamp `lamps[i]` of
    level-2 class `classes[i]`, scored in group `groups[i]` (a lamp
    partition; None: one group). The statistic is the one the studies
    report: per group the mean over classes of the mean within each class
    (over the observations of that group), then the mean over groups. A
    bootstrap draw weighs each observation by how often its lamp was drawn
    (a class without a drawn lamp in a group drops out of that group's
    mean), so lamps, not observations, are the unit.

    Meant for paired differences: each value ours-minus-theirs on the same
    lamp, so the interval is of the paired difference, as `compare.json`'s
    reductions are. Vectorised over draws (multinomial counts per class).
    Returns (estimate, lower, upper); the estimate is the statistic on the
    data as they are. Non-finite values, empty input, mismatched lengths and
    a lamp with two classes are refused."""
    v = np.asarray(values, float)
    lamp = np.asarray(lamps, dtype=object)
    cls = np.asarray(classes, dtype=object)
    grp = np.zeros(v.shape, int) if groups is None else np.asarray(groups)
    if v.ndim != 1 or not (v.shape == lamp.shape == cls.shape == grp.shape):
        raise ValueError(
            f"values {v.shape}, lamps {lamp.shape}, classes {cls.shape} and "
            f"groups {grp.shape} must be one per observation."
        )
    if v.size == 0:
        raise ValueError("no observations: a bootstrap interval needs a lamp.")
    if not np.all(np.isfinite(v)):
        raise ValueError(
            "values are not all finite: a paired difference is "
            "undefined for a lamp; leave that lamp out."
        )
    ids, at = np.unique(lamp.astype(str), return_inverse=True)
    lamp_class = {}
    for i, c in zip(at.tolist(), cls.tolist(), strict=True):
        if lamp_class.setdefault(i, c) != c:
            raise ValueError(
                f"lamp {ids[i]!r} has two classes, {lamp_class[i]!r} and {c!r}."
            )
    rng = np.random.default_rng(seed)
    counts = np.ones((n_boot + 1, ids.size))  # row 0: the data as they are
    for c in sorted(set(lamp_class.values())):
        members = np.asarray([i for i, k in lamp_class.items() if k == c])
        counts[1:, members] = rng.multinomial(
            members.size, np.full(members.size, 1.0 / members.size), size=n_boot
        )
    per_group = []
    for g in np.unique(grp):
        num, den = [], []
        for c in sorted(set(cls[grp == g].tolist())):
            m = (grp == g) & (cls == c)
            w = counts[:, at[m]]
            num.append(w @ v[m])
            den.append(w.sum(axis=1))
        num, den = np.asarray(num), np.asarray(den)
        present = den > 0
        means = np.where(present, num / np.where(present, den, 1.0), 0.0)
        per_group.append(means.sum(axis=0) / np.maximum(present.sum(axis=0), 1))
    stats = np.mean(per_group, axis=0)
    a = (1 - level) / 2
    lo, hi = np.quantile(stats[1:], [a, 1 - a])
    return float(stats[0]), float(lo), float(hi)
