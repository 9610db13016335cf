"""Band search: gradients, optimistix recovery, nlopt vs grid, reproducibility,
resumable sweeps (local and Dask), lamp-grouped problems, evaluate JSON."""

import dataclasses
import json
import os
from pathlib import Path

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from bandopt.estimate import LampTable
from bandopt.scene import band_weights
from bandopt.search import (
    Space,
    bandset_losses,
    fit_local,
    free_bandset,
    global_search,
    grid_pairs,
    grid_search,
    jitted_losses,
    make_problem,
    make_task,
    run_sweep,
)
from bandopt.sensor import slit_super_gaussian


TRUE_BAND = (500.0, 40.0)  # centre, FWHM [nm] that defines the synthetic metric


@pytest.fixture(scope="module")
def synthetic():
    """Smooth random spectra on a 5 nm grid; metric 0 is exactly linear in
    log(L_true / L_pan), so the band (500 nm, 40 nm) gives zero loss."""
    rng = np.random.default_rng(0)
    wl = np.arange(380.0, 901.0, 5.0)
    n_lamps, q = 24, 2
    basis = np.exp(
        -0.5 * ((wl[None, :] - np.linspace(380, 900, 8)[:, None]) / 60.0) ** 2
    )
    toa = rng.uniform(0.05, 1.0, size=(n_lamps, q, 8)) @ basis  # (l, q, w)
    space = Space(1, pan="fixed")
    pan = np.asarray(space.fixed_bands().response(jnp.asarray(wl)))[0]
    true = np.asarray(
        slit_super_gaussian(
            wl, np.array([TRUE_BAND[0]]), np.array([TRUE_BAND[1]]), np.array([6.0])
        )
    )[0]
    wts = np.asarray(band_weights(jnp.asarray(np.stack([true, pan])), jnp.asarray(wl)))
    toa[:, 1] = 3.0 * toa[:, 0]  # a lamp's scenes: scaled copies (one ratio per lamp)
    ratio = (toa[:, 0] @ wts[0]) / (toa[:, 0] @ wts[1])
    truth = np.column_stack(
        [100 + 50 * np.log(ratio), np.ones(n_lamps), np.full(n_lamps, 4000.0)]
    )
    classes = np.array(["a", "b", "c"] * (n_lamps // 3), dtype=object)
    table = LampTable(
        np.repeat(np.arange(n_lamps), q), classes, truth, np.ones_like(truth, bool)
    )
    lamps = np.arange(n_lamps)
    splits = [
        (lamps[lamps % 2 == 0], lamps[lamps % 2 == 1]),
        (lamps[lamps % 2 == 1], lamps[lamps % 2 == 0]),
    ]
    prob = make_problem(
        toa, wl, table, lamps, splits, target="ler", space=space, lam=1e-10
    )
    return {
        "toa": toa,
        "wl": wl,
        "table": table,
        "space": space,
        "problem": prob,
        "splits": splits,
    }


def test_loss_is_zero_at_the_true_band_and_positive_elsewhere(synthetic):
    p = synthetic["problem"]
    at = float(p.loss(jnp.array([TRUE_BAND[0]]), jnp.array([TRUE_BAND[1]])))
    off = float(p.loss(jnp.array([600.0]), jnp.array([40.0])))
    assert at < 1e-10 < 1e-3 < off


def test_gradient_matches_finite_differences_and_is_finite_at_edges(synthetic):
    p, space = synthetic["problem"], synthetic["space"]
    value, vg, _ = jitted_losses(p, space)
    u = jnp.array([0.31, 0.22])
    _, g = vg(u)
    h = 1e-6
    fd = [
        (float(value(u.at[i].add(h))) - float(value(u.at[i].add(-h)))) / (2 * h)
        for i in range(2)
    ]
    # central differences in float64: truncation ~h², rounding ~1e-16/h
    np.testing.assert_allclose(np.asarray(g), fd, rtol=1e-5, atol=1e-8)
    for edge in ([0.0, 0.0], [1.0, 1.0], [0.0, 1.0], [1.0, 0.0]):  # bounds of the box
        f, g = vg(jnp.array(edge))
        assert np.isfinite(float(f)) and np.all(np.isfinite(np.asarray(g)))


@pytest.mark.parametrize("solver", ["bfgs", "lm"])
def test_optimistix_recovers_the_known_band(synthetic, solver):
    p = synthetic["problem"]
    loss, res = bandset_losses(1)
    init = free_bandset([515.0], [50.0])
    r = fit_local(loss, init, args=p, solver=solver, residual_fn=res, max_steps=200)
    assert r.loss < r.initial_loss
    np.testing.assert_allclose(float(r.bands.centre_nm[0]), TRUE_BAND[0], atol=0.5)
    np.testing.assert_allclose(float(r.bands.fwhm_nm[0]), TRUE_BAND[1], atol=1.0)
    assert r.result in (
        "successful",
        "nonlinear_max_steps_reached",
        "max_steps_reached",
    )


def test_mlsl_reaches_the_grid_optimum_with_few_evaluations(synthetic):
    p, space = synthetic["problem"], synthetic["space"]
    value, vg, batch = jitted_losses(p, space)
    grid = grid_search(batch, space, step_nm=10.0, chunk=256)
    assert grid.n_evals == len(grid_pairs(space, 10.0))
    g = global_search(value, vg, space.dim, algorithm="mlsl", max_evals=150, seed=1)
    assert g.n_evals <= 150
    assert g.loss <= grid.loss + 1e-9  # the grid contains the true band: loss ~0
    for alg in ("direct", "crs2"):
        r = global_search(value, vg, space.dim, algorithm=alg, max_evals=60, seed=1)
        assert r.n_evals <= 60 and np.isfinite(r.loss) and r.status


def test_nlopt_exceptions_keep_the_best_point():
    import nlopt

    calls = []

    def value(x):
        calls.append(1)
        if len(calls) > 5:
            raise nlopt.RoundoffLimited("simulated")
        return float(np.sum((np.asarray(x) - 0.3) ** 2))

    def vg(x):
        return value(x), 2 * (np.asarray(x) - 0.3)

    r = global_search(value, vg, 2, algorithm="crs2", max_evals=50, seed=0)
    assert r.status.startswith("exception RoundoffLimited")
    assert r.n_evals == 6 and np.isfinite(r.loss)


def test_same_seed_same_result(synthetic):
    p, space = synthetic["problem"], synthetic["space"]
    value, vg, _ = jitted_losses(p, space)
    a = global_search(value, vg, space.dim, algorithm="crs2", max_evals=80, seed=7)
    b = global_search(value, vg, space.dim, algorithm="crs2", max_evals=80, seed=7)
    assert a.x == b.x and a.loss == b.loss and a.trace == b.trace


def test_problem_rejects_leaking_splits(synthetic):
    s = synthetic
    lamps = np.arange(12)
    with pytest.raises(ValueError, match="outside"):
        make_problem(
            s["toa"],
            s["wl"],
            s["table"],
            lamps,
            [(lamps, np.array([20]))],
            target="ler",
            space=s["space"],
        )
    with pytest.raises(ValueError, match="both sides"):
        make_problem(
            s["toa"],
            s["wl"],
            s["table"],
            lamps,
            [(lamps, lamps[:2])],
            target="ler",
            space=s["space"],
        )


def test_outer_test_lamps_never_enter_the_search():
    from bandopt.search import get_context
    from bandopt.search._task import _lamps_and_splits

    ctx = get_context("tiny", None, 0, "none")
    for k in range(len(ctx.splits)):
        lamps, splits, _, test = _lamps_and_splits(ctx, k)
        assert not set(lamps) & set(test)
        for tr, va in splits:
            assert not set(tr) & set(va) and set(tr) | set(va) <= set(lamps)
            # stratified: every class on both sides of every inner split
            assert set(ctx.table.classes[tr]) == set(ctx.table.classes[va])


def test_run_task_is_reproducible():
    from bandopt.search import run_task

    t = make_task(
        preset="tiny",
        atmospheres="none",
        target="g",
        n_bands=1,
        fold=0,
        max_evals=25,
        local_max_evals=10,
        polish_steps=3,
        seed=3,
    )
    a, b = run_task(t), run_task(t)
    assert a.bands == b.bands and a.loss == b.loss
    assert a.lamp_errors == b.lamp_errors
    assert a.local["result"] and a.global_search["n_evals"] <= 25


# -- sweeps: resume, spawned workers, Dask ------------------------------------------


def fake_runner(task):
    """A cheap stand-in for run_task: fails once for tasks marked 'flaky'."""
    marker = Path(task["noise"]) / f"calls_{task['seed']}"
    marker.parent.mkdir(parents=True, exist_ok=True)
    with marker.open("a") as fh:
        fh.write("x")
    if task["target"] == "cct" and len(marker.read_text()) == 1:
        raise RuntimeError("simulated crash")
    return {
        "task": task,
        "value": task["seed"] ** 2,
        "pid": os.getpid(),
        "xla_flags": os.environ.get("XLA_FLAGS"),
        "wall_s": 0.0,
    }


def _tasks(tmp_path, n=3):
    # `noise` carries the marker directory (the fake runner ignores its meaning)
    return [
        make_task(target="cct" if i == 1 else "ler", seed=i, noise=str(tmp_path / "m"))
        for i in range(n)
    ]


def test_sweep_resumes_after_partial_failure(tmp_path):
    tasks = _tasks(tmp_path)
    out = tmp_path / "out"
    first = run_sweep(tasks, out, runner="tests.test_search:fake_runner")
    assert first[1] is None and first[0]["value"] == 0 and first[2]["value"] == 4
    assert list((out / "tasks").glob("*.failed.json"))
    second = run_sweep(tasks, out, runner="tests.test_search:fake_runner")
    assert [r["value"] for r in second] == [0, 1, 4]
    calls = {i: len((tmp_path / "m" / f"calls_{i}").read_text()) for i in range(3)}
    assert calls == {0: 1, 1: 2, 2: 1}  # finished tasks were not rerun
    assert not list((out / "tasks").glob("*.failed.json"))


def test_sweep_spawned_workers_cap_xla_threads(tmp_path):
    from bandopt.search._sweep import WORKER_XLA_FLAGS

    tasks = [make_task(target="ler", seed=i, noise=str(tmp_path / "m")) for i in (0, 2)]
    res = run_sweep(
        tasks, tmp_path / "out", workers=2, runner="tests.test_search:fake_runner"
    )
    assert {r["xla_flags"] for r in res} == {WORKER_XLA_FLAGS}
    assert all(r["pid"] != os.getpid() for r in res)
    assert os.environ.get("XLA_FLAGS") != WORKER_XLA_FLAGS or "XLA_FLAGS" in os.environ


@pytest.mark.filterwarnings("ignore::DeprecationWarning")
@pytest.mark.filterwarnings("ignore::ResourceWarning")
def test_dask_local_cluster_same_code_path(tmp_path):
    distributed = pytest.importorskip("distributed")
    tasks = _tasks(tmp_path)
    with (
        distributed.LocalCluster(
            processes=False, n_workers=1, threads_per_worker=2, dashboard_address=":0"
        ) as cluster,
        distributed.Client(cluster) as client,
    ):
        run_sweep(
            tasks,
            tmp_path / "out",
            scheduler=client,
            runner="tests.test_search:fake_runner",
        )
        res = run_sweep(
            tasks,
            tmp_path / "out",
            scheduler=client,
            runner="tests.test_search:fake_runner",
        )
    assert [r["value"] for r in res] == [0, 1, 4]
    assert all(r["pid"] == os.getpid() for r in res)  # threads-only cluster


PHYSICAL = {"LER": (0, 683), "G": (-10, 10), "CCT": (1000, 25000)}


def test_evaluate_json_schema(tmp_path, capsys):
    from bandopt.cli import main
    from bandopt.datasets.lamps import library
    from bandopt.estimate import lamp_truth

    lib = library().select(scored_only=True)
    i = [r.level2 for r in lib.records].index("hps")
    wl, v = lib.wavelength_nm, lib.values[i]
    keep = wl <= 780
    f1 = tmp_path / "hps_to780.csv"
    f1.write_text(
        "\n".join(f"{a:g},{b:.8g}" for a, b in zip(wl[keep], v[keep], strict=True))
    )
    f2 = tmp_path / "full.csv"
    f2.write_text("\n".join(f"{a:g},{b:.8g}" for a, b in zip(wl, v, strict=True)))
    # one band-error model for all three metrics and the half-width interval
    # unit (`--sigma joint --interval-unit half-width`): a real fit on the
    # whole library in half the time of the default's (105 s at 888edec, the
    # suite's slowest test); every other option at evaluate's default
    argv = ["evaluate", "--bands", "sdgsat-1", "--lamps", str(f1), str(f2), "--json"]
    assert main([*argv, "--sigma", "joint", "--interval-unit", "half-width"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["bands"] == "sdgsat-1" and isinstance(out["scene"], dict)
    assert [r["file"] for r in out["lamps"]] == [str(f1), str(f2)]
    truth, _ = lamp_truth(v[None], wl)
    for r in out["lamps"]:
        assert set(r) == {
            "file",
            "true",
            "true_null_reasons",
            "estimate",
            "interval90",
            "null_reasons",
            "unexplained",
            "known_type_p_value",
            "level1_probabilities",
            "level1_top2",
            "predicted_level1",
            "predicted_level2",
        }
        assert set(r["true"]) == set(r["estimate"]) == {"LER", "G", "CCT"}
        # The HPS lamp is classified with the foundation's identifiers.
        assert r["predicted_level1"] == "hid" and r["predicted_level2"] == "hps"
        assert r["unexplained"] is False
        assert 0.05 <= r["known_type_p_value"] <= 1  # p >= α: not flagged
        assert abs(sum(r["level1_probabilities"].values()) - 1) < 1e-9
        top = r["level1_top2"]["types"]
        assert top[0]["type"] == "hid" and len(top) == 2
        assert top[0]["probability"] == max(r["level1_probabilities"].values())
        assert isinstance(r["level1_top2"]["close"], bool)
        np.testing.assert_allclose(r["true"]["LER"], truth[0, 0], rtol=2e-3)
        for m, (lo, hi) in PHYSICAL.items():
            e, iv = r["estimate"][m], r["interval90"][m]
            assert lo <= iv[0] <= e <= iv[1] <= hi, (m, e, iv)
    assert out["notes"][0]["nir_extension"] == "hps"
    # the default prior holds same-class blends of the library lamps too
    from bandopt.cli._cmd_evaluate import MIXTURES_DEFAULT
    from bandopt.inversion import MIX_PAIRS

    assert MIXTURES_DEFAULT == MIX_PAIRS
    assert out["mixtures_per_class"] == MIX_PAIRS
    # and blends of two types, as a pixel holding two lamp types sees them
    from bandopt.cli._cmd_evaluate import CROSS_MIXTURES_DEFAULT
    from bandopt.inversion import CROSS_MIX_PAIRS

    assert CROSS_MIXTURES_DEFAULT == CROSS_MIX_PAIRS
    assert out["cross_mixtures_per_class_pair"] == CROSS_MIX_PAIRS
    desc = out["scene"]["estimator_description"]
    assert "pairwise blends of two measured lamps" in desc
    assert main(["evaluate", "--bands", "no-such-sensor", "--lamps", str(f1)]) == 2


def test_jax_x64_is_on():
    assert jax.config.jax_enable_x64  # pyright: ignore


def test_warm_start_takes_previous_result_explicitly(tmp_path):
    """run_task's warm start gets the n - 1 result from `results` (no module
    global): a dict filled by the call, or a sweep's finished task files."""
    import json

    from bandopt.search import TaskResults, run_task, task_id

    t = make_task(
        preset="tiny",
        atmospheres="none",
        target="g",
        n_bands=2,
        fold=0,
        max_evals=20,
        local_max_evals=5,
        polish_steps=2,
        seed=1,
    )
    results = {}
    a = run_task(t, results=results)
    (key,) = results
    assert results[key]["task"]["n_bands"] == 1 and a.warm_start is not None
    (tmp_path / "tasks").mkdir()
    (tmp_path / "tasks" / f"{key}.json").write_text(json.dumps(results[key]))
    from_files = TaskResults(tmp_path)
    b = run_task(t, results=from_files)
    assert list(from_files) == [key]  # read from the file, nothing else run
    assert b.bands == a.bands and b.loss == a.loss
    assert task_id(t) != key
    # the task file is the result's to_dict(), read back exactly
    from bandopt.search import TaskResult

    again = TaskResult.from_dict(results[key])
    assert again.to_dict() == results[key]
    assert list(again.to_dict()) == list(results[key])
    assert TaskResult.from_dict(a.to_dict()) == a


def test_task_result_json_is_the_task_file_form():
    """`TaskResult.to_dict()` keeps the key order of the task files written
    before the class existed (search, final fold, reference sensor) and
    `from_dict` inverts it; unknown keys are refused by name."""
    from bandopt.search import TaskResult

    ev = {"lamp_index": [3], "lamp_errors": [[1.0, 0.1, 50.0]], "fold_of_lamp": [0],
          "lambdas": [[0.1]], "degrees": [[1]]}  # fmt: skip
    search = TaskResult(
        task={"kind": "search", "fold": 0}, bands={"bands": []}, context={"c": 1},
        wall_s=2.0, space={"n": 1}, loss=0.5, spread=[1.0], global_search={"g": 1},
        local=None, warm_start=None, **ev,
    )  # fmt: skip
    assert list(search.to_dict()) == [
        "task", "space", "bands", "loss", "spread", "global", "local", "warm_start",
        "context", "lamp_index", "lamp_errors", "fold_of_lamp", "lambdas", "degrees",
        "wall_s",
    ]  # fmt: skip
    final = dataclasses.replace(search, **dict.fromkeys(ev))
    assert list(final.to_dict()) == [
        "task", "space", "bands", "loss", "spread", "global", "local", "warm_start",
        "context", "wall_s",
    ]  # fmt: skip
    assert final.evaluation() is None and search.evaluation() == ev
    ref = TaskResult(task={"kind": "reference", "sensor": "viirs-dnb"},
                     bands={"name": "VIIRS"}, context={}, wall_s=1.0, **ev)  # fmt: skip
    assert ref.is_reference and list(ref.to_dict()) == [
        "task", "bands", *ev, "wall_s", "context",
    ]  # fmt: skip
    for r in (search, final, ref):
        d = json.loads(json.dumps(r.to_dict()))
        assert TaskResult.from_dict(d) == r and TaskResult.from_dict(d).to_dict() == d
    with pytest.raises(ValueError, match=r"unknown keys \['bogus'\]"):
        TaskResult.from_dict({**search.to_dict(), "bogus": 1})
    with pytest.raises(ValueError, match=r"missing keys \['context'\]"):
        TaskResult.from_dict({"task": {}, "bands": {}, "wall_s": 1.0})


def test_context_is_a_scenario_table_with_folds():
    """A search context's views are its scenario table's rows: spectra per
    lamp, lamp table, types, folds over the lamps stratified by type."""
    from bandopt.folds import Folds
    from bandopt.forward import ScenarioTable
    from bandopt.search import get_context

    ctx = get_context("tiny")
    t = ctx.scenes
    assert isinstance(t, ScenarioTable) and isinstance(ctx.folds, Folds)
    assert ctx.toa.shape == (t.n_lamps, t.scenes_per_lamp, t.wavelength_nm.size)
    np.testing.assert_array_equal(ctx.toa.reshape(-1, ctx.toa.shape[-1]), t.toa)
    np.testing.assert_array_equal(ctx.table.lamp_of, t.lamp)
    np.testing.assert_array_equal(ctx.table.classes, t.level2)
    assert ctx.splits is ctx.folds and ctx.lamp_ids == t.lamp_ids
    assert not ctx.scene_kind.any()  # no perturbations: every scene clean
    for s in ctx.folds:
        for c in set(t.level2[s.test]):
            assert c in set(t.level2[s.train])  # every tested type is trained
