"""The single-split study's comparison (`compare_with_references`), its tasks
and its table (`bandopt.search._single_split`, `python -m experiments.search
compare`)."""

import numpy as np
import pytest

from bandopt.search import (
    EVALS_PER_DIM,
    FOLDS,
    SearchOptions,
    compare_with_references,
    pool_folds,
    single_split_tasks,
    table_text,
)


def _result(errors, index, **extra):
    return {
        "lamp_errors": np.asarray(errors)[index].tolist(),
        "lamp_index": list(map(int, index)),
        "wall_s": 1.0,
        **extra,
    }


def test_comparison_invariants():
    """Our errors at half the reference's on every lamp: reduction 0.5 for
    every metric; the goal is met exactly where it asks <= 0.5; a set with a
    missing fold is skipped; the equal-band-count set is the joint one."""
    rng = np.random.default_rng(0)
    n = 24
    classes = np.array(["a", "b", "c"] * (n // 3), object)
    ref_err = rng.uniform(1.0, 2.0, (n, 3))
    folds = [np.arange(k, n, 3) for k in range(3)]
    bands4 = {"bands": [{"name": f"B{i}"} for i in range(4)]}
    ref = _result(ref_err, np.arange(n), task={"sensor": "ref4"}, bands=bands4)

    def searched(scale):
        return {
            k: _result(scale * ref_err, f, bands={}, spread=None)
            for k, f in enumerate(folds)
        }

    sets = {
        ("all", 3, "fixed"): searched(0.5),  # 3 + pan = the reference's 4 bands
        ("all", 5, "fixed"): searched(0.5),
        ("ler", 5, "fixed"): searched(0.8),
        ("g", 5, "fixed"): {0: searched(0.1)[0]},  # folds 1, 2 missing
    }
    goal = {"LER": 0.4, "G": 0.5, "CCT": 0.6}
    c = compare_with_references(sets, [ref], classes, goal, titles={"ref4": "R"})
    assert set(c.ours) == {"all-n3+pan", "all-n5+pan", "ler-n5+pan"}
    assert c.references["ref4"]["title"] == "R"
    assert c.best_for_goal == {m: "all-n5+pan" for m in ("LER", "G", "CCT")}
    for m, g in goal.items():
        red = c.reductions["ref4"][m]
        assert red["reduction"] == pytest.approx(0.5)
        assert red["meets_goal"] == (0.5 >= g)
    eq = c.reductions["ref4"]["equal_band_count"]
    assert eq["ours"] == "all-n3+pan" and eq["CCT"]["reduction"] == pytest.approx(0.5)
    assert pool_folds({0: ref, 1: ref}) is None  # fold 2 missing
    assert set(c.as_dict()) == {"references", "ours", "best_for_goal", "reductions"}


def test_single_split_tasks_budget_grows_with_dimension():
    """Targets x band counts x folds, in that order; without `max_evals` the
    budget is `EVALS_PER_DIM` per search dimension (2 per band), with it the
    given number for every band count."""
    opts = SearchOptions(bands=(1, 3), preset="tiny", seed=2)
    tasks = single_split_tasks(["ler", "all"], opts)
    assert len(tasks) == 2 * 2 * len(FOLDS)
    assert [t["fold"] for t in tasks[: len(FOLDS)]] == list(FOLDS)
    assert {(t["target"], t["n_bands"], t["max_evals"]) for t in tasks} == {
        (tg, n, EVALS_PER_DIM * 2 * n) for tg in ("ler", "all") for n in (1, 3)
    }
    assert {(t["preset"], t["seed"], t["pan"]) for t in tasks} == {("tiny", 2, "fixed")}
    fixed = single_split_tasks(["g"], SearchOptions(bands=(5,), max_evals=20))
    assert {t["max_evals"] for t in fixed} == {20}
    assert opts.bands_text == "1,3"


def test_table_text_rows():
    """One row per reference sensor (band count, MAEs, reductions, goal) and
    one per searched set (its band count with pan)."""
    mae = {"LER": {"mae": 10.0}, "G": {"mae": 0.1}, "CCT": {"mae": 300.0}}
    red = {m: {"reduction": 0.5, "meets_goal": True} for m in ("LER", "G", "CCT")}
    summary = {
        "best_for_goal": {"LER": "all-n5+pan"},
        "references": {"ref4": {"n_bands": 4, **mae}},
        "reductions": {"ref4": red},
        "ours": {"all-n5+pan": {"n_bands": 5, "pan": "fixed", **mae}},
    }
    lines = table_text(summary).splitlines()
    assert len(lines) == 4 and "LER: all-n5+pan" in lines[0]
    assert lines[2].split() == [
        "ref4",
        "4",
        "10.00",
        "0.100",
        "300",
        "|",
        "50%",
        "50%",
        "50%",
        "yes",
    ]
    assert lines[3].split() == ["ours", "all-n5+pan", "6", "10.00", "0.100", "300"]
