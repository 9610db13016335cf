"""`bandopt/studies/moon.py`: its pure parts (the Moon-state presets,
per-class G errors, the README table)."""

import pytest

from bandopt.studies import moon as em


def test_moon_presets_are_the_search_preset_with_other_moon_states():
    from bandopt.search import _task

    assert em.preset_name(None) == "search"
    name = em.preset_name(("full",))
    assert _task.PRESETS[name]["moons"] == ("full",)
    base = {k: v for k, v in _task.PRESETS["search"].items() if k != "moons"}
    assert {k: v for k, v in _task.PRESETS[name].items() if k != "moons"} == base
    assert em.preset_name((None,)) == "search_moon_none"


def test_g_by_class_and_table():
    recs = [
        {"estimator": "inversion", "level2": "mercury", "G": 1.0},
        {"estimator": "inversion", "level2": "mercury", "G": 3.0},
        {"estimator": "inversion", "level2": "led_amber", "G": None},
        {"estimator": "ridge", "level2": "mercury", "G": 9.0},
    ]
    assert em.g_by_class(recs, "inversion") == {"mercury": pytest.approx(2.0)}
    row = {
        "moon": "none",
        "estimator": "inversion",
        "LER": 18.3, "LER_sd": 1.0, "G": 0.333, "G_sd": 0.01, "CCT": 438.0,
        "CCT_sd": 5.0, "G_by_class": {"mercury": 0.86},
    }  # fmt: skip
    paired = [
        {"band_set": "sdgsat-1", "vs": "recommended", "estimator": "inversion-moon",
         "LER_diff": 2.0, "LER_diff_sd": 0.5},
        {"band_set": "recommended", "vs": "inversion", "estimator": "inversion-moon",
         "LER_diff": -9.0, "LER_diff_sd": 0.4, "G_diff": -0.46, "G_diff_sd": 0.03},
    ]  # fmt: skip
    text = em.readme_text({"partitions": 4, "rows": [row], "paired": paired})
    want = (
        "| none | recommended | inversion | 18.3 ± 1.0 | 0.333 ± 0.010 | 438 ± 5 "
        "| nan | 0.86 |"
    )
    assert want in text
    ref = "| sdgsat-1 − recommended | inversion-moon | +2.0 ± 0.5 | n/a | n/a |"
    assert ref in text
    assert (
        "| recommended: inversion-moon − inversion | inversion-moon | -9.0 ± 0.4 "
        "| -0.460 ± 0.030 | n/a |"
    ) in text
    assert "mean ± SD over 4 partitions" in text


def test_unseen_types_lines():
    o = {
        "LER_covered": 0.8, "G_covered": 0.81, "CCT_covered": 0.85,
        "level1_correct": 0.4, "unexplained": 0.02, "out_of_range": 0,
    }  # fmt: skip
    unseen = {"inversion-moon": {"overall": o}}
    text = em.readme_text({"partitions": 4, "rows": [], "unseen_types": unseen})
    assert "Unseen lamp types (recommended bands, `inversion-moon`" in text
    assert "level-1 type right 0.40" in text and "out of range 0" in text


def test_coverage_column_and_where_held_out_classes_went():
    row = {
        "moon": "none and full (as make estimate)", "band_set": "recommended",
        "estimator": "inversion-moon-loco", "LER": 18.0, "LER_sd": 0.7,
        "G": 0.383, "G_sd": 0.043, "CCT": 412.0, "CCT_sd": 9.0,
        "G_by_class": {}, "coverage": {"LER": 0.97, "G": 0.951, "CCT": 0.96},
    }  # fmt: skip
    ridge = dict(row, estimator="ridge", coverage={"LER": None, "G": None})
    o = {
        "LER_covered": 0.8, "G_covered": 0.81, "CCT_covered": 0.85,
        "level1_correct": 0.4, "unexplained": 0.02, "out_of_range": 0,
    }  # fmt: skip
    by_class = {
        "hps": {"level1_predicted": {"led": 0.7, "hid": 0.2, "lps": 0.05, "x": 0.05}},
        "mercury": {"level1_correct": 0.0},
    }
    text = em.readme_text(
        {
            "partitions": 4,
            "rows": [row, ridge],
            "unseen_types": {em.LOCO: {"overall": o, "by_class": by_class}},
        }
    )
    assert "| 0.97/0.95/0.96 |" in text
    assert "| ridge |" in text and text.count("| n/a |") >= 1
    assert "hps → led 0.70, hid 0.20, lps 0.05" in text and "x 0.05" not in text
    assert "mercury →" not in text
    assert list(em.UNSEEN) == ["inversion", "inversion-moon", em.LOCO]
