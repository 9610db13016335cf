"""`bandopt/studies/ablations/mix.py` and the study machinery: its pure
parts (the README table, the paired rows, the figure) on a hand-made
summary."""

import json

import numpy as np
import pytest

from bandopt import studies
from bandopt.studies.ablations import mix as em


def _summary():
    def row(est, ler, g, cct, l1):
        return {
            "band_set": "recommended", "surface": "unknown", "estimator": est,
            "LER": ler, "LER_sd": 0.5, "G": g, "G_sd": 0.02, "CCT": cct,
            "CCT_sd": 9.0, "LER_covered": 0.92, "G_covered": 0.9,
            "CCT_covered": 0.91, "level1_correct": l1,
        }  # fmt: skip

    o = {
        "LER_covered": 0.8, "G_covered": 0.81, "CCT_covered": 0.85,
        "level1_correct": 0.4, "unexplained": 0.02, "out_of_range": 0,
    }  # fmt: skip
    return {
        "partitions": 4,
        "estimators": list(em.ESTIMATORS),
        "title": em.TITLE,
        "mix_pairs": 50,
        "mix_fractions": [0.25, 0.5, 0.75],
        "oracle": {"LER": 0.04, "G": 0.0001, "sigma_rel": 0.003},
        "rows": [
            row("inversion-moon", 18.0, 0.38, 412.0, 0.83),
            row("inversion-moon-mix", 14.6, 0.29, 365.0, 0.85),
        ],
        "paired": [
            {
                "band_set": "recommended",
                "surface": "unknown",
                "estimator": "inversion-moon-mix",
                "vs": "inversion-moon",
                "LER_diff": -3.4,
                "LER_diff_sd": 0.6,
                "G_diff": -0.09,
                "G_diff_sd": 0.01,
            },
            {
                "band_set": "sdgsat-1",
                "surface": "unknown",
                "estimator": "inversion-moon-mix",
                "vs": "recommended",
                "LER_diff": 2.0,
                "LER_diff_sd": 0.5,
            },
        ],
        "unseen_types": {"inversion-moon-mix": {"overall": o, "by_class": {}}},
    }


def test_readme_table_and_paired_rows():
    text = em.readme_text(_summary())
    assert "mean ± SD over 4 partitions" in text
    assert "up to 50 pairs per class, flux fractions 0.25, 0.5, 0.75" in text
    assert "0.04 lm/W" in text  # the test-lamp-in-prior floor
    assert (
        "| recommended | unknown | inversion-moon-mix | 14.6 ± 0.5 | 0.290 ± 0.020 "
        "| 365 ± 9 | 0.92/0.90/0.91 | 0.85 |"
    ) in text
    assert (
        "| recommended: mix − no mix | inversion-moon-mix | unknown | -3.4 ± 0.6 "
        "| -0.090 ± 0.010 | n/a |"
    ) in text
    assert (
        "| sdgsat-1 − recommended | inversion-moon-mix | unknown | +2.0 ± 0.5" in text
    )
    assert "level-1 type right 0.40" in text
    assert "`-loco` calibrates" not in text  # no such run in this summary
    s = _summary()
    s["unseen_types"]["inversion-moon-mix-loco"] = s["unseen_types"][
        "inversion-moon-mix"
    ]
    assert "`-loco` calibrates the 90 % intervals" in em.readme_text(s)


def test_missing_values_are_said_not_invented():
    s = _summary()
    s["rows"][0].update(G=None, G_covered=None, level1_correct=None)
    text = em.readme_text(s)
    assert "| recommended | unknown | inversion-moon | 18.0 ± 0.5 | n/a |" in text
    assert "0.92/n/a/0.91 | n/a |" in text


def test_figure_is_written(tmp_path):
    path = tmp_path / "errors.png"
    studies.figure(_summary(), path)
    from matplotlib.image import imread

    img = imread(path)
    assert img.ndim == 3 and img.shape[0] > 100 and img.shape[1] > 500
    assert np.ptp(img[..., :3]) > 0  # not blank


def test_resumable_records_keep_finished_units_and_drop_a_torn_line(tmp_path):
    """`bandopt.studies.load_records` (used by every study):
    with `keep` the finished units come back and a half-written last line is
    dropped with a message naming the file and line; without it the file is
    deleted (recomputed, not replayed)."""
    from bandopt.studies import load_records

    path = tmp_path / "records.jsonl"
    good = [{"partition": 0, "band_set": "a"}, {"partition": 1, "band_set": "b"}]
    path.write_text("".join(json.dumps(r) + "\n" for r in good) + '{"partit')
    said = []
    records, done = load_records(path, keep=True, say=said.append)
    assert records == good and done == {(0, "a"), (1, "b")}
    assert said == [f"{path}:3: unreadable line dropped (interrupted write)"]
    assert load_records(path, keep=False, say=said.append) == ([], set())
    assert not path.exists()


def test_kept_units_are_read_back_on_resume(tmp_path):
    from bandopt.studies import keep_unit, load_records

    path = tmp_path / "records.jsonl"
    a = [{"partition": 0, "band_set": "x", "LER": 1.0}]
    b = [{"partition": 1, "band_set": "y", "LER": 2.0}]
    assert keep_unit(path, a) is a and keep_unit(path, b) is b
    assert load_records(path, keep=True, say=print) == (a + b, {(0, "x"), (1, "y")})


@pytest.mark.parametrize("study", ["estimate_mix", "estimate_library"])
def test_only_partitions_is_checked_before_any_work(study, capsys):
    import functools
    import importlib

    if study == "estimate_mix":
        main = functools.partial(studies.run, em.STUDY)
    else:
        main = importlib.import_module(f"experiments.{study}").main
    with pytest.raises(SystemExit):
        main(["--partitions", "2", "--only-partitions", "2", "--out", "x"])
    assert "each must be in 0..1" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        main(["--only-partitions", "0"])
    assert "needs its own --out" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        main(["--no-unseen"] if study == "estimate_library" else ["--partitions", "0"])
    err = capsys.readouterr().err
    assert ("unrecognized" if study == "estimate_library" else ">= 1") in err
