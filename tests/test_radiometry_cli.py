"""`bandopt radiometry` end to end on a tiny configuration, the bit-depth
recommendation rule and the measurement pipeline."""

import json

import numpy as np
import pytest

from bandopt.cli import main, run_radiometry
from bandopt.radiometry import (
    LinearQuantiser,
    RadiometryConfig,
    load_band_set,
    measure,
    study_band_set as load_ours,
)
from bandopt.radiometry._tables import recommend_bits


def test_help(capsys):
    with pytest.raises(SystemExit) as exc:
        main(["radiometry", "--help"])
    assert exc.value.code == 0
    assert "--bands" in capsys.readouterr().out


def test_bad_band_set_names_choices():
    with pytest.raises(ValueError, match="expected one of"):
        load_band_set("no-such-sensor")
    with pytest.raises(ValueError, match="no such band-set file"):
        load_band_set("missing.json")


def test_ours_reads_spectral_recommendation(tmp_path):
    (tmp_path / "recommendation.json").write_text(
        json.dumps(
            {
                "spectral": {
                    "bands": [
                        {"name": "b1", "centre_nm": 500.0, "fwhm_nm": 40.0},
                        {
                            "name": "b2",
                            "centre_nm": 600.0,
                            "fwhm_nm": 40.0,
                            "shape_k": 8.0,
                        },
                    ]
                }
            }
        )
    )
    bands, label, note = load_ours("ours", results_dir=tmp_path)
    assert label == "ours" and list(bands.names) == ["b1", "b2"] and "spectral" in note
    (tmp_path / "recommendation.json").write_text("{}")
    bands, _, note = load_ours("ours", results_dir=tmp_path)
    assert "default" in note and len(bands) == 4


def test_run_writes_tables_and_figures(tmp_path):
    bands, _, _ = load_band_set("aerocube")
    from bandopt.datasets.lamps import library

    few = tuple(library().select(scored_only=True).ids[::12])  # a handful of lamps
    cfg = RadiometryConfig.quick(bit_depth_table=False, lamps=few)
    summary = run_radiometry(
        bands,
        "aerocube",
        tmp_path / "out",
        config=cfg,
        recommend=tmp_path / "recommendation.json",
        log=lambda *_: None,
    )["summary"]
    out = tmp_path / "out"
    for name in (
        "distributions.csv",
        "limits.csv",
        "sensitivity.csv",
        "snr_ner.csv",
        "quantisation_noise.csv",
        "summary.json",
        "manifest.json",
        "histograms/aerocube.png",
    ):
        assert (out / name).is_file(), name
    rec = json.loads((tmp_path / "recommendation.json").read_text())["radiometry"]
    assert set(rec["detection_limit_w_m2_sr_nm"]) == {"blue", "green", "red"}
    for b in summary["bands"]:
        assert b["saturation_w_m2_sr_nm"] > b["detection_limit_w_m2_sr_nm"] > 0
    groups = {
        r.split(",")[1]
        for r in (out / "distributions.csv").read_text().splitlines()[1:]
    }
    assert groups == {"lamp", "moon", "uplight", "fire"}


def test_recommend_bits_rule():
    ref = {
        "scheme": "none",
        "bits": None,
        "LER_mae": 10.0,
        "G_mae": 0.1,
        "CCT_mae": 100.0,
        "macro_f1": 0.8,
    }

    def row(bits, f):
        return {
            "scheme": "linear",
            "bits": bits,
            "LER_mae": 10.0 * f,
            "G_mae": 0.1 * f,
            "CCT_mae": 100.0 * f,
            "macro_f1": 0.8 - 0.1 * (f - 1),
        }

    rows = [ref, row(8, 2.0), row(10, 1.2), row(12, 1.04), row(14, 1.06), row(16, 1.0)]
    # 12 passes but 14 does not: the rule asks for every larger depth to pass too
    assert recommend_bits(rows)["recommended_linear_bits"] == 16
    rows[4] = row(14, 1.01)
    out = recommend_bits(rows)
    assert out["recommended_linear_bits"] == 12 and out["agrees_with_thesis_ge_12_bits"]
    # companded schemes follow the same rule; the scheme needing fewer bits wins
    comp = [
        {**row(8, 1.2), "scheme": "sqrt"},
        {**row(10, 1.0), "scheme": "sqrt"},
        {**row(8, 1.0), "scheme": "two-gain"},
        {**row(10, 1.3), "scheme": "two-gain"},
        {**row(12, 1.0), "scheme": "two-gain"},
    ]
    out = recommend_bits(rows + comp)
    assert out["companded_bits_per_scheme"] == {"sqrt": 10, "two-gain": 12}
    assert out["recommended_companded_bits"] == 10
    assert out["recommended_companding"] == "sqrt"
    assert out["recommended_linear_bits"] == 12


def test_quantisation_error_shrinks_with_bits():
    from bandopt.scene import build_scenarios
    from bandopt.sensor import reference_sensor

    scen = build_scenarios(
        lamps=None,
        scored_only=True,
        surfaces=("asphalt",),
        atmospheres=("none",),
        moons=(None,),
        classes=("P6", "C0"),
    )
    bands = reference_sensor("aerocube")
    m = measure(scen, bands, seed=1)
    assert m.clean.shape == m.noisy.shape == (len(scen.lamp_ids) * 2, 3)
    # noise is unbiased: mean relative deviation near zero, spread ~ 1/sqrt(N),
    # over the rows whose band carries signal (LPS and amber LEDs put almost no
    # light into a blue band, where the relative deviation is unbounded)
    lit = m.clean >= 0.1 * np.median(m.clean, axis=0)
    rel = (m.noisy - m.clean)[lit] / m.clean[lit]
    assert abs(float(np.mean(rel))) < 0.05
    lo, hi = m.clean.min(0), m.clean.max(0) * 2
    err = [
        float(
            np.sqrt(
                np.mean(
                    (
                        np.asarray(LinearQuantiser(lo, hi, n)(m.noisy))
                        - np.clip(m.noisy, lo, hi)
                    )
                    ** 2
                )
            )
        )
        for n in (6, 10, 14)
    ]
    assert err[0] > err[1] > err[2]


@pytest.mark.slow  # ~20 s: photometric truth of every scored lamp
def test_standin_scores_are_sane():
    """The stand-in estimator and classifier: finite errors, F1 in [0, 1], and
    noise-free radiances score at least as well as 4-bit quantised ones."""
    from bandopt.radiometry import score
    from bandopt.scene import build_scenarios
    from bandopt.sensor import reference_sensor

    scen = build_scenarios(
        lamps=None,
        scored_only=True,
        surfaces=("asphalt",),
        atmospheres=("none",),
        moons=(None,),
        classes=("P6", "C0"),
    )
    m = measure(scen, reference_sensor("aerocube"), seed=0)
    clean = score(m.clean, scen, m.lamp_of, models="standin")
    assert clean["estimator"].startswith("stand-in")
    assert clean["classifier"].startswith("stand-in")
    assert 0.0 <= clean["macro_f1"] <= 1.0
    lo, hi = m.clean.min(0), m.clean.max(0)
    coarse = np.asarray(LinearQuantiser(lo, hi * 1.01, 4)(m.clean))
    worse = score(coarse, scen, m.lamp_of, models="standin")
    for k in ("LER_mae", "G_mae", "CCT_mae"):
        assert np.isfinite(clean[k]) and clean[k] <= worse[k] * 1.05
    with pytest.raises(ValueError, match="expected one of"):
        score(m.clean, scen, m.lamp_of, models="sklearn")


def test_default_scoring_runs_the_project_models_without_fallback():
    """By default `score` runs bandopt.estimate and bandopt.classify, named in
    the result (there is no silent switch to the stand-ins any more)."""
    from bandopt.datasets.lamps import library
    from bandopt.radiometry import score
    from bandopt.scene import build_scenarios
    from bandopt.sensor import reference_sensor

    lib = library().select(scored_only=True)
    ids = []
    for cls in ("hps", "metal_halide", "led_amber"):
        ids += [r.id for r in lib.records if r.level2 == cls][:6]
    scen = build_scenarios(
        lamps=tuple(ids),
        surfaces=("asphalt",),
        atmospheres=("none",),
        moons=(None,),
        classes=("P6",),
    )
    m = measure(scen, reference_sensor("aerocube"), seed=0)
    out = score(m.noisy, scen, m.lamp_of)
    assert out["estimator"] == "bandopt.estimate.fit_estimator"
    assert out["classifier"].startswith("bandopt.classify.evaluate_band_set")
    assert 0.0 <= out["macro_f1"] <= 1.0 and np.isfinite(out["LER_mae"])
