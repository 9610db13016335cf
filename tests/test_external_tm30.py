"""`bandopt.studies.external_tm30` on synthetic `bandopt evaluate --json`
outputs: per-lamp scores (errors, coverage, level-1, a null CCT as
25,000 K, an unexplained lamp not scored as an error, out-of-range counts),
class-balanced summaries with bootstrap intervals, paired differences and
the README text. The run itself is `make external-tm30`."""

import json
from pathlib import Path

import numpy as np
import pytest

from bandopt.results import readme_section
from bandopt.studies import external_tm30 as ext


CLASSES = {
    "a1": ("led", "led_warm"), "a2": ("led", "led_warm"),
    "b1": ("hid", "hps"), "c1": ("led", "led_rgb"),
}  # fmt: skip


def _lamp(stem, est, true=(300.0, 1.0, 3000.0), l1="led", unexplained=False, iv=None):
    return {
        "file": f"/tmp/x/{stem}.csv",
        "true": dict(zip(ext.METRICS, true, strict=True)),
        "estimate": dict(zip(ext.METRICS, est, strict=True)),
        "interval90": iv
        or {"LER": [250.0, 350.0], "G": [0.5, 1.5], "CCT": [2000, 4000]},
        "unexplained": unexplained,
        "predicted_level1": None if unexplained else l1,
    }


def _output(scale=1.0):
    return {
        "lamps": [
            _lamp("a1", (300.0 + 10 * scale, 1.1, 3100.0)),
            _lamp("a2", (300.0 - 20 * scale, 0.9, None)),  # null CCT
            _lamp("b1", (None, None, None), l1=None, unexplained=True),
            _lamp("c1", (320.0, 1.0, 3000.0), l1="hid"),
        ]
    }


def test_lamp_rows_score_errors_coverage_and_flags():
    rows = {r["lamp"]: r for r in ext.lamp_rows(_output(), CLASSES)}
    assert rows["a1"]["LER"] == pytest.approx(10.0)
    assert rows["a1"]["CCT"] == pytest.approx(100.0)
    assert rows["a1"]["LER_covered"] is True and rows["a1"]["level1_correct"]
    assert rows["a2"]["CCT"] == pytest.approx(ext.CCT_NULL_K - 3000.0)
    b1 = rows["b1"]  # flagged, not guessed: no error, a wrong family
    assert b1["unexplained"] and b1["LER"] is None and b1["CCT"] is None
    assert not b1["level1_correct"]
    assert not rows["c1"]["level1_correct"]
    bad = _output()
    bad["lamps"][0]["estimate"]["LER"] = 700.0
    bad["lamps"][1]["estimate"]["LER"] = -1.0
    assert sum(r["out_of_range"] for r in ext.lamp_rows(bad, CLASSES)) == 2
    with pytest.raises(ValueError, match=r"unknown lamp file '/tmp/x/zz\.csv'"):
        ext.lamp_rows({"lamps": [_lamp("zz", (1.0, 1.0, 1.0))]}, CLASSES)


def test_summaries_are_class_balanced_with_unscored_classes_apart():
    s = ext.summarise(ext.lamp_rows(_output(), CLASSES), draws=200)
    assert s["classes"] == ["hps", "led_warm"] and s["lamps"] == 3
    # LER: led_warm (10 + 20) / 2 = 15; hps has none (unexplained)
    assert s["LER"] == pytest.approx(15.0)
    assert s["unexplained"] == pytest.approx((1.0 + 0.0) / 2)
    assert s["level1_correct"] == pytest.approx((0.0 + 1.0) / 2)
    lo, hi = s["LER_ci90"]
    assert 10.0 <= lo <= s["LER"] <= hi <= 20.0
    assert s["by_class"]["led_warm"]["lamps"] == 2
    assert s["unscored"]["led_rgb"]["lamps"] == 1
    assert s["unscored"]["led_rgb"]["LER"] == pytest.approx(20.0)
    assert s["out_of_range"] == 0


def test_paired_differences_on_the_same_lamps():
    ours = ext.lamp_rows(_output(1.0), CLASSES)
    theirs = ext.lamp_rows(_output(2.0), CLASSES)
    p = ext.paired(theirs, ours, draws=200)
    assert p["lamps"] == 3
    assert p["LER"] == pytest.approx(15.0)  # (10 + 20) / 2 more on led_warm
    assert p["LER_ci90"][0] <= 15.0 <= p["LER_ci90"][1]
    assert p["G"] == pytest.approx(0.0)


def test_readme_text_from_a_summary(tmp_path):
    rows = ext.lamp_rows(_output(), CLASSES)
    s = ext.summarise(rows, draws=100)
    summary = {
        "lamps": 4, "scene": "asphalt, atmosphere none, moonless, 5 lx, noise-free",
        "band_sets": {"recommended": s, "sdgsat-1": s},
        "paired": {"sdgsat-1": ext.paired(rows, rows, draws=100)},
        "in_library_reference": "recommended 11.2 lm/W / 0.296 / 369 K",
    }  # fmt: skip
    text = ext.readme_text(summary)
    assert text.startswith("## External check: `bandopt evaluate` on 4 measured lamps")
    assert "Class-balanced over the 2 scored classes (hps, led_warm; 3 lamps)" in text
    assert "| recommended | 15.0 [" in text
    assert "| 0.50 | 0.50 | 0 |" in text
    assert "| sdgsat-1 − recommended | 0.0 [0.0, 0.0] |" in text
    assert "Apart (led_rgb, a class the library does not score; 1 lamps)" in text
    assert "recommended 11.2 lm/W / 0.296 / 369 K" in text
    # hps's only lamp is unexplained: no error to give, said as n/a
    assert "hps (1) n/a lm/W, G n/a, CCT n/a K, level-1 0.00, unexplained 1.00" in text
    ext.figure(summary, tmp_path / "e.png")
    assert (tmp_path / "e.png").stat().st_size > 10_000


def test_committed_section_is_generated_from_the_committed_summary():
    root = Path(__file__).resolve().parents[1] / "results"
    path = root / "external_tm30" / "summary.json"
    if not path.is_file():
        pytest.skip("make external-tm30 not run")
    summary = json.loads(path.read_text())
    section = readme_section("external-tm30", root)
    assert section.strip() == ext.readme_text(summary).strip()
    for s in summary["band_sets"].values():
        assert s["out_of_range"] == 0 and s["tm30_lamps_in_prior"] == 0
    assert np.isfinite(summary["band_sets"]["recommended"]["LER"])


def test_surface_known_runs_in_the_readme_text():
    rows = ext.lamp_rows(_output(), CLASSES)
    worse = ext.lamp_rows(_output(scale=2.0), CLASSES)
    s = ext.summarise(rows, draws=100)
    summary = {
        "lamps": 4, "scene": "asphalt, atmosphere none, moonless, 5 lx, noise-free",
        "band_sets": {"recommended": s}, "paired": {},
        "surface_known": {"recommended, inversion": ext.summarise(worse, draws=100),
                          "contiguous-26, direct": s},
        "surface_known_paired": ext.paired(rows, worse, draws=100),
    }  # fmt: skip
    text = ext.readme_text(summary)
    assert "Told the scene's surface (`--surface asphalt`)" in text
    assert "| contiguous-26, direct | 15.0 [" in text
    assert "| recommended, inversion | 30.0 [" in text
    # led_warm's errors 10 and 20 against 20 and 40; hps unexplained in both
    better = "paired on the same lamps (negative: the direct estimate is better): "
    assert better + "LER -15.0 [" in text
    assert list(ext.SURFACE_KNOWN) == [
        "recommended, inversion", "contiguous-26, direct",
    ]  # fmt: skip
    assert ext.SURFACE_KNOWN["contiguous-26, direct"][1] == ("--estimator", "direct")


def test_lamp_files_are_what_evaluate_accepts(tmp_path):
    """Every TM-30 lamp file covers the 380-780 nm evaluate asks for: the
    measured values as the library holds them, and where the library cut the
    source's trailing zeros as the end of the measurement, zeros again."""
    from bandopt.cli._evaluate_inputs import load_user_lamp
    from bandopt.datasets.lamps import library

    lib = library(tm30=True, extend_nir=False)
    keep = [
        i
        for i, r in enumerate(lib.records)
        if r.source_set == "ies_tm30" and r.excluded is None and r.level2 is not None
    ]
    cut = [i for i in keep if (lib.records[i].cut_reason or "").startswith("zeros")]
    assert cut, "no TM-30 lamp is cut: the case this test is about is gone"
    files = ext.lamp_files(lib, [keep[0], *cut[:3]], tmp_path)
    for i, path in zip([keep[0], *cut[:3]], files, strict=True):
        w, v = np.loadtxt(path, delimiter=",", skiprows=1).T
        assert (w[0], w[-1]) == (380.0, 780.0)
        lo, hi = lib.records[i].measured_range_nm
        on = (lib.wavelength_nm >= lo) & (lib.wavelength_nm <= hi)
        np.testing.assert_array_equal(v[w <= hi], lib.values[i][on])
        assert np.all(v[w > hi] == 0.0)
        load_user_lamp(path)  # evaluate takes it
