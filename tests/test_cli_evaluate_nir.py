"""`bandopt evaluate --nir`: the NIR beyond a user spectrum's measured end
comes from its spectral features (or the user), the JSON says which and why,
and ambiguous evidence widens the intervals over every candidate."""

import json

import numpy as np
import pytest

from bandopt.cli import main


SNR_PER_NM = 30.0
"""Spectrometer noise of the field-like LED: mean visible level / 30 per nm."""

LER_TOLERANCE = 0.1
"""The LED's estimated LER lies within 10 % of its truth (the zero-NIR
estimate was exact; the fluorescent extension lost the type)."""


def _write_csv(path, w, s):
    path.write_text("\n".join(f"{a:g},{b:.10g}" for a, b in zip(w, s, strict=True)))
    return path


def _noisy_led_to_798(tmp_path):
    from bandopt.datasets.lamps import library

    lib = library(extend_nir=False)
    _, v = next(
        (r, v)
        for r, v in zip(lib.records, lib.values, strict=True)
        if r.level2 == "led_cool" and r.id.startswith("photobiology")
    )
    w = lib.wavelength_nm
    m = w <= 798
    rng = np.random.default_rng(7)
    x = v[m] + rng.normal(0.0, np.nanmean(v[m & (w <= 780)]) / SNR_PER_NM, m.sum())
    # the reader refuses negatives beyond 1 % of the peak: clipped, as many
    # spectrometer programs write them
    return _write_csv(tmp_path / "led798.csv", w[m], np.maximum(x, 0.0))


def test_bad_nir_is_refused_naming_the_option(tmp_path, capsys):
    w = np.arange(380.0, 781.0)
    f = _write_csv(tmp_path / "l.csv", w, np.exp(-0.5 * ((w - 600) / 60) ** 2))
    argv = ["evaluate", "--bands", "sdgsat-1", "--lamps", str(f), "--nir", "foo"]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert "--nir 'foo'" in err and "fluorescent" in err and "none" in err


def test_nir_choices_and_files_are_accepted(tmp_path):
    from bandopt.cli._cmd_evaluate import check_nir, load_user_lamp
    from bandopt.spectra import GRID_1NM

    f = _noisy_led_to_798(tmp_path)
    for value in ("none", "fluorescent", "auto", "LED"):
        check_nir(value)
    grid = np.asarray(GRID_1NM)
    (none,), note = load_user_lamp(f, "none")
    assert np.all(none[grid > 798] == 0) and note["nir_extension"] == "none"
    (fl,), note = load_user_lamp(f, "fluorescent")
    assert fl[-1] > 0  # the fluorescent model, not zeros
    assert note["nir_extension"] == "fluorescent"
    own = _write_csv(tmp_path / "own_nir.csv", np.arange(700.0, 901.0), np.ones(201))
    check_nir(str(own))
    (mine,), note = load_user_lamp(f, str(own))
    assert np.allclose(mine[grid > 798], 1.0) and note["nir_extension"] == "user"
    short = _write_csv(tmp_path / "short.csv", np.arange(700.0, 851.0), np.ones(151))
    with pytest.raises(ValueError, match="--nir"):
        load_user_lamp(f, str(short))


@pytest.mark.slow  # trains the inversion (~60 s)
def test_noisy_led_to_798_nm_is_an_led(tmp_path, capsys):
    """The field case: an LED measured to 798 nm with spectrometer noise is
    extended as an LED, named an LED, and its LER estimated closely."""
    f = _noisy_led_to_798(tmp_path)
    argv = ["evaluate", "--bands", "sdgsat-1", "--lamps", str(f), "--json"]
    assert main(argv) == 0
    out = json.loads(capsys.readouterr().out)
    (row,) = out["lamps"]
    (note,) = out["notes"]
    assert note["nir_extension"] == "led" and note["measured_to_nm"] == 798
    assert note["identification"]["evidence"]
    assert row["predicted_level1"] == "led"
    assert abs(row["estimate"]["LER"] / row["true"]["LER"] - 1) < LER_TOLERANCE
    assert "Hg 405/436/546/578 nm" in out["scene"]["nir_policy"]


def test_ambiguous_lamp_reports_candidates_and_union_intervals(tmp_path, capsys):
    """A lamp whose features are ambiguous runs the estimator once per
    candidate: the notes list the candidates, the intervals are their union
    (ridge: the estimator does not matter here)."""
    w = np.arange(380.0, 781.0)
    amber12 = np.exp(-0.5 * ((w - 589.0) / (12.0 / 2.3548)) ** 2)
    f = _write_csv(tmp_path / "amber12.csv", w, amber12)
    f_led = _noisy_led_to_798(tmp_path)
    argv = ["evaluate", "--bands", "sdgsat-1", "--lamps", str(f), str(f_led)]
    assert main([*argv, "--estimator", "ridge", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    amb, led = out["notes"]
    assert set(amb["candidates"]) == {"lps", "led"}
    assert "union" in amb["estimate_policy"]
    assert "candidates" not in led and led["nir_extension"] == "led"
    for r in out["lamps"]:
        for m, (lo, hi) in r["interval90"].items():
            assert lo <= r["estimate"][m] <= hi
    # the baselines flag what no library lamp looks like (issue 33, item 6)
    assert out["lamps"][1]["unexplained"] is False
    assert out["lamps"][1]["predicted_level1"] == "led"
    line = _write_csv(
        tmp_path / "line450.csv", w, np.exp(-0.5 * ((w - 450.0) / 2.0) ** 2)
    )
    argv = ["evaluate", "--bands", "sdgsat-1", "--lamps", str(line)]
    assert main([*argv, "--estimator", "ridge", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    (row,) = out["lamps"]
    assert row["unexplained"] is True and row["predicted_level1"] is None
    assert "unexplained" in row["null_reasons"]["type"]
    assert "bandopt.novelty" in out["scene"]["estimator_description"]
