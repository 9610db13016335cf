"""Stability study: the batched loss equals the single-split loss, test lamps
never reach the search, float32 agreement, stated rules (band count, Pareto
knee, medoid), tolerance perturbations, resumable and Dask-run study tasks."""

import json

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import pytest

from bandopt.estimate import LampTable
from bandopt.search import Space, make_problem
from bandopt.search._analysis import band_count_choice, knee, pareto_mask
from bandopt.search._stability import (
    angle_from_unit,
    batched_loss,
    batched_search,
    design_terms,
    distinct_starts,
    lamp_resamples,
    make_batch_data,
    medoid,
    overlap_matrix,
    unit_from_angle,
)
from bandopt.search._tolerance import AOI_N_EFF, perturbed_bands
from bandopt.sensor import BandSet, slit_super_gaussian


@pytest.fixture(scope="module")
def synth():
    """Smooth random spectra (5 nm grid), 30 lamps of 3 classes, 2 scenes each;
    truth depends on band ratios so the loss has structure."""
    rng = np.random.default_rng(3)
    wl = np.arange(380.0, 901.0, 5.0)
    n_lamps, q = 30, 2
    basis = np.exp(
        -0.5 * ((wl[None, :] - np.linspace(380, 900, 8)[:, None]) / 60.0) ** 2
    )
    coef = rng.uniform(0.05, 1.0, size=(n_lamps, 8))
    toa = np.stack([coef @ basis, 2.0 * (coef @ basis)], 1)  # (l, q, w)
    truth = np.column_stack(
        [
            100 + 40 * np.log(coef[:, 3] / coef[:, 6]),
            0.5 + 0.2 * coef[:, 1],
            2500 + 2000 * coef[:, 2],
        ]
    )
    classes = np.array(["a", "b", "c"] * (n_lamps // 3), dtype=object)
    valid = np.ones_like(truth, bool)
    valid[[1, 7, 20], 2] = False  # CCT not meaningful for three lamps
    truth[~valid] = np.nan
    table = LampTable(np.repeat(np.arange(n_lamps), q), classes, truth, valid)
    res = lamp_resamples(classes, 2, seed=0)
    return {"wl": wl, "toa": toa, "table": table, "res": res}


def test_resamples_are_grouped_and_partition_the_lamps(synth):
    res = synth["res"]
    assert len(res) == 6
    for p in (0, 1):
        tests = np.concatenate([r.test for r in res if r.partition == p])
        assert np.array_equal(np.sort(tests), np.arange(30))
    for r in res:
        assert not set(r.train) & set(r.test)
        for tr, va in r.inner:
            assert not (set(tr) | set(va)) & set(r.test)
    # two partitions differ
    a = [tuple(r.test) for r in res if r.partition == 0]
    b = [tuple(r.test) for r in res if r.partition == 1]
    assert a != b


def test_batched_estimation_term_equals_single_split_loss(synth):
    space = Space(2, min_fwhm_nm=20.0)
    data = make_batch_data(
        synth["toa"], synth["wl"], synth["table"], synth["res"], space
    )
    u = jnp.asarray(np.random.default_rng(0).uniform(0.1, 0.9, space.dim))
    for i in (0, 4):
        r = synth["res"][i]
        prob = make_problem(
            synth["toa"],
            synth["wl"],
            synth["table"],
            r.train,
            list(r.inner),
            target="all",
            space=space,
        )
        est, _, _ = design_terms(data, space, u, i)
        c, f = space.physical(u)
        np.testing.assert_allclose(3 * float(est), float(prob.loss(c, f)), rtol=1e-10)


def test_outer_test_lamps_do_not_influence_the_loss(synth):
    space = Space(2, min_fwhm_nm=20.0)
    data = make_batch_data(
        synth["toa"], synth["wl"], synth["table"], synth["res"], space
    )
    u = jnp.asarray(np.full(space.dim, 0.4))
    r = 1
    test = synth["res"][r].test
    rows = np.isin(synth["table"].lamp_of, test)

    def f(toa):
        d = eqx.tree_at(lambda x: x.toa, data, toa)
        e, c, _ = design_terms(d, space, u, r)
        return e + c

    g = np.asarray(jax.grad(f)(data.toa))
    assert np.all(g[rows] == 0.0)
    assert np.any(g[~rows] != 0.0)


def test_class_term_equals_cv_loss_arithmetic(synth):
    """With three classes the one-hot matrix has the (n, 3) shape cv_loss takes."""
    from bandopt.estimate import cv_loss
    from bandopt.search._stability import class_cv_loss

    space = Space(2, min_fwhm_nm=20.0)
    data = make_batch_data(
        synth["toa"], synth["wl"], synth["table"], synth["res"], space
    )
    x = jnp.asarray(np.random.default_rng(2).normal(size=(data.toa.shape[0], 3)))
    tw, vw = data.train_w[0], data.val_w[0]
    one = jnp.ones(3)
    want = cv_loss(x, data.onehot, data.onehot > -1, tw, vw, one, one, 1e-3)
    np.testing.assert_allclose(
        float(class_cv_loss(x, data.onehot, tw, vw, 1e-3)), float(want), rtol=1e-12
    )


def test_shared_ridge_equals_one_fit_per_column(synth):
    """The fast path (one Gram matrix per split for all columns sharing the
    weights) gives the terms of one `fit_ridge` per column."""
    space = Space(3, min_fwhm_nm=20.0)
    args = (synth["toa"], synth["wl"], synth["table"], synth["res"], space)
    fast = make_batch_data(*args)
    slow = make_batch_data(*args, shared=False)
    for seed in (0, 1):
        u = jnp.asarray(np.random.default_rng(seed).uniform(0.05, 0.95, space.dim))
        a = np.asarray(design_terms(fast, space, u, 2))
        b = np.asarray(design_terms(slow, space, u, 2))
        np.testing.assert_allclose(a, b, rtol=1e-10)


@pytest.mark.parametrize("noise", [False, True])
def test_float32_loss_agrees_with_float64(synth, noise):
    """With photon noise too: both precisions see the same draws (drawn in
    float64 and cast; float32 draws of `jax.random.normal` are other numbers,
    which once made the float32 loss differ by 60 %)."""
    space = Space(3, min_fwhm_nm=20.0)
    kw = dict(noise=noise)
    d64 = make_batch_data(
        synth["toa"], synth["wl"], synth["table"], synth["res"], space, **kw
    )
    d32 = make_batch_data(
        synth["toa"],
        synth["wl"],
        synth["table"],
        synth["res"],
        space,
        dtype=jnp.float32,
        **kw,
    )
    U = np.random.default_rng(1).uniform(0.05, 0.95, (len(synth["res"]), 4, space.dim))
    f = batched_loss(space, 0.5)
    a = np.asarray(f(d64, jnp.asarray(U)))
    b = np.asarray(f(d32, jnp.asarray(U, jnp.float32)), float)
    assert np.max(np.abs(a - b) / a) < 1e-3


def test_batched_search_converges_reproducibly_to_stationary_points(synth):
    """nlopt starts, optimistix BFGS fits: seeded, never worse than the start,
    the reported loss is the loss at the reported point, and a fit reported
    converged sits where the finite-difference gradient in the angles is 0."""
    space = Space(1, min_fwhm_nm=20.0)
    data = make_batch_data(
        synth["toa"], synth["wl"], synth["table"], synth["res"], space
    )
    kw = dict(restarts=3, explore_evals_per_dim=10, max_steps=100, seed=5)
    a = batched_search(data, space, **kw)
    b = batched_search(data, space, **kw)
    np.testing.assert_array_equal(a.u, b.u)
    np.testing.assert_array_equal(a.start_u, b.start_u)
    assert a.restart_losses.shape == a.result.shape == (len(synth["res"]), 3)
    assert np.all(a.restart_losses <= a.start_losses)
    # exploration: every start is a point nlopt evaluated, with its value
    f0 = np.asarray(batched_loss(space, 0.0)(data, jnp.asarray(a.start_u)))
    np.testing.assert_allclose(f0, a.start_losses, rtol=1e-10)
    assert np.all(a.explore_evals == 10 * space.dim)
    U = jnp.asarray(a.u[:, None, :])
    np.testing.assert_allclose(
        np.asarray(batched_loss(space, 0.0)(data, U))[:, 0], a.loss, rtol=1e-8
    )
    counts = a.result_counts()
    assert set(counts) <= {"successful", "nonlinear_max_steps_reached"}
    assert counts.get("successful", 0) >= a.result.size // 2, counts
    np.testing.assert_array_equal(
        a.converged, a.result[np.arange(len(a.u)), np.argmin(a.restart_losses, 1)]
        == "successful",
    )

    z = angle_from_unit(a.restart_u)
    h = 1e-5  # central differences: truncation ~h², round-off ~1e-16/h
    checked = 0
    for r, k in zip(*np.nonzero(a.result == "successful"), strict=True):
        zz = np.array(z[r, k])
        rows = [np.zeros(len(zz)) for _ in zz]
        g = []
        for i, e in enumerate(rows):
            e[i] = h
            # only resample r's loss: evaluate the batched loss in row r
            zr = np.repeat(zz[None], len(synth["res"]), 0)
            up = np.asarray(
                batched_loss(space, 0.0)(
                    data, jnp.asarray(unit_from_angle(zr + e)[:, None, :])
                )
            )[r, 0]
            dn = np.asarray(
                batched_loss(space, 0.0)(
                    data, jnp.asarray(unit_from_angle(zr - e)[:, None, :])
                )
            )[r, 0]
            g.append((up - dn) / (2 * h))
        assert np.max(np.abs(g)) < 1e-3 * max(1.0, a.restart_losses[r, k]), (r, k, g)
        checked += 1
    assert checked > 0


def test_a_search_stopped_early_says_max_steps(synth):
    space = Space(1, min_fwhm_nm=20.0)
    data = make_batch_data(
        synth["toa"], synth["wl"], synth["table"], synth["res"], space
    )
    s = batched_search(data, space, restarts=2, explore_evals_per_dim=5, max_steps=2)
    assert set(s.result.ravel()) == {"nonlinear_max_steps_reached"}
    assert not s.converged.any()
    assert np.all(s.steps == 2)


def test_angle_transform_reaches_the_bounds_and_inverts():
    u = np.array([0.0, 1e-9, 0.3, 0.5, 1.0])
    np.testing.assert_allclose(
        np.asarray(unit_from_angle(jnp.asarray(angle_from_unit(u)))), u, atol=1e-12
    )
    # a bound is a stationary point in the angle
    g = jax.grad(lambda z: unit_from_angle(z))(jnp.asarray(np.pi / 2))
    assert abs(float(g)) < 1e-15


def test_distinct_starts_skip_permuted_and_near_duplicates():
    space = Space(2, min_fwhm_nm=20.0)
    pts = [
        (np.array([0.2, 0.7, 0.3, 0.3]), 1.0),
        (np.array([0.7, 0.2, 0.3, 0.3]), 1.1),  # the same design, bands swapped
        (np.array([0.21, 0.7, 0.3, 0.3]), 1.2),  # within 0.1 of the first
        (np.array([0.5, 0.9, 0.1, 0.6]), 1.5),
    ]
    U, f = distinct_starts(pts, 2, space)
    np.testing.assert_array_equal(f, [1.0, 1.5])
    np.testing.assert_array_equal(U[1], pts[3][0])
    _, f = distinct_starts(pts, 3, space)  # filled with the next best
    np.testing.assert_array_equal(f, [1.0, 1.5, 1.1])
    with pytest.raises(ValueError, match="need 5"):
        distinct_starts(pts, 5, space)


def test_overlap_matrix():
    wl = jnp.arange(380.0, 901.0)
    r = slit_super_gaussian(
        wl,
        jnp.array([500.0, 500.0, 800.0]),
        jnp.array([40.0, 40.0, 40.0]),
        jnp.array([6.0] * 3),
    )
    ov = np.asarray(overlap_matrix(r))
    np.testing.assert_allclose(ov[0, 1], 1.0, rtol=1e-9)
    assert ov[0, 2] < 1e-6 and ov[0, 0] == 0.0


def test_band_count_rule_and_paired_difference():
    per_n = {
        1: [0.60, 0.62, 0.61, 0.63],
        2: [0.45, 0.47, 0.46, 0.44],
        3: [0.40, 0.43, 0.41, 0.42],
        4: [0.41, 0.40, 0.405, 0.42],
    }
    ch = band_count_choice(per_n)
    assert ch["best_n"] == 4  # mean 0.40875 < 0.415
    assert ch["chosen_n"] == 3  # 0.415 within one SD (0.0085) of 0.40875
    d = ch["paired_difference_to_next_n"]["2-1"]
    np.testing.assert_allclose(d["mean"], -0.16, atol=1e-12)
    assert d["partitions_better"] == 4


def test_pareto_front_and_knee():
    pts = np.array([[0.0, 1.0], [1.0, 0.0], [0.4, 0.4], [0.5, 0.5], [0.9, 0.9]])
    m = pareto_mask(pts)
    assert m.tolist() == [True, True, True, False, False]
    assert knee(pts, m) == 2


def test_medoid_is_the_central_design():
    centres = (450.0, 500.0, 510.0, 520.0, 700.0)
    designs = [(np.array([c]), np.array([40.0])) for c in centres]
    assert medoid(designs) == 2


def test_perturbed_bands_aoi_and_leakage():
    b = BandSet.from_physical([500.0, 700.0], [40.0, 40.0])
    p = perturbed_bands(b, aoi_deg=10.0)
    want = 500.0 * np.sqrt(1 - (np.sin(np.radians(10.0)) / AOI_N_EFF) ** 2)
    np.testing.assert_allclose(float(p.centre_nm[0]), want, rtol=1e-9)
    assert float(p.centre_nm[0]) < 500.0  # blue shift
    wl = jnp.arange(380.0, 901.0)
    q = np.asarray(perturbed_bands(b, leakage=0.01).response(wl))
    assert abs(q[0, 0] - 0.01) < 1e-6 and abs(q[0].max() - 1.0) < 1e-6


# ------------------------------------------------------------------------------
# real study tasks (tiny): resume after a kill, Dask LocalCluster


def _tiny_tasks():
    from bandopt.search._study import make_study_task

    kw = dict(
        preset="tiny",
        partitions=1,
        restarts=2,
        explore_evals_per_dim=5,
        max_steps=20,
        atmospheres="none",
    )
    return [make_study_task(n_bands=1, **kw), make_study_task(n_bands=2, **kw)]


RUNNER = "bandopt.search._study:run_study_task"
_VOLATILE = ("wall_s", "search_s", "evals_per_s")


def _stable(r):
    return json.dumps(
        {k: v for k, v in r.items() if k not in _VOLATILE}, sort_keys=True
    )


@pytest.fixture(scope="module")
def full_sweep(tmp_path_factory):
    from bandopt.search import run_sweep

    out = tmp_path_factory.mktemp("full")
    return run_sweep(_tiny_tasks(), out, runner=RUNNER)


def test_killed_sweep_resumes_with_identical_results(full_sweep, tmp_path):
    from bandopt.search import run_sweep
    from bandopt.search._sweep import task_path

    tasks = _tiny_tasks()
    run_sweep(tasks[:1], tmp_path, runner=RUNNER)  # "killed" after the first task
    first = task_path(tmp_path, tasks[0]).stat().st_mtime_ns
    res = run_sweep(tasks, tmp_path, runner=RUNNER)
    assert task_path(tmp_path, tasks[0]).stat().st_mtime_ns == first  # not rerun
    assert [_stable(r) for r in res] == [_stable(r) for r in full_sweep]


@pytest.mark.filterwarnings("ignore::DeprecationWarning")
@pytest.mark.filterwarnings("ignore::ResourceWarning")
@pytest.mark.filterwarnings("ignore::UserWarning")
def test_study_task_on_a_dask_local_cluster(full_sweep, tmp_path):
    distributed = pytest.importorskip("distributed")
    from bandopt.search import run_sweep
    from bandopt.search._sweep import _worker_env

    tasks = _tiny_tasks()[:1]
    with _worker_env():  # spawned worker processes: x64, CPU, XLA flags
        cluster = distributed.LocalCluster(
            processes=True, n_workers=1, threads_per_worker=1, dashboard_address=None
        )
    with cluster, distributed.Client(cluster):
        res = run_sweep(
            tasks, tmp_path, scheduler=cluster.scheduler_address, runner=RUNNER
        )
    # same code path; a spawned worker's single-threaded XLA may round the
    # last digits differently from this process, so compare numerically
    a, b = res[0], full_sweep[0]
    for key in ("inner_loss", "snr", "max_overlap"):
        np.testing.assert_allclose(a[key], b[key], rtol=1e-9)
    for da, db in zip(a["designs"], b["designs"], strict=True):
        np.testing.assert_allclose(da["centre_nm"], db["centre_nm"], rtol=1e-9)
        np.testing.assert_allclose(da["fwhm_nm"], db["fwhm_nm"], rtol=1e-9)
    assert [s["labels_pred"] for s in a["scores"]] == [
        s["labels_pred"] for s in b["scores"]
    ]


def test_the_paired_adam_loop_runs_on_optax_and_keeps_its_best_point(synth):
    """The old loop kept for the solver pairing (`search._solvers`) is optax's
    Adam: seeded, its reported loss is the loss at its reported point, never
    above the loss at its own uniform starts, and its steps lower that loss."""
    from bandopt.search._solvers import ADAM, adam_search

    space = Space(1, min_fwhm_nm=20.0)
    data = make_batch_data(
        synth["toa"], synth["wl"], synth["table"], synth["res"], space
    )
    a = adam_search(data, space, alpha=0.0, seed=4)
    b = adam_search(data, space, alpha=0.0, seed=4)
    np.testing.assert_array_equal(a["u"], b["u"])
    f = batched_loss(space, 0.0)
    np.testing.assert_allclose(
        np.asarray(f(data, jnp.asarray(a["u"][:, None, :])))[:, 0],
        a["loss"],
        rtol=1e-8,
    )
    n_r = len(synth["res"])
    u0 = np.random.default_rng(4).uniform(
        0.05, 0.95, size=(n_r, ADAM["restarts"], space.dim)
    )
    start = np.asarray(f(data, jnp.asarray(u0))).min(axis=1)
    assert np.all(a["loss"] <= start)
    assert np.all(a["loss"] < start - 1e-6)
    assert a["n_evals"] == n_r * ADAM["restarts"] * (ADAM["steps"] + 1)
