"""Issue 15 items 2 and 5: no silent wrong answers. Bands outside the data are
refused, an undefined number is `null` with a reason (never the invalid JSON
`NaN`), a band set without a usable ratio is warned about, a lamp outside the
scene is an error, the help says noisy radiances can be negative, and an
amber LED cut at 780 nm gets no sodium lines."""

import json
import math

import numpy as np
import pytest

from bandopt.cli import main
from bandopt.sensor import BandSet


def strict_json(text: str):
    """`json.loads` that refuses NaN and Infinity (not JSON, RFC 8259)."""

    def bad(c):
        raise ValueError(f"invalid JSON constant {c}")

    return json.loads(text, parse_constant=bad)


def _write_csv(path, w, s):
    path.write_text("\n".join(f"{a:g},{b:.10g}" for a, b in zip(w, s, strict=True)))
    return path


# -- item 5: NaN ---------------------------------------------------------------


def test_metrics_without_visible_light_is_valid_json_with_reasons(tmp_path, capsys):
    w = np.arange(380.0, 901.0)
    s = np.where(w > 800, np.exp(-0.5 * ((w - 850) / 10) ** 2), 0.0)
    f = _write_csv(tmp_path / "ir_only.csv", w, s)
    assert main(["metrics", str(f), "--json"]) == 0
    (row,) = strict_json(capsys.readouterr().out)
    for k in ("LER", "G", "CCT", "Duv"):
        assert row[k] is None
        assert "no light in 380-780 nm" in row["null_reason"][k]
    assert math.isfinite(row["LER_full_range"])  # defined: power beyond 780 nm


def test_metrics_table_says_why(tmp_path, capsys):
    w = np.arange(380.0, 901.0)
    s = np.where(w > 800, 1.0, 0.0)
    f = _write_csv(tmp_path / "ir.csv", w, s)
    assert main(["metrics", str(f)]) == 0
    out = capsys.readouterr().out
    assert "n/a" in out and "nan" not in out.lower().replace("n/a", "")
    assert "LER: no light in 380-780 nm" in out


def test_json_safe_turns_every_non_finite_into_null():
    from bandopt.cli._output import dumps

    obj = {"a": float("nan"), "b": [1.0, float("inf")], "c": np.float64("-inf")}
    assert strict_json(dumps(obj)) == {"a": None, "b": [1.0, None], "c": None}


# -- item 5: no usable ratio ----------------------------------------------------


def _bands(*centres_fwhm, name="test"):
    return BandSet.from_physical(
        centre_nm=[c for c, _ in centres_fwhm],
        fwhm_nm=[f for _, f in centres_fwhm],
        names=[f"b{i}" for i in range(len(centres_fwhm))],
        name=name,
    )


def test_no_usable_ratio_is_detected():
    from bandopt.cli._checks import has_usable_ratio, ratio_warning

    assert not has_usable_ratio(_bands((550.0, 50.0)))
    assert not has_usable_ratio(_bands((550.0, 50.0), (550.0, 50.0)))
    assert has_usable_ratio(_bands((550.0, 50.0), (650.0, 50.0)))
    assert has_usable_ratio(_bands((550.0, 50.0), (550.0, 80.0)))  # widths differ
    w = ratio_warning(_bands((550.0, 50.0), (550.0, 50.0)), "twin.json")
    assert "twin.json" in w and "training mean" in w and "identical" in w
    assert "one band" in ratio_warning(_bands((550.0, 50.0)), "one.json")


@pytest.mark.slow  # trains the estimators (~40 s)
def test_evaluate_warns_without_a_usable_ratio(tmp_path, capsys):
    f = tmp_path / "twin.json"
    f.write_text(
        json.dumps(
            {
                "name": "twin",
                "bands": [
                    {"name": "a", "centre_nm": 550, "fwhm_nm": 50},
                    {"name": "b", "centre_nm": 550, "fwhm_nm": 50},
                ],
            }
        )
    )
    w = np.arange(380.0, 901.0)
    lamp = _write_csv(tmp_path / "l.csv", w, np.exp(-0.5 * ((w - 600) / 60) ** 2))
    argv = ["evaluate", "--bands", str(f), "--lamps", str(lamp), "--json"]
    assert main([*argv, "--mixtures", "0"]) == 0  # the prior is not the point here
    cap = capsys.readouterr()
    out = strict_json(cap.out)
    assert any("no usable band ratio" in x for x in out["warnings"])
    assert "warning:" in cap.err and "training mean" in cap.err


# -- item 5: lamp outside the scene, negative radiances, amber LED ------------


def test_lamp_outside_the_scene_is_an_error(tmp_path, capsys):
    lay = tmp_path / "far.toml"
    lay.write_text(
        'name = "far"\nlength_m = 600.0\nwidth_m = 200.0\n\n'
        "[[lamp]]\nx_m = 5300.0\ny_m = 2.5\nmounting_height_m = 8.0\n"
        'luminaire = "road-optic"\nlamp = "nist_traditional_hps"\nflux_lm = 4000.0\n'
    )
    rc = main(["render", "--layout", str(lay), "--out", str(tmp_path / "o")])
    assert rc == 2
    err = capsys.readouterr().err
    assert "lamp 1" in err and "outside the scene" in err and "5300" in err
    assert not (tmp_path / "o").exists()


def test_simulate_help_says_noisy_radiance_can_be_negative(capsys):
    with pytest.raises(SystemExit):
        main(["simulate", "--help"])
    text = " ".join(capsys.readouterr().out.split())
    assert "CAN BE NEGATIVE" in text


def test_amber_led_cut_at_780_gets_no_sodium_lines(tmp_path):
    """A direct amber LED (589 nm, 15 nm wide: the narrowest measured amber
    LED is 14 nm) cut at 780 nm resembles the library's LPS spectrum most (the
    nearest-lamp rule added the Na 819 nm doublet); its band is wider than
    LPS's at any resolution up to 10 nm, hence an LED: no lines. A 12 nm band
    could be LPS read at 10 nm resolution: both candidates are extended."""
    from bandopt.cli._cmd_evaluate import load_user_lamp
    from bandopt.spectra import GRID_1NM

    w = np.arange(380.0, 781.0)
    s = np.exp(-0.5 * ((w - 589.0) / (15.0 / 2.3548)) ** 2)
    (values,), note = load_user_lamp(_write_csv(tmp_path / "amber.csv", w, s))
    assert note["nir_extension"] == "led"
    grid = np.asarray(GRID_1NM)
    na = (grid >= 815) & (grid <= 823)
    assert values[na].max() < 1e-6 * values.max()  # no 819 nm doublet
    s12 = np.exp(-0.5 * ((w - 589.0) / (12.0 / 2.3548)) ** 2)
    rows, note = load_user_lamp(_write_csv(tmp_path / "amber12.csv", w, s12))
    assert set(note["candidates"]) == {"lps", "led"} and len(rows) == 2
    assert "union over the candidates" in note["estimate_policy"]


def test_single_band_rule_matches_the_library():
    """Every library spectrum the rule calls a single-band emitter is an LED,
    and the measured LPS spectrum is not one (it is 3-6 nm wide)."""
    from bandopt.datasets import nir
    from bandopt.datasets.lamps import library

    lib = library(extend_nir=False)
    w = lib.wavelength_nm
    vis = (w >= 380) & (w <= 780)
    hits = [
        nir.technology_of(r.level2, r.level1)
        for r, v in zip(lib.records, lib.values, strict=True)
        if nir.is_single_band_emitter(w[vis], v[vis])
    ]
    assert hits and set(hits) == {"led"}
    lps = [v for r, v in zip(lib.records, lib.values, strict=True) if r.level2 == "lps"]
    assert lps and not any(nir.is_single_band_emitter(w[vis], v[vis]) for v in lps)


# -- item 2: bands outside the data -------------------------------------------

FAR = {
    "name": "far",
    "range_nm": [380, 1100],
    "bands": [
        {"name": "nir1000", "centre_nm": 1000, "fwhm_nm": 100},
        {"name": "green", "centre_nm": 550, "fwhm_nm": 50},
    ],
}


@pytest.mark.parametrize(
    "command",
    [
        ["simulate", "--lamps", "nist_traditional_hps", "--out", "{tmp}/r.csv"],
        ["classify", "--scenarios", "quick", "--no-noise"],
        ["render", "--layout", "single", "--out", "{tmp}/render"],
    ],
)
def test_band_outside_the_data_is_refused(command, tmp_path, capsys):
    f = tmp_path / "far.json"
    f.write_text(json.dumps(FAR))
    argv = [a.format(tmp=tmp_path) for a in command]
    flag = ["--bands", str(f)]
    rc = main([argv[0], *flag, *argv[1:]])
    assert rc == 2
    err = capsys.readouterr().err
    assert "nir1000" in err and "100.0 %" in err and "outside" in err
    assert not any(p.name != "far.json" for p in tmp_path.iterdir())


def test_partial_coverage_is_a_warning_naming_band_and_fraction():
    from bandopt.cli._checks import coverage_check
    from bandopt.sensor import reference_sensor

    warnings = coverage_check(reference_sensor("sdgsat-1"), source="sdgsat-1")
    assert len(warnings) == 2
    assert any("band PAN loses 3.6 %" in w for w in warnings)
    assert coverage_check(reference_sensor("aerocube"), source="aerocube") == []
