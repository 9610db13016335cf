"""Lamp-type classification over lamp partitions
(`bandopt.studies.classification_partitions`): its plan, the aggregation over
partitions, the paired differences, and a quick run that resumes."""

import json
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

import bandopt.studies.classification_partitions as cp
from bandopt.results import readme_section


def _rec(design, est, p, f2, f1=None, n_model=0, surface="unknown", n_bands=3):
    return {
        "design": design,
        "estimator": est,
        "partition": p,
        "level2_macro_f1": f2,
        "level1_macro_f1": f2 + 0.1 if f1 is None else f1,
        "modelled_per_class": n_model,
        "surface_knowledge": surface,
        "n_bands": n_bands,
    }


def test_plan_drops_what_it_says_and_nothing_else():
    designs = {"classification": 6, "spectral": 6, "sdgsat-1": 4, "viirs-dnb": 1}
    units, dropped = cp.plan_units(designs, 4)
    why = {(d["design"], d["estimator"]): d["reason"] for d in dropped}
    assert set(why) == {
        ("classification", "inversion/class"),
        ("classification", "inversion/measured"),
        ("spectral", "inversion/class"),
        ("spectral", "inversion/measured"),
        ("viirs-dnb", "inversion"),
        ("viirs-dnb", "inversion-moon"),
    }
    assert "--surface-modes" in why[("spectral", "inversion/class")]
    assert "--one-band-inversion" in why[("viirs-dnb", "inversion")]
    # 4 estimators for the multi-band designs, 2 for the one-band one
    assert len(units) == 4 * (3 * 4 + 2)
    # the KNN of every partition first, then the inversion with the Moon
    # fitted, then told, each by partition
    stages = [e.startswith("inversion") + (e == "inversion-moon") for _, _, e in units]
    assert stages == sorted(stages)
    knn = [p for p, _, e in units if not e.startswith("inversion")]
    assert knn == sorted(knn) and len(knn) == 4 * 2 * 4
    full, none = cp.plan_units(
        designs, 2, surface_modes=True, one_band_inversion=True, moon_all_designs=True
    )
    assert none == [] and len(full) == 2 * (6 + 6 + 4 + 4)
    # the told-Moon inversion: not for a 3-band reference unless asked
    three = {"classification": 6, "jilin-1-03b": 3}
    units, dropped = cp.plan_units(three, 1)
    assert ("jilin-1-03b", "inversion-moon") in {
        (d["design"], d["estimator"]) for d in dropped
    }
    assert (0, "classification", "inversion-moon") in units
    units, _ = cp.plan_units(three, 1, moon_all_designs=True)
    assert (0, "jilin-1-03b", "inversion-moon") in units
    # surface knowledge never for a reference sensor
    assert not any(e in cp.SURFACE_ESTIMATORS and d == "sdgsat-1" for _, d, e in full)


def test_aggregate_mean_and_sample_sd_over_partitions():
    recs = [
        _rec("a", "knn", 2, 0.5),
        _rec("a", "knn", 0, 0.7),
        _rec("a", "knn", 1, 0.6),
        _rec("b", "knn", 0, 0.2, n_model=5),
    ]
    rows = cp.aggregate(recs)
    a = next(r for r in rows if r["design"] == "a")
    assert a["partitions"] == 3 and a["partition_ids"] == [0, 1, 2]
    assert a["level2_macro_f1_per_partition"] == [0.7, 0.6, 0.5]
    assert a["level2_macro_f1_mean"] == pytest.approx(0.6)
    assert a["level2_macro_f1_sd"] == pytest.approx(0.1)  # ddof 1
    assert a["level1_macro_f1_mean"] == pytest.approx(0.7)
    b = next(r for r in rows if r["design"] == "b")
    assert b["level2_macro_f1_sd"] is None and b["modelled_per_class"] == 5
    with pytest.raises(ValueError, match="partition repeated"):
        cp.aggregate([*recs, _rec("a", "knn", 1, 0.1)])
    with pytest.raises(ValueError, match="modelled_per_class"):
        cp.aggregate([*recs, _rec("b", "knn", 1, 0.1)])


def test_paired_differences_pair_by_partition_only():
    recs = [
        _rec("ours", "knn", 0, 0.7),
        _rec("ours", "knn", 1, 0.8),
        _rec("ours", "knn", 2, 0.9),
        _rec("ref", "knn", 0, 0.5),
        _rec("ref", "knn", 2, 0.4),  # partition 1 missing: not paired
        _rec("ours", "inversion", 0, 0.6),  # no reference row: no pair
    ]
    (row,) = cp.paired_differences(recs, ["ours"], ["ref"])
    assert row["estimator"] == "knn" and row["partition_ids"] == [0, 2]
    np.testing.assert_allclose(row["level2_diff_per_partition"], [0.2, 0.5])
    assert row["level2_diff_mean"] == pytest.approx(0.35)
    assert row["level2_diff_sd"] == pytest.approx(np.std([0.2, 0.5], ddof=1))


@settings(max_examples=30, deadline=None)
@given(st.lists(st.tuples(st.floats(0, 1), st.floats(0, 1)), min_size=2, max_size=6))
def test_paired_mean_is_the_difference_of_means(values):
    """With every partition on both sides, the mean paired difference is the
    difference of the designs' means, and its SD is at most the sum of theirs
    (SD of a difference)."""
    recs = []
    for p, (a, b) in enumerate(values):
        recs += [_rec("ours", "knn", p, a), _rec("ref", "knn", p, b)]
    (row,) = cp.paired_differences(recs, ["ours"], ["ref"])
    rows = {r["design"]: r for r in cp.aggregate(recs)}
    want = rows["ours"]["level2_macro_f1_mean"] - rows["ref"]["level2_macro_f1_mean"]
    assert row["level2_diff_mean"] == pytest.approx(want, abs=1e-12)
    bound = rows["ours"]["level2_macro_f1_sd"] + rows["ref"]["level2_macro_f1_sd"]
    assert row["level2_diff_sd"] <= bound + 1e-12


def test_quick_run_writes_everything_and_resumes(tmp_path, capsys):
    out = tmp_path / "q"
    assert cp.run(out, quick=True) == 0
    for name in ("records.jsonl", "summary.json", "summary.csv", "paired.csv",
                 "f1_partitions.png", "report.md", "manifest.json"):  # fmt: skip
        assert (out / name).is_file(), name
    s = json.loads((out / "summary.json").read_text())
    n_units = len((out / "records.jsonl").read_text().splitlines())
    assert s["timing"]["units"] == n_units == 2 * (4 + 6)
    assert {r["estimator"] for r in s["rows"]} == set(cp.ESTIMATORS)
    assert all(r["partitions"] == 2 for r in s["rows"])
    assert {(r["design"], r["reference"]) for r in s["paired"]} == {
        ("classification", "sdgsat-1")
    }
    assert s["modelled_classes_added"] == {"mercury": 2 * 2 * 3}  # 2 designs
    man = json.loads((out / "manifest.json").read_text())
    used = {(r["design"], r["estimator"]): r for r in man["config"]["rows"]}
    assert used[("classification", "knn+models")]["modelled_lamps_used"]
    assert not used[("classification", "knn")]["modelled_lamps_used"]
    assert used[("classification", "inversion/class")]["surface_knowledge"] == "class"
    assert used[("classification", "inversion-moon")]["moon"] == "known per pixel"
    assert used[("classification", "inversion")]["moon"] == "fitted"
    assert used[("classification", "knn")]["moon"] == "unknown"
    # an interrupted run: the last line cut short (no newline) -> recomputed on
    # a line of its own, the rest kept
    lines = (out / "records.jsonl").read_text().splitlines()
    (out / "records.jsonl").write_text("\n".join([*lines[:-1], lines[-1][:40]]))
    capsys.readouterr()
    assert cp.run(out, quick=True) == 0
    log = capsys.readouterr().out
    assert "unreadable line dropped" in log and f"{n_units - 1} finished earlier" in log
    again = json.loads((out / "summary.json").read_text())
    assert again["rows"] == s["rows"]  # same seeds, same numbers
    fixed = (out / "records.jsonl").read_text().splitlines()
    assert len(fixed) == n_units and all(json.loads(x) for x in fixed)


def test_readme_section_is_read_from_the_summary():
    root = Path(__file__).resolve().parents[1] / "results"
    summary = json.loads((root / "classify_partitions" / "summary.json").read_text())
    text = cp.readme_text(summary)
    row = next(
        r for r in summary["rows"]
        if r["design"] == "classification" and r["estimator"] == "knn"
    )  # fmt: skip
    m, sd = row["level2_macro_f1_mean"], row["level2_macro_f1_sd"]
    assert f"{m:.3f} ± {sd:.3f}" in text
    assert "| classification | sdgsat-1 |" in text
    assert text.strip() == readme_section("classify-partitions", root)


def test_csv_tables_hold_every_column_and_lists_as_json(tmp_path):
    """`studies.write_csv`: columns in first-seen order over all rows, a
    missing value empty, lists and dicts as JSON (summary.csv's per-partition
    values)."""
    import csv

    from bandopt.studies import write_csv

    path = tmp_path / "t.csv"
    write_csv(path, [{"a": 1, "b": [0.5, None]}, {"a": 2, "c": {"x": "y"}}])
    with path.open(newline="") as fh:
        rows = list(csv.reader(fh))
    assert rows == [["a", "b", "c"], ["1", "[0.5, null]", ""], ["2", "", '{"x": "y"}']]
