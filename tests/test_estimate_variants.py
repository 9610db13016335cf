"""`experiments/estimate_shift.py` and `experiments/estimate_planck.py`:
their studies, the per-class table and README text they build from per-lamp
records, the manifest saying whether modelled spectra trained, and how far
measured halogen lamps lie from a Planck radiator (the runs themselves are
`make study NAME=estimate-shift` and `make study NAME=estimate-planck`)."""

import dataclasses

import numpy as np
import pytest

from bandopt import inversion as inv_mod
from bandopt.results import readme_section
from bandopt.studies import GRID, SHIFTS, manifest_config
from bandopt.studies.ablations import (
    defaults as ed,
    planck as ep,
    shift as es,
    tm30 as et,
)


def test_studies_pair_evaluates_estimator_with_one_change_each():
    assert SHIFTS == inv_mod.PEAK_SHIFTS_NM
    assert GRID == inv_mod.INTERVAL_OFFSET_GRID
    assert (es.BASE, es.SHIFT, ep.PLANCK, ed.DEFAULT) == (
        inv_mod.NARROW_ESTIMATOR,
        inv_mod.SHIFT_ESTIMATOR,
        inv_mod.PLANCK_ESTIMATOR,
        inv_mod.DEFAULT_ESTIMATOR,
    )
    assert ed.STUDY.estimators == (es.BASE, ed.DEFAULT)
    assert ed.STUDY.pairs == ((ed.DEFAULT, es.BASE),)
    (label,) = ed.STUDY.unseen
    opts = inv_mod.options_of(label)
    assert opts.peak_shifts_nm == SHIFTS and opts.planck and not opts.tm30
    assert manifest_config(ed.STUDY, 4)["modelled_lamps_used"] is True
    for study, variant, more in (
        (es.STUDY, es.SHIFT, {"peak_shifts_nm": SHIFTS}),
        (ep.STUDY, ep.PLANCK, {"planck": True}),
    ):
        assert study.estimators == (es.BASE, variant)
        assert study.pairs == ((variant, es.BASE),)
        assert set(study.band_sets) == {"recommended", "sdgsat-1", "nightsat"}
        assert study.unseen == (f"{es.BASE}-loco", f"{variant}-loco")
        base, var = (inv_mod.options_of(u) for u in study.unseen)
        assert base.calibration == "classes" and base.interval_offsets == GRID
        assert var == dataclasses.replace(base, **more)


def test_manifests_say_whether_modelled_spectra_trained():
    shift = manifest_config(es.STUDY, 4)
    planck = manifest_config(ep.STUDY, 4)
    assert shift["modelled_lamps_used"] is False
    assert planck["modelled_lamps_used"] is True
    assert "Planck" in planck["training_lamps"]
    assert "Planck" not in shift["training_lamps"]
    assert "shifted" in shift["training_lamps"]
    assert shift["unseen_types"][1]["peak_shifts_nm"] == list(SHIFTS)
    assert not shift["unseen_types"][1]["planck"]
    assert (
        planck["unseen_types"][1]["planck"]
        and not planck["unseen_types"][1]["peak_shifts_nm"]
    )


def _records(est, ler):
    """Two partitions; recommended bands: an amber LED and an hps lamp; one
    SDGSAT-1 record that the per-class table ignores."""
    recs = [
        {"band_set": "recommended", "estimator": est, "surface": "unknown",
         "partition": p, "fold": 0, "lamp": f"{c}{p}", "level2": c, "level1": "x",
         "out_of_range": 0, "LER": ler[c] + p, "G": 0.1, "CCT": 100.0,
         "CCT_mired": 10.0, "LER_covered": 1.0, "G_covered": 1.0,
         "CCT_covered": 1.0, "LER_width": 80.0, "level1_correct": 1.0}
        for p in (0, 1)
        for c in ("led_amber", "hps")
    ]  # fmt: skip
    return [*recs, {**recs[0], "band_set": "sdgsat-1", "LER": 999.0}]


def test_per_class_table_and_readme_text():
    recs = _records(es.BASE, {"led_amber": 20.0, "hps": 7.0})
    recs += _records(es.SHIFT, {"led_amber": 10.0, "hps": 7.0})
    table = es.by_class(recs)
    assert table[es.BASE]["led_amber"]["LER"] == pytest.approx(20.5)
    assert table[es.SHIFT]["led_amber"]["LER"] == pytest.approx(10.5)
    assert table[es.SHIFT]["led_amber"]["lamps"] == 2
    rows = inv_mod.summarise(recs)
    paired = inv_mod.estimator_differences(rows, es.STUDY.pairs, es.COLUMNS)
    (p,) = [x for x in paired if x["band_set"] == "recommended"]
    assert p["LER_diff"] == pytest.approx(-5.0)  # class-balanced: (-10 + 0) / 2
    text = es.readme_text(
        {"partitions": 2, "peak_shifts_nm": list(SHIFTS), "rows": rows,
         "paired": paired, "unseen_types": {}, "extra": {"by_class": table}}
    )  # fmt: skip
    assert "shifted by -10, -7.5, -5, -2.5, +2.5, +5, +7.5, +10 nm" in text
    assert "| recommended | -5.0 ± 0.0 | +0.000 ± 0.000 | +0 ± 0 |" in text
    assert "without → with shifts: hps (2) 7.5 → 7.5 lm/W" in text
    assert "led_amber (2) 20.5 → 10.5 lm/W, CCT 100 → 100 K." in text


def test_planck_text_says_modelled_and_how_well_it_matches():
    match = {"lamps": 3, "CCT_range_K": [2300.0, 3000.0], "LER_diff_mean_abs": 12.5,
             "LER_diff_range": [-10.0, 20.0], "G_diff_mean_abs": 0.15,
             "G_diff_range": [-0.2, 0.3]}  # fmt: skip
    unseen = {
        f"{ep.PLANCK}-loco": {
            "overall": {"LER_covered": 0.9, "G_covered": 0.8, "CCT_covered": 0.85,
                        "LER_width": 150.0, "level1_correct": 0.48,
                        "unexplained": 0.02, "out_of_range": 0},
            "by_class": {"incandescent_halogen": {
                "level1_predicted": {"incandescent": 0.99, "hid": 0.01}}},
        },
        f"{ep.PLANCK}-loco (offset 0)": {"overall": {}},
    }  # fmt: skip
    text = ep.readme_text(
        {"partitions": 4, "rows": [], "paired": [], "unseen_types": unseen,
         "extra": {"planck_match": match}}
    )  # fmt: skip
    assert "modelled lamps used: yes" in text
    assert "level-1 right 0.48; unexplained 0.02; out of range 0." in text
    assert "incandescent_halogen → incandescent 0.99, hid 0.01" in text
    assert "(offset 0)" not in text
    assert "3 measured halogen lamps (2300-3000 K)" in text
    assert "LER differs by 12.5 lm/W on average (lamp − model -10.0 to +20.0)" in text


def test_planck_match_against_the_library():
    """The library's measured halogen lamps: a Planck radiator at each one's
    CCT has an LER within tens of lm/W (both are thermal spectra) and the
    CCTs lie in the Planck spectra's 2400-3200 K neighbourhood."""
    m = ep.planck_match()
    assert m["lamps"] >= 20
    assert 2000.0 < m["CCT_range_K"][0] < m["CCT_range_K"][1] < 3500.0
    assert 0.0 < m["LER_diff_mean_abs"] < 40.0
    lo, hi = m["LER_diff_range"]
    assert lo <= 0.0 <= hi or np.isclose(lo, hi)


def test_tm30_study_pairs_evaluates_estimator_with_and_without_them():
    assert et.TM30 == inv_mod.TM30_ESTIMATOR
    assert et.STUDY.estimators == (ed.DEFAULT, et.TM30)
    assert et.STUDY.pairs == ((et.TM30, ed.DEFAULT),)
    base, var = (inv_mod.options_of(u) for u in et.STUDY.unseen)
    assert base.peak_shifts_nm == SHIFTS and base.planck and not base.tm30
    assert var == dataclasses.replace(base, tm30=True)
    counts = et.tm30_counts()
    assert counts["lamps"] == sum(counts["by_class"].values()) > 150
    assert counts["duplicates_removed"] > 20


def test_tm30_text_compares_with_evaluates_estimator():
    recs = _records(ed.DEFAULT, {"led_amber": 20.0, "hps": 7.0})
    recs += _records(et.TM30, {"led_amber": 20.0, "hps": 5.0})
    rows = inv_mod.summarise(recs)
    paired = inv_mod.estimator_differences(rows, et.STUDY.pairs, es.COLUMNS)
    counts = {"lamps": 5, "by_class": {"hps": 3, "led_warm": 2},
              "duplicates_removed": 4, "excluded": 1}  # fmt: skip
    text = et.readme_text(
        {"partitions": 2, "rows": rows, "paired": paired, "unseen_types": {},
         "extra": {"by_class": es.by_class(recs, (ed.DEFAULT, et.TM30)),
                   "tm30": counts}}
    )  # fmt: skip
    assert f"`{et.TM30}` minus `{ed.DEFAULT}`" in text
    assert "| recommended | -1.0 ± 0.0 |" in text
    assert "without → with the TM-30 lamps: hps (2) 7.5 → 5.5 lm/W" in text
    assert "The TM-30 lamps in the prior: 5 (hps 3, led_warm 2); 4 of" in text


@pytest.mark.parametrize(
    "module",
    [es, ep, ed, et],
    ids=["estimate-shift", "estimate-planck", "defaults", "tm30"],
)
def test_committed_section_is_generated_from_the_committed_summary(module):
    import json
    from pathlib import Path

    results = Path(__file__).resolve().parents[1] / "results"
    study = module.STUDY
    summary = json.loads((results / Path(study.out).name / "summary.json").read_text())
    section = readme_section(f"{study.name}", results)
    assert section.strip() == module.readme_text(summary).strip()
    assert summary["scored_lamps"] == "measured lamps only"
    assert summary["modelled_lamps_used"] is (study is not es.STUDY)
    assert summary["estimators"] == list(study.estimators)
    for row in summary["rows"]:
        assert row["out_of_range"] == 0 and row["partitions"] == 4
