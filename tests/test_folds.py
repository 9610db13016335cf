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
