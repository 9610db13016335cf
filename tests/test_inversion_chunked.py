"""`Inversion.predict` in chunks of bounded memory: every chunk size gives the
unchunked prediction (each surface mode, the Moon fitted and told, several
band-error models, the cross-conformal flag), and the chunk size chosen from a
memory budget bounds the posterior-sized arrays a prediction makes (bytes
computed from their shapes, not measured)."""

import dataclasses

import numpy as np
import pytest

from bandopt import inversion as inv_mod
from tests._bands import FIVE, GRID
from tests._inversion import moonlit_scenarios, patch_inversion


N = 10
"""Pixels per test image: chunk sizes 1, 3, 4 and 7 leave a remainder."""

TOL = 1e-12
"""Chunked against unchunked: pixels are scored independently, so only the
rounding of compiled calls of other shapes may differ."""


@pytest.fixture(scope="module")
def fitted():
    """A small inversion (40 lamps, a moonless and a full-Moon state) with
    four band-error models, a finite threshold and two flag folds, and
    `N` pixels of its own lamps on asphalt and grass with their Moon."""
    lamps = inv_mod.library_lamps(GRID, scored=True).take(range(0, 200, 5))
    scen = moonlit_scenarios(lamps.ids[0])
    cond = inv_mod.Conditions.from_scenarios(scen)
    w = inv_mod.band_weights_on(FIVE, GRID)
    base = inv_mod.build_inversion(lamps, w, cond, inv_mod.surface_basis(GRID))
    rng = np.random.default_rng(0)
    folds = []
    for f in range(2):
        keep = np.arange(len(lamps.ids)) % 2 != f
        n_held = int((~keep).sum())
        folds.append(
            inv_mod.FlagFold(
                base.restricted(keep),
                rng.gamma(2.0, 1.0, n_held),
                np.ones(n_held),
                tuple(np.asarray(lamps.level2)[~keep]),
            )
        )
    inv = dataclasses.replace(
        base,
        sigma_rel=0.03,
        sigma_floor=0.003,
        metric_sigma=(0.01, 0.03, 0.03),
        metric_floor=(0.03, 0.001, 0.01),
        threshold=3.0,
        flag_noise=(0.01, 0.001),
        flag_folds=tuple(folds),
    )
    a, _ = inv.design
    mean_surface = np.eye(a.shape[-1])[0]  # basis coefficients of the mean
    y = np.einsum("kabr,r->kab", a[:N], mean_surface)[:, 0]
    y = y * rng.uniform(0.5, 2.0, (N, 1))
    moon = np.where(np.arange(N) % 3 == 0, np.nan, rng.uniform(0, 1, N))
    return inv, y * rng.normal(1.0, 0.02, y.shape), moon


def _same(got: inv_mod.InversionResult, want: inv_mod.InversionResult) -> None:
    for f in dataclasses.fields(want):
        g, w = getattr(got, f.name), getattr(want, f.name)
        if isinstance(w, np.ndarray) and w.dtype.kind == "f":
            np.testing.assert_allclose(g, w, rtol=TOL, atol=TOL, err_msg=f.name)
        elif isinstance(w, np.ndarray):
            np.testing.assert_array_equal(g, w, err_msg=f.name)
        else:
            assert g == w, f.name


SURFACES = {
    "unknown": lambda inv: None,
    "class": lambda inv: ["asphalt", "grass"] * (N // 2),
    "one class": lambda inv: ["grass"] * N,
    "measured": lambda inv: inv.basis.coords(
        inv.basis.mean[None] * np.linspace(0.8, 1.2, N)[:, None]
    ),
}


@pytest.mark.parametrize("surface", list(SURFACES))
@pytest.mark.parametrize("told", [False, True])
def test_every_chunk_size_gives_the_unchunked_prediction(fitted, surface, told):
    inv, y, moon = fitted
    mode = "measured" if surface == "measured" else surface.split()[-1]
    inv = dataclasses.replace(inv, surface_mode=mode)
    s = SURFACES[surface](inv)
    m = moon if told else None
    whole = inv.predict(y, s, m, chunk_pixels=N)
    assert len(whole.misfit) == N and np.isfinite(whole.estimate[:, :2]).all()
    for step in (1, 3, 4, 7, N + 5, None):
        _same(inv.predict(y, s, m, chunk_pixels=step), whole)
    parts = list(inv.predict_chunks(y, s, m, chunk_pixels=4))
    assert [i for i, _ in parts] == [0, 4, 8]
    _same(inv_mod.InversionResult.concatenate([r for _, r in parts]), whole)
    rows = [whole.row(i) for i in range(N)]
    assert rows == [inv.predict(y, s, m, chunk_pixels=3).row(i) for i in range(N)]


def test_one_pixel_chunks_of_a_shared_surface_score_as_the_image(fitted, monkeypatch):
    """A chunk of one pixel of an image whose pixels share their surface
    runs the shared path, as the whole image does (an unchunked single
    pixel runs the per-pixel path)."""
    inv, y, _ = fitted
    seen = []
    real = inv_mod._score

    def spy(*args, shared=None, **kw):
        seen.append(shared)
        return real(*args, shared=shared, **kw)

    patch_inversion(monkeypatch, "_score", spy)
    inv.predict(y[:3], chunk_pixels=1)
    assert seen and all(s is True for s in seen)
    seen.clear()
    inv.predict(y[:1])
    assert seen and all(s is None for s in seen)
    seen.clear()
    inv_c = dataclasses.replace(inv, surface_mode="class")
    inv_c.predict(y[:3], ["asphalt", "grass", "asphalt"], chunk_pixels=1)
    assert seen and all(s is False for s in seen)


@pytest.mark.parametrize("budget_mib", [0.2, 1.4, 1.6, 7.0])
def test_the_budgets_chunk_bounds_the_posterior_arrays(fitted, monkeypatch, budget_mib):
    """The chunk size from a budget is the largest whose analytic bound fits,
    and every scoring and normalisation in the prediction (the flag folds'
    too) makes arrays within that bound: twice the scored log weights as
    returned (their padded concatenation), three times the unpadded ones."""
    inv, y, moon = fitted
    y = np.tile(y, (6, 1))
    budget = int(budget_mib * 2**20)
    k, s = len(inv.prior.ids), 5  # joint, flag and three metrics' noise models
    assert len(inv._predict_noise()) == s
    step = inv.predict_chunk_pixels(budget)
    assert step == inv_mod.predict_chunk_pixels(k, s, budget) >= 1
    bound = inv_mod.predict_chunk_bytes(k, s, step)
    if step > 1:
        assert bound <= budget < inv_mod.predict_chunk_bytes(k, s, step + 1)
    made = []
    real = inv_mod._score

    def spy(*args, **kw):
        lk, chi = real(*args, **kw)
        padded = lk if lk.base is None else lk.base
        made.append((lk.shape[0], 2 * padded.nbytes + 3 * lk.nbytes))
        return lk, chi

    patch_inversion(monkeypatch, "_score", spy)
    inv.predict(y, None, np.tile(moon, 6), memory_bytes=budget)
    assert made and max(n for n, _ in made) == min(step, len(y))
    assert all(b <= inv_mod.predict_chunk_bytes(k, s, n) <= bound for n, b in made)


def test_concatenation_and_bad_chunks_are_refused(fitted):
    inv, y, _ = fitted
    with pytest.raises(ValueError, match="chunk_pixels must be >= 1"):
        inv.predict(y, chunk_pixels=0)
    with pytest.raises(ValueError, match="moon: 3 entries for 10 pixels"):
        inv.predict(y, None, np.zeros(3), chunk_pixels=2)
    with pytest.raises(ValueError, match="memory_bytes must be > 0"):
        inv_mod.predict_chunk_pixels(10, 1, 0)
    with pytest.raises(ValueError, match="need at least one"):
        inv_mod.InversionResult.concatenate([])
    part = inv.predict(y[:2])
    other = dataclasses.replace(part, level1_labels=part.level1_labels[::-1])
    with pytest.raises(ValueError, match="different inversions"):
        inv_mod.InversionResult.concatenate([part, other])


@pytest.mark.parametrize("surface", ["unknown", "class"])
@pytest.mark.parametrize("told", [False, True])
def test_float32_scoring_stays_within_its_stated_tolerance(fitted, surface, told):
    """float32 scoring (shared and per-pixel paths, Moon fitted and told)
    moves posteriors, type probabilities, estimates and intervals by no more
    than `FLOAT32_TOLERANCE` from float64, calls the same types, and keeps
    the estimates' NaN pattern (CCT where it is not meaningful)."""
    inv, y, moon = fitted
    inv = dataclasses.replace(inv, surface_mode=surface)
    s = SURFACES[surface](inv)
    m = moon if told else None
    tol = inv_mod.FLOAT32_TOLERANCE
    r64 = inv.predict(y, s, m)
    r32 = inv.predict(y, s, m, dtype="float32")
    for name in ("level1_probabilities", "level2_probabilities", "cct_probability"):
        d = np.abs(getattr(r32, name) - getattr(r64, name))
        assert d.max() <= tol["type_probability"], name
    assert r32.level1 == r64.level1 and r32.level2 == r64.level2
    np.testing.assert_array_equal(np.isnan(r32.estimate), np.isnan(r64.estimate))
    ok = np.isfinite(r64.estimate)
    np.testing.assert_allclose(
        r32.estimate[ok], r64.estimate[ok], rtol=tol["estimate_rel"]
    )
    ok = np.isfinite(r64.interval90)
    np.testing.assert_allclose(
        r32.interval90[ok], r64.interval90[ok], rtol=tol["interval_rel"]
    )
    noise = inv._predict_noise()
    sig, fl = [x[0] for x in noise], [x[1] for x in noise]
    p64, _ = inv.posterior(y, s, sig, moon=m, floors=fl)
    p32, _ = inv.posterior(y, s, sig, moon=m, floors=fl, dtype=np.float32)
    assert np.abs(p32 - p64).max() <= tol["posterior"]
    assert np.abs(p32 - p64).max() > 0  # float32 did run


def test_an_unknown_scoring_dtype_is_refused(fitted):
    inv, y, _ = fitted
    with pytest.raises(ValueError, match="dtype 'float16': expected one of"):
        inv.predict(y, dtype="float16")
