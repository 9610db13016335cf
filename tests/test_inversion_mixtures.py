"""Pairwise same-class mixtures of prior lamps (`mixture_lamps`,
`fit_inversion(mixtures=)`, estimator `inversion-moon-mix`): what they are
(convex blends per lumen of two lamps of one class, whose LER is the
flux-weighted harmonic mean of the pair's), that they come from the prior's
own lamps only, and that a new lamp lying between two training lamps is
found by a prior with mixtures and missed by one without."""

import numpy as np
import pytest

from bandopt import inversion as inv_mod
from bandopt.estimate import lamp_truth
from bandopt.photometry import ler
from tests._bands import GRID
from tests._inversion import patch_inversion
from tests.test_inversion_models import _case, _pixels


@pytest.fixture(scope="module")
def case():
    return _case()


def test_counts_ids_and_classes(case):
    lamps = case[0]
    mix = inv_mod.mixture_lamps(lamps, 2, fractions=(0.25, 0.5))
    l2 = np.asarray(lamps.level2, object)
    for c in sorted(set(l2)):
        n = int((l2 == c).sum())
        pairs = min(n * (n - 1) // 2, 2)
        assert sum(x == c for x in mix.level2) == 2 * pairs
    for i, l1, l2m in zip(mix.ids, mix.level1, mix.level2, strict=True):
        a, b = i[4:].rsplit("@", 1)[0].split("+")
        ia, ib = lamps.ids.index(a), lamps.ids.index(b)
        assert lamps.level2[ia] == lamps.level2[ib] == l2m  # same class only
        assert lamps.level1[ia] == l1
    # seeded: the same draw twice, another seed another draw
    again = inv_mod.mixture_lamps(lamps, 2, fractions=(0.25, 0.5))
    assert again.ids == mix.ids
    other = [inv_mod.mixture_lamps(lamps, 2, seed=s).ids for s in range(1, 6)]
    assert any(o != inv_mod.mixture_lamps(lamps, 2).ids for o in other)


def test_one_lamp_classes_get_none_and_bad_arguments_fail(case):
    lamps = case[0]
    one = lamps.take([0])
    assert inv_mod.mixture_lamps(one).ids == ()
    assert inv_mod.mixture_lamps(one).spectra.shape == (0, GRID.size)
    with pytest.raises(ValueError, match="fractions"):
        inv_mod.mixture_lamps(lamps, fractions=(0.0, 0.5))
    with pytest.raises(ValueError, match="max_pairs"):
        inv_mod.mixture_lamps(lamps, -1)
    with pytest.raises(ValueError, match="mixtures"):
        inv_mod.fit_inversion(
            *case[2:3], case[1], lamps, case[3], case[5], case[6],
            inv_mod.Conditions.clear(GRID), mixtures=-1,
        )  # fmt: skip


def test_mixture_is_a_per_lumen_blend_with_the_harmonic_ler(case):
    """One lumen of a blend holds f lumen of lamp i and 1-f of lamp j, so its
    radiant power is f/LER_i + (1-f)/LER_j: LER_mix is their flux-weighted
    harmonic mean (computed here independently, with `bandopt.photometry`)."""
    lamps = case[0]
    mix = inv_mod.mixture_lamps(lamps, 3)
    truth, valid = lamp_truth(mix.spectra, GRID)
    for k, i in enumerate(mix.ids):
        pair, f = i[4:].rsplit("@", 1)
        a, b = (lamps.ids.index(x) for x in pair.split("+"))
        f = float(f)
        np.testing.assert_allclose(
            mix.spectra[k], f * lamps.spectra[a] + (1 - f) * lamps.spectra[b]
        )
        la, lb = (float(ler(lamps.spectra[x], GRID)) for x in (a, b))
        lm = float(ler(mix.spectra[k], GRID))
        np.testing.assert_allclose(lm, 1.0 / (f / la + (1 - f) / lb), rtol=1e-9)
        assert min(la, lb) - 1e-9 <= lm <= max(la, lb) + 1e-9
        assert valid[k, 0] and truth[k, 0] == pytest.approx(lm, rel=1e-9)


def _between_case(case):
    """Three lamps of one class: the test lamp is the 50/50 blend of the two
    training lamps' spectra, seen on asphalt and grass at two illuminances."""
    lamps = case[0]
    l2 = np.asarray(lamps.level2, object)
    warm = np.flatnonzero(l2 == "led_warm")[:2]
    others = np.flatnonzero(l2 != "led_warm")
    base = lamps.take(np.concatenate([warm, others]))
    blend = 0.5 * base.spectra[0] + 0.5 * base.spectra[1]
    lamps = base + inv_mod.LampSet(("blend",), blend[None], ("led",), ("led_warm",))
    return (lamps, *_pixels(lamps))


def test_a_lamp_between_two_training_lamps_is_found_with_mixtures(case):
    lamps, row_lamp, rad, w = _between_case(case)
    test = len(lamps.ids) - 1
    train = np.arange(test)
    cond = inv_mod.Conditions.clear(GRID)
    basis = inv_mod._basis(GRID)
    truth, _ = lamp_truth(lamps.spectra[test:], GRID)
    rows = row_lamp == test
    errs = {}
    for n in (0, 1):
        inv = inv_mod.build_inversion(
            lamps.take(train), w, cond, basis, "unknown", 0.003
        )
        if n:
            mix = inv_mod.mixture_lamps(lamps.take(train), 50)
            assert any(i.startswith("mix:") and "@0.5" in i for i in mix.ids)
            inv = inv_mod.build_inversion(
                lamps.take(train) + mix, w, cond, basis, "unknown", 0.003
            )
        est = inv.predict(rad[rows]).estimate
        errs[n] = np.abs(est[:, 0] - truth[0, 0]).mean()
    assert errs[1] < 0.2 * errs[0]
    assert errs[1] < 1.0  # lm/W


def spy_priors(monkeypatch) -> list:
    """Patch `build_inversion` to record the lamp ids of every prior built
    (then build it as before); returns the list it appends to."""
    built = []
    real = inv_mod.build_inversion

    def spy(pset, *a, **k):
        built.append(pset.ids)
        return real(pset, *a, **k)

    patch_inversion(monkeypatch, "build_inversion", spy)
    return built


def test_fit_builds_mixtures_from_its_own_priors_only(case, monkeypatch):
    """Every prior the fit builds (inner folds, final) holds mixtures of its
    own lamps only (an inner prior with one lamp per class has none): no
    inner-validation or test lamp is in any of them, and the diagnostics say
    how many the final prior holds."""
    lamps, row_lamp, rad, train, test, inner, w = case
    built = spy_priors(monkeypatch)
    inv = inv_mod.fit_inversion(
        rad, row_lamp, lamps, train, inner, w, inv_mod.Conditions.clear(GRID),
        basis=inv_mod._basis(GRID), mixtures=5,
    )  # fmt: skip
    assert len(built) == len(inner) + 1
    for ids, allowed in zip(built, [tr for tr, _ in inner] + [train], strict=True):
        ok = {lamps.ids[i] for i in allowed}
        parts = {
            p for i in ids if i.startswith("mix:")
            for p in i[4:].rsplit("@", 1)[0].split("+")
        }  # fmt: skip
        assert parts <= ok
    assert any(i.startswith("mix:") for i in built[-1])
    d = inv.diagnostics["mixtures"]
    assert d["max_pairs_per_class"] == 5
    assert d["n"] == sum(i.startswith("mix:") for i in inv.prior.ids) > 0
    # the scored-lamp guard catches a mixture made of a test lamp
    inv_mod._check_never_scored(inv, [lamps.ids[i] for i in test])
    with pytest.raises(RuntimeError, match="mixtures of scored lamps"):
        inv_mod._check_never_scored(inv, [lamps.ids[train[0]]])


def test_large_priors_score_in_smaller_chunks_with_the_same_numbers(case):
    """`_chunk` shrinks the pixels per call for large priors; the scores do
    not depend on it."""
    assert inv_mod._chunk(64, 224) == 64
    assert inv_mod._chunk(256, 3000) < 256
    assert inv_mod._chunk(64, 10**6) == 8
    lamps, _row_lamp, rad, train, *_rest, w = case
    inv = inv_mod.build_inversion(
        lamps.take(train), w, inv_mod.Conditions.clear(GRID), inv_mod._basis(GRID)
    )
    ref = inv.posterior(rad[:40])[0]
    with pytest.MonkeyPatch.context() as mp:
        patch_inversion(mp, "CHUNK_PRIOR", 1)
        small = inv.posterior(rad[:40])[0]
    np.testing.assert_allclose(small, ref, rtol=1e-10, atol=1e-14)


def test_cross_type_blends_are_named_by_their_majority_lamp(case):
    """`cross_mixture_lamps`: per ordered class pair `pairs` lamp pairs of
    two different classes, each at every minority share, a per-lumen blend
    whose level-1/-2 classes are the majority lamp's; seeded; bad arguments
    refused."""
    lamps = case[0]
    shares = (0.1, 0.4)
    x = inv_mod.cross_mixture_lamps(lamps, 2, shares=shares)
    l2 = np.asarray(lamps.level2, object)
    classes = sorted(set(l2))
    n = {c: int((l2 == c).sum()) for c in classes}
    expected = sum(
        min(2, n[c] * n[d]) for c in classes for d in classes if c != d
    ) * len(shares)
    assert len(x.ids) == expected == x.spectra.shape[0]
    for k, i in enumerate(x.ids):
        assert i.startswith("xmix:")
        pair, s = i[5:].rsplit("@", 1)
        a, b = (lamps.ids.index(p) for p in pair.split("+"))
        assert lamps.level2[a] != lamps.level2[b]
        assert (x.level1[k], x.level2[k]) == (lamps.level1[a], lamps.level2[a])
        s = float(s)
        assert s in shares
        np.testing.assert_allclose(
            x.spectra[k], (1 - s) * lamps.spectra[a] + s * lamps.spectra[b]
        )
        la, lb = (float(ler(lamps.spectra[j], GRID)) for j in (a, b))
        lm = float(ler(x.spectra[k], GRID))  # one lumen: (1-s) of a, s of b
        np.testing.assert_allclose(lm, 1.0 / ((1 - s) / la + s / lb), rtol=1e-9)
    assert inv_mod.cross_mixture_lamps(lamps, 2, shares=shares).ids == x.ids
    assert inv_mod.cross_mixture_lamps(lamps, 0).ids == ()
    with pytest.raises(ValueError, match="shares"):
        inv_mod.cross_mixture_lamps(lamps, 1, shares=(0.5,))
    with pytest.raises(ValueError, match="pairs"):
        inv_mod.cross_mixture_lamps(lamps, -1)


def test_fit_builds_cross_type_blends_from_its_own_priors_only(case, monkeypatch):
    lamps, row_lamp, rad, train, test, inner, w = case
    built = spy_priors(monkeypatch)
    inv = inv_mod.fit_inversion(
        rad, row_lamp, lamps, train, inner, w, inv_mod.Conditions.clear(GRID),
        basis=inv_mod._basis(GRID), cross_mixtures=1,
    )  # fmt: skip
    for ids, allowed in zip(built, [tr for tr, _ in inner] + [train], strict=True):
        ok = {lamps.ids[i] for i in allowed}
        parts = {
            p for i in ids if i.startswith("xmix:")
            for p in i[5:].rsplit("@", 1)[0].split("+")
        }  # fmt: skip
        assert parts and parts <= ok
    d = inv.diagnostics["cross_mixtures"]
    assert d["pairs_per_class_pair"] == 1
    assert d["n"] == sum(i.startswith("xmix:") for i in inv.prior.ids) > 0
    inv_mod._check_never_scored(inv, [lamps.ids[i] for i in test])
    with pytest.raises(RuntimeError, match="mixtures of scored lamps"):
        inv_mod._check_never_scored(inv, [lamps.ids[train[0]]])
    with pytest.raises(ValueError, match="cross_mixtures"):
        inv_mod.fit_inversion(
            rad, row_lamp, lamps, train, inner, w, inv_mod.Conditions.clear(GRID),
            cross_mixtures=-1,
        )  # fmt: skip
