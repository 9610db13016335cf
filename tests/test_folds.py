"""Lamp-grouped, stratified folds and the lamp-level bootstrap."""

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from bandopt.folds import (
    class_balanced_mae,
    class_balanced_weights,
    lamp_bootstrap_ci,
    nested_lamp_splits,
    stratified_lamp_folds,
)


_classes = st.lists(st.sampled_from(["a", "b", "c", "d"]), min_size=6, max_size=60)


@settings(deadline=None, max_examples=40)
@given(classes=_classes, k=st.integers(2, 5), seed=st.integers(0, 10))
def test_folds_partition_and_stratify(classes, k, seed):
    if len(classes) < k:
        return
    folds = stratified_lamp_folds(classes, k, seed)
    allidx = np.concatenate(folds)
    assert sorted(allidx.tolist()) == list(range(len(classes)))  # a partition
    arr = np.asarray(classes)
    for c in set(classes):
        per_fold = [np.sum(arr[f] == c) for f in folds]
        assert max(per_fold) - min(per_fold) <= 1  # stratified


def test_nested_splits_never_share_lamps():
    classes = ["hps"] * 3 + ["led_warm"] * 9 + ["mercury"] * 3 + ["fl"] * 20
    for s in nested_lamp_splits(classes, n_outer=3, n_inner=2, seed=1):
        assert not set(s.train) & set(s.test)
        assert len(s.train) + len(s.test) == len(classes)
        for tr, va in s.inner:
            assert not set(tr) & set(va) and set(tr) | set(va) == set(s.train)
            assert not set(va) & set(s.test)
        # every class of 3 lamps has one test lamp in each of 3 outer folds
        assert sum(classes[i] == "hps" for i in s.test) == 1


def test_reproducible_with_seed():
    classes = ["a"] * 7 + ["b"] * 5
    a = stratified_lamp_folds(classes, 3, 4)
    b = stratified_lamp_folds(classes, 3, 4)
    c = stratified_lamp_folds(classes, 3, 5)
    assert all(np.array_equal(x, y) for x, y in zip(a, b, strict=True))
    assert not all(np.array_equal(x, y) for x, y in zip(a, c, strict=True))


def test_class_balance():
    classes = ["a"] * 9 + ["b"]
    w = class_balanced_weights(classes)
    assert w.sum() == pytest.approx(1.0)
    assert w[-1] == pytest.approx(0.5)
    err = np.r_[np.ones(9), 3.0]
    assert class_balanced_mae(err, classes) == pytest.approx(2.0)


def test_bootstrap_interval_contains_estimate_and_shrinks():
    rng = np.random.default_rng(0)
    classes = np.repeat(["a", "b"], 50)
    err = rng.exponential(1.0, 100)
    est, lo, hi = lamp_bootstrap_ci(err, classes, n_boot=500)
    assert lo <= est <= hi
    _, lo2, hi2 = lamp_bootstrap_ci(np.tile(err, 4), np.tile(classes, 4), n_boot=500)
    assert hi2 - lo2 < hi - lo
    with pytest.raises(ValueError, match="differ"):
        lamp_bootstrap_ci(err[:3], classes)


def test_lamp_folds_is_the_nested_splits_as_a_record():
    """`lamp_folds` holds exactly `nested_lamp_splits`'s folds, indexable and
    iterable like them, with the rule that made them and the outer pairs."""
    from bandopt.folds import Folds, lamp_folds

    classes = ["a"] * 7 + ["b"] * 5 + ["c"] * 3
    folds = lamp_folds(classes, n_outer=3, n_inner=2, seed=4)
    plain = nested_lamp_splits(classes, n_outer=3, n_inner=2, seed=4)
    assert isinstance(folds, Folds) and len(folds) == len(plain) == 3
    assert (folds.seed, folds.n_outer, folds.n_inner) == (4, 3, 2)
    for k, (mine, theirs) in enumerate(zip(folds, plain, strict=True)):
        assert folds[k] is mine and mine.outer == theirs.outer == k
        np.testing.assert_array_equal(mine.test, theirs.test)
        train, test = folds.outer()[k]
        np.testing.assert_array_equal(train, theirs.train)
        np.testing.assert_array_equal(test, theirs.test)
    other = lamp_folds(classes, n_outer=3, n_inner=2, seed=5)
    assert not all(
        np.array_equal(a.test, b.test) for a, b in zip(folds, other, strict=True)
    )


def test_paired_lamp_interval_resamples_lamps_of_the_studies_statistic():
    """`paired_lamp_ci`: with one group and one value per lamp, the class-
    balanced mean with the interval of `lamp_bootstrap_ci` (the same
    resampling within class, drawn as multinomial counts); with partitions,
    the estimate is the studies' statistic (per partition class-balanced,
    then the mean over partitions) and a lamp scored in two partitions is
    one unit; a shift of every value by the same amount has an interval of
    zero width; bad input is refused."""
    from bandopt.folds import paired_lamp_ci

    rng = np.random.default_rng(1)
    classes = np.repeat(["a", "b", "c"], [40, 12, 5])
    lamps = [f"L{i}" for i in range(classes.size)]
    d = rng.normal(0.3, 1.0, classes.size)
    est, lo, hi = paired_lamp_ci(d, lamps, classes, n_boot=4000)
    ref, rlo, rhi = lamp_bootstrap_ci(d, classes, n_boot=4000, seed=3)
    assert est == pytest.approx(ref)
    assert lo == pytest.approx(rlo, abs=0.05) and hi == pytest.approx(rhi, abs=0.05)
    assert lo < est < hi
    # two partitions scoring overlapping, unequal lamp sets
    part = rng.integers(0, 2, classes.size)
    extra = np.flatnonzero(part == 0)[:7]  # these lamps are also in partition 1
    v = np.r_[d, d[extra] + 1.0]
    lp = np.r_[lamps, np.asarray(lamps)[extra]]
    cp = np.r_[classes, classes[extra]]
    gp = np.r_[part, np.ones(extra.size, int)]
    est2, lo2, hi2 = paired_lamp_ci(v, lp, cp, gp)
    want = np.mean([
        np.mean([v[(gp == g) & (cp == c)].mean() for c in sorted(set(cp[gp == g]))])
        for g in (0, 1)
    ])  # fmt: skip
    assert est2 == pytest.approx(want) and lo2 < est2 < hi2
    same = paired_lamp_ci(np.full(9, -2.5), list("abcdefghi"), ["x"] * 9)
    assert same == pytest.approx((-2.5,) * 3)
    with pytest.raises(ValueError, match="finite"):
        paired_lamp_ci(np.r_[d[:-1], np.nan], lamps, classes)
    with pytest.raises(ValueError, match="one per observation"):
        paired_lamp_ci(d[:3], lamps, classes)
    with pytest.raises(ValueError, match="two classes"):
        paired_lamp_ci([1.0, 2.0], ["L1", "L1"], ["a", "b"], [0, 1])
