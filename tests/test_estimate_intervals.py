"""`bandopt/studies/ablations/intervals.py`: its study, the summary and README
text it builds from per-lamp records (the runs themselves are `make
estimate-intervals`)."""

import pytest

from bandopt import inversion as inv_mod
from bandopt.results import readme_section
from bandopt.studies import (
    STUDIES,
    by_intervals,
    held_out_overall as _overall,
    manifest_config,
    run,
)
from bandopt.studies.ablations import intervals as ei


def test_study_scores_both_units_from_one_fit_for_every_band_set():
    s = ei.STUDY
    assert ei.GRID == inv_mod.INTERVAL_OFFSET_GRID
    assert (ei.BASE, ei.NARROW) == (
        inv_mod.MIX_METRIC_ESTIMATOR,
        inv_mod.NARROW_ESTIMATOR,
    )
    assert s.estimators == (ei.BASE, ei.NARROW) and s.pairs == ((ei.NARROW, ei.BASE),)
    assert set(s.band_sets) == {"recommended", "sdgsat-1", "nightsat"}
    (label,) = s.unseen
    opts = inv_mod.options_of(label)
    assert (opts.calibration, opts.sigma_rule) == ("classes", "per-metric")
    assert opts.interval_offsets == ei.GRID and label == f"{ei.NARROW}-loco"
    assert s.figure_name == "intervals.png" and s.out == "results/estimate_intervals"


def _records(est, width, covered):
    """Two partitions x two lamps of two classes, one band set."""
    return [
        {
            "band_set": "recommended", "estimator": est, "surface": "unknown",
            "partition": p, "lamp": f"l{i}", "level2": f"c{i}", "out_of_range": 0,
            "LER": 10.0, "G": 0.3, "CCT": 300.0, "CCT_mired": 20.0,
            "LER_covered": covered, "G_covered": 1.0, "CCT_covered": 1.0,
            "LER_width": width * (1 + p) + i, "G_width": 0.5, "CCT_width": 900.0,
            "CCT_width_mired": 80.0,
        }
        for p in (0, 1)
        for i in (0, 1)
    ]  # fmt: skip


def test_summary_pairs_widths_and_coverage_and_the_readme_says_so():
    recs = _records(ei.BASE, 300.0, 1.0) + _records(ei.NARROW, 200.0, 0.5)
    rows = inv_mod.summarise(recs)
    by = {r["estimator"]: r for r in rows}
    # per partition the class-balanced mean width: 300 x (1 + p) + 0.5
    assert by[ei.BASE]["LER_width_per_partition"] == [300.5, 600.5]
    (p,) = inv_mod.estimator_differences(rows, ei.STUDY.pairs, ei.WIDTH_COLUMNS)
    assert p["LER_width_diff"] == pytest.approx(-150.0)  # (-100 - 200) / 2
    assert p["LER_width_diff_sd"] == pytest.approx(70.71, abs=0.01)
    assert p["LER_covered_diff"] == pytest.approx(-0.5)
    assert "LER_diff" not in p  # errors are not among the compared columns
    text = ei.readme_text(
        {"partitions": 2, "offset_grid": list(ei.GRID), "rows": rows,
         "paired": [p], "unseen_types": {}}
    )  # fmt: skip
    row = f"| recommended | {ei.NARROW} | 0.50/1.00/1.00 | 300 ± 141 |"
    assert row in text
    assert (
        "| recommended | -150 ± 71 | +0.000 ± 0.000 | +0 ± 0 | -0.50 ± 0.00 |" in text
    )


def test_coverage_by_quartile_of_the_half_width_intervals_width():
    """8 lamps: the two with the narrowest half-width intervals form the first
    quartile, whatever each unit's own widths; other band sets are ignored."""
    recs = []
    for i, w in enumerate((50, 10, 80, 20, 70, 30, 60, 40)):
        for est, cov in ((ei.BASE, 1.0), (ei.NARROW, 0.0 if w <= 20 else 0.5)):
            recs.append(
                {"band_set": "recommended", "estimator": est, "partition": 0,
                 "fold": 0, "lamp": f"l{i}", "LER_width": w if est == ei.BASE
                 else 1.0, "LER_covered": cov}
            )  # fmt: skip
    recs.append({**recs[0], "band_set": "sdgsat-1", "LER_covered": 0.0})
    out = ei.coverage_by_width(recs)
    assert out == {"LER": {"half-width": [1.0] * 4, "narrowest": [0.0, 0.5, 0.5, 0.5]}}
    text = ei.readme_text(
        {"partitions": 1, "offset_grid": [0.0], "rows": [], "paired": [],
         "unseen_types": {}, "extra": {"coverage_by_width": out}}
    )  # fmt: skip
    assert "LER 1.00/1.00/1.00/1.00 → 0.00/0.50/0.50/0.50." in text


def test_unseen_line_names_the_least_covered_class():
    by_class = {
        "hps": {"LER_covered": 0.9, "G_covered": 0.5, "CCT_covered": None},
        "lps": {"LER_covered": 0.7, "G_covered": 1.0, "CCT_covered": None},
    }
    overall = {"LER_covered": 0.8, "G_covered": 0.75, "CCT_covered": 1.0,
               "LER_width": 120.0, "out_of_range": 0}  # fmt: skip
    text = ei.readme_text(
        {"partitions": 1, "offset_grid": [0.0], "rows": [], "paired": [],
         "unseen_types": {"x-loco": {"overall": overall, "by_class": by_class}}}
    )  # fmt: skip
    assert "mean width LER 120 lm/W; out of range 0." in text
    overall.update(G_width=2.5, CCT_width=900.0, CCT_width_mired=80.0)
    text = ei.readme_text(
        {"partitions": 1, "offset_grid": [0.0], "rows": [], "paired": [],
         "unseen_types": {"x-loco": {"overall": overall, "by_class": by_class}}}
    )  # fmt: skip
    assert "LER 120 lm/W, G 2.500, CCT 900 K (80 mired); out of" in text
    assert "Lowest held-out class: LER lps 0.70, G hps 0.50." in text


def test_unseen_records_split_by_their_intervals():
    recs = []
    for tag, cov in (("narrowest", 0.5), ("offset 0", 1.0)):
        for c in ("hps", "lps"):
            recs.append(
                {"held_out_class": c, "level1_in_prior": True, "LER_covered": cov,
                 "LER_width": 100 * cov, "level1_correct": 1.0, "unexplained": 0.0,
                 "out_of_range": 0, "intervals": tag}
            )  # fmt: skip
    split = by_intervals(recs)
    assert list(split) == ["narrowest", "offset 0"]
    assert _overall(split["narrowest"])["LER_width"] == 50.0
    assert _overall(split["offset 0"])["LER_covered"] == 1.0
    assert list(by_intervals([{"a": 1}])) == [None]


def test_manifest_lists_every_unseen_run_with_its_offsets():
    (run,) = manifest_config(ei.STUDY, 4)["unseen_types"]
    assert run["label"] == f"{ei.NARROW}-loco"
    assert run["interval_offsets"] == list(ei.GRID)
    assert (run["calibration"], run["sigma_rule"]) == ("classes", "per-metric")
    assert run["mixtures"] == inv_mod.MIX_PAIRS and run["peak_shifts_nm"] == []
    mix = manifest_config(STUDIES["estimate-mix"], 4)["unseen_types"]
    assert {r["interval_offsets"] == [0.0] for r in mix} == {True}
    assert [r["mixtures"] for r in mix] == [0, inv_mod.MIX_PAIRS, inv_mod.MIX_PAIRS]
    assert manifest_config(STUDIES["estimate-mix"], 4)["modelled_lamps_used"] is False


def test_help_is_this_studys(capsys):
    with pytest.raises(SystemExit):
        run(ei.STUDY, ["--help"])
    assert "Narrower 90 % intervals" in capsys.readouterr().out


def test_committed_section_is_generated_from_the_committed_summary():
    import json
    from pathlib import Path

    results = Path(__file__).resolve().parents[1] / "results"
    summary = json.loads((results / "estimate_intervals" / "summary.json").read_text())
    section = readme_section("estimate-intervals", results)
    assert section.strip() == ei.readme_text(summary).strip()
    assert summary["offset_grid"] == list(ei.GRID)
    assert summary["scored_lamps"] == "measured lamps only"
    assert summary["modelled_lamps_used"] is False
