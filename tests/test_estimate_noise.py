"""`bandopt/studies/ablations/noise.py`: its study and README text on a hand-made
summary (the runs themselves are `make study NAME=estimate-noise`)."""

from bandopt import inversion as inv_mod
from bandopt.studies import run
from bandopt.studies.ablations import noise as en


def _row(band_set, est, ler):
    return {
        "band_set": band_set, "estimator": est, "surface": "unknown",
        "LER": ler, "LER_sd": 1.0, "G": 0.3, "G_sd": 0.01, "CCT": 350.0,
        "CCT_sd": 20.0, "LER_covered": 0.95, "G_covered": 0.9,
        "CCT_covered": None, "level1_correct": 0.85,
    }  # fmt: skip


def test_study_compares_one_model_with_one_per_metric_for_every_band_set():
    s = en.STUDY
    assert s.estimators == (en.ONE, en.PER) and s.pairs == ((en.PER, en.ONE),)
    assert set(s.band_sets) == {"recommended", "sdgsat-1", "nightsat"}
    assert all(m == ("unknown",) for m in s.band_sets.values())
    opts = [inv_mod.options_of(u) for u in s.unseen]
    assert [o.sigma_rule for o in opts] == ["error", "per-metric"]
    assert all(o.calibration == "classes" for o in opts)  # evaluate's intervals
    assert s.readme is en.readme_text and s.out == "results/estimate_noise"


def test_readme_table_and_paired_rows():
    summary = {
        "partitions": 4,
        "sigma_grid": [0.003, 0.03],
        "floor_grid": [0.001, 0.01],
        "rows": [_row("recommended", en.ONE, 14.9), _row("recommended", en.PER, 12.1)],
        "paired": [
            {
                "band_set": "recommended",
                "estimator": en.PER,
                "vs": en.ONE,
                "LER_diff": -2.8,
                "LER_diff_sd": 0.5,
            },
            {
                "band_set": "nightsat",
                "estimator": en.PER,
                "vs": "recommended",
                "LER_diff": 1.0,
                "LER_diff_sd": 0.7,
            },
        ],
        "unseen_types": {},
    }
    text = en.readme_text(summary)
    assert "| recommended | inversion-moon-mix-metric | 12.1 ± 1.0 |" in text
    assert "0.95/0.90/n/a" in text
    assert "| recommended: per metric − one model | inversion-moon-mix-metric |" in text
    assert "| nightsat − recommended | inversion-moon-mix-metric |" in text
    assert "(0.003, 0.03) and floor (0.001, 0.01)" in text


def test_help_is_this_studys(capsys):
    import pytest

    with pytest.raises(SystemExit):
        run(en.STUDY, ["--help"])
    assert "A band-error model per metric" in capsys.readouterr().out
