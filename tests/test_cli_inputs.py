"""Issue 33: every input checked at the door. Each test names the item of the
issue it covers; a bad input exits 2 naming the option or file a user typed,
an odd one gives a physical answer."""

import json
import sys

import numpy as np
import pandas as pd
import pytest

from bandopt.cli import main


S = [
    "--lamps", "nist_traditional_hps", "--surfaces", "asphalt",
    "--atmospheres", "none", "--moon", "none", "--classes", "P4",
]  # fmt: skip


def refused(capsys, argv, *needles):
    """Run the CLI in-process; assert exit 2 and a last stderr line
    `bandopt ...: error: ...` holding every needle; return that line."""
    try:
        rc = main(argv)
    except SystemExit as e:  # argparse's usage errors
        rc = e.code
    err = capsys.readouterr().err.strip().splitlines()
    assert rc == 2, (rc, err)
    assert "Traceback" not in "\n".join(err)
    last = err[-1]
    assert last.startswith("bandopt ") and ": error: " in last, err
    for n in needles:
        assert n in last, (n, last)
    return last


def _radiances(out):
    table = pd.read_parquet(out / "radiances.parquet")
    cols = [c for c in table.columns if str(c).startswith("L_")]
    return table, cols


# items 3 and 4: photometry is scale-free and has one rule for null


W = np.arange(380.0, 901.0)


def _csv(path, values, w=W):
    path.write_text(
        "\n".join(f"{a:g},{b:.17g}" for a, b in zip(w, values, strict=True))
    )
    return path


def _warm_led():
    """A phosphor-converted LED shape: a 450 nm pump and a broad phosphor."""
    return 0.4 * np.exp(-0.5 * ((W - 450) / 10) ** 2) + np.exp(
        -0.5 * ((W - 610) / 60) ** 2
    )


def _line(centre_nm):
    """A 20 nm wide triangular line, exactly 0 outside it."""
    return np.clip(1.0 - np.abs(W - centre_nm) / 10.0, 0.0, None) + 0.0


def _metrics(capsys, *files):
    assert main(["metrics", *map(str, files), "--json"]) == 0
    return json.loads(capsys.readouterr().out)


@pytest.mark.parametrize("peak", [1e308, 1e-300, 3e-308])
def test_photometry_is_scale_free(peak, tmp_path, capsys):
    s = _warm_led()
    one = _csv(tmp_path / "one.csv", s / s.max())
    scaled = _csv(tmp_path / "scaled.csv", s / s.max() * peak)
    a, b = _metrics(capsys, one, scaled)
    for k in ("LER", "LER_full_range", "G", "CCT", "Duv"):
        assert a[k] is not None and b[k] == pytest.approx(a[k], rel=1e-9), k
    assert a["CCT"] < 5000.0 and a["G"] < 3.0  # warm, with blue light


def test_subnormal_spectrum_is_refused_with_the_reason(tmp_path, capsys):
    s = _warm_led()
    f = _csv(tmp_path / "tiny.csv", s / s.max() * 1e-318)
    refused(capsys, ["metrics", str(f)], str(f), "smallest normal")


def test_evaluate_reads_a_lamp_whatever_its_scale(tmp_path):
    from bandopt.cli._cmd_evaluate import load_user_lamp

    s = _warm_led()
    one, _ = load_user_lamp(_csv(tmp_path / "one.csv", s / s.max()))
    big, _ = load_user_lamp(_csv(tmp_path / "big.csv", s / s.max() * 1e308))
    np.testing.assert_allclose(big, one, rtol=1e-12)
    assert np.all(np.isfinite(big))


def test_no_visible_light_has_no_g_in_metrics_and_evaluate(tmp_path, capsys):
    from bandopt.estimate import lamp_truth

    (row,) = _metrics(capsys, _csv(tmp_path / "ir.csv", _line(850.0)))
    assert row["LER"] is None and row["G"] is None and row["CCT"] is None
    assert "no light in 380-780 nm" in row["null_reason"]["G"]
    _, valid = lamp_truth(_line(850.0)[None], W)
    assert not valid[0].any()


@pytest.mark.parametrize("centre", [380.0, 450.0, 700.0])
def test_cct_not_meaningful_is_null_in_metrics_as_in_evaluate(centre, tmp_path, capsys):
    from bandopt.estimate import lamp_truth

    (row,) = _metrics(capsys, _csv(tmp_path / "line.csv", _line(centre)))
    assert row["CCT"] is None and row["CCT_flag"] is True
    assert "not meaningful" in row["null_reason"]["CCT"]
    assert row["LER"] is not None and row["G"] is not None
    values, valid = lamp_truth(_line(centre)[None], W)
    assert not valid[0, 2]
    assert values[0, 0] == pytest.approx(row["LER"], rel=1e-12)
    assert values[0, 1] == pytest.approx(row["G"], rel=1e-12)


# item 8: task files carry and check their own key


def _opt_argv(out, n_bands="2"):
    return ["optimise", "--target", "cct", "--bands", n_bands, "--preset", "tiny",
            "--no-folds", "--out", str(out)]  # fmt: skip


def _task(n_bands=2):
    from bandopt.search import make_task

    return make_task(
        target="cct",
        n_bands=n_bands,
        pan="none",
        fold="final",
        seed=0,
        max_evals=400,
        preset="tiny",
        noise=None,
    )


@pytest.mark.parametrize("text", ["[]", '{"foo": 1}', "null", '{"task": 3}'])
def test_a_task_file_that_is_not_a_result_is_named(text, tmp_path, capsys):
    from bandopt.cli._cmd_optimise import check_task_files
    from bandopt.search._sweep import task_path

    out = tmp_path / "opt"
    path = task_path(out, _task())
    path.parent.mkdir(parents=True)
    path.write_text(text)
    refused(capsys, _opt_argv(out), str(path), "corrupt task file", "--force")
    assert path.is_file()
    check_task_files([_task()], out, force=True, log=sys.stderr)
    assert not path.exists()
    assert "recomputing (--force)" in capsys.readouterr().err


def test_another_runs_task_file_is_not_reused(tmp_path, capsys):
    """A --bands 3 result copied over the --bands 2 task file is refused,
    naming the file, instead of printing 3 bands for a 2-band run."""
    from bandopt.search._sweep import task_path

    out = tmp_path / "opt"
    path = task_path(out, _task(2))
    path.parent.mkdir(parents=True)
    path.write_text(json.dumps({"task": _task(3), "bands": {}, "wall_s": 1.0}))
    refused(capsys, _opt_argv(out), str(path), "another run")


# item 10: report names an unreadable results file


@pytest.mark.parametrize("text", ["{", b"\xff\xfe{}"])
def test_report_names_an_unreadable_results_file(text, tmp_path, capsys):
    res = tmp_path / "res"
    res.mkdir()
    bad = res / "recommendation.json"
    bad.write_bytes(text if isinstance(text, bytes) else text.encode())
    argv = ["report", "--results", str(res), "--out", str(tmp_path / "o")]
    refused(capsys, argv, str(bad))
    assert "disagree" not in capsys.readouterr().err


# item 1: --moon-zenith range


@pytest.mark.parametrize("zenith", ["180", "95", "90", "-10", "nan", "inf"])
def test_moon_zenith_outside_the_sky_is_refused(zenith, tmp_path, capsys):
    argv = ["simulate", "--bands", "sdgsat-1", *S[:6], "--moon", "full"]
    argv += ["--classes", "P6", "--moon-zenith", zenith, "--out", str(tmp_path / "o")]
    refused(capsys, argv, "--moon-zenith", "horizon")
    assert not (tmp_path / "o").exists()


def test_moon_zenith_beyond_the_atmosphere_table_names_the_option(tmp_path, capsys):
    argv = ["simulate", "--bands", "sdgsat-1", *S[:4], "--atmospheres"]
    argv += ["midlatitude_summer/urban/23", "--moon", "full", "--classes", "P6"]
    argv += ["--moon-zenith", "85", "--out", str(tmp_path / "o")]
    last = refused(capsys, argv, "--moon-zenith")
    assert "moon_zenith_deg" not in last


def test_moonlight_never_darkens_a_scene(tmp_path, capsys):
    """Near the horizon the Moon adds little light, never negative light."""
    out = tmp_path / "o"
    argv = ["simulate", "--bands", "sdgsat-1", "--lamps", "nist_traditional_lps"]
    argv += ["--surfaces", "snow", "--atmospheres", "none", "--moon", "none"]
    argv += ["full", "--moon-zenith", "89.9", "--classes", "P6", "--out", str(out)]
    assert main(argv) == 0
    table, cols = _radiances(out)
    dark = table[table["moon"] == "none"][cols].to_numpy(float)
    lit = table[table["moon"] != "none"][cols].to_numpy(float)
    assert np.all(lit >= dark)


# item 2: --bits with one scenario


def test_bits_with_one_value_per_band_is_refused(tmp_path, capsys):
    argv = ["simulate", "--bands", "sdgsat-1", *S, "--bits", "12"]
    refused(capsys, [*argv, "--out", str(tmp_path / "o")], "--bits", "one value")


@pytest.mark.parametrize("bits", ["0", "-3", "1.5", "100"])
def test_bits_outside_the_quantiser_range_is_refused(bits, tmp_path, capsys):
    argv = ["simulate", "--bands", "sdgsat-1", *S, "--bits", bits]
    refused(capsys, [*argv, "--out", str(tmp_path / "o")], "--bits")


def test_bits_quantise_to_finite_radiances(tmp_path, capsys):
    out = tmp_path / "o"
    argv = ["simulate", "--bands", "sdgsat-1", *S, "P6", "--bits", "4"]
    assert main([*argv, "--out", str(out), "--json"]) == 0
    summary = json.loads(capsys.readouterr().out)
    for band in summary["per_band"].values():
        assert band["min"] is not None and band["max"] is not None


# item 5: numeric options and option combinations checked at the door


@pytest.mark.parametrize(
    ("argv", "needle"),
    [
        (["radiometry", "--quick", "--read-noise", "-1"], "--read-noise"),
        (["radiometry", "--quick", "--dark-current", "nan"], "--dark-current"),
        (["radiometry", "--quick", "--gsd", "0"], "--gsd"),
        (["radiometry", "--quick", "--tdi", "0"], "--tdi"),
        (["radiometry", "--quick", "--snr", "inf"], "--snr"),
        (["simulate", "--bands", "sdgsat-1", *S, "--gsd", "0"], "--gsd"),
        (["moon", "--date", "2019-07-16", "--lat", "95", "--lon", "11"], "--lat"),
        (["moon", "--date", "2019-07-16", "--lat", "48", "--lon", "400"], "--lon"),
        (["moon", "--date", "2019-07-16", "--lat", "nan", "--lon", "11"], "--lat"),
        (["render", "--layout", "single", "--gsd", "-5"], "--gsd"),
        (["render", "--layout", "single", "--mtf-nyquist", "1.5"], "--mtf-nyquist"),
        (["optimise", "--target", "g", "--bands", "0"], "--bands"),
        (["optimise", "--target", "g", "--bands", "2", "--max-evals", "0"],
         "--max-evals"),
        (["surfaces", "--percentiles", "-5", "95"], "--percentiles"),
        (["evaluate", "--bands", "sdgsat-1", "--lamps", "x.csv", "--mixtures", "-1"],
         "--mixtures"),
        (["library", "--plot", ""], "--plot"),
        (["simulate", "--bands", "sdgsat-1", *S, "--out", " "], "--out"),
    ],
)  # fmt: skip
def test_bad_numbers_and_empty_values_are_refused(argv, needle, tmp_path, capsys):
    if argv[0] in ("radiometry", "render", "optimise") and "--out" not in argv:
        argv = [*argv, "--out", str(tmp_path / "o")]
    if argv[0] == "simulate" and "--out" not in argv:
        argv = [*argv, "--out", str(tmp_path / "o")]
    refused(capsys, argv, needle)
    assert not (tmp_path / "o").exists()


def test_optimise_noise_must_be_a_finite_radiance(tmp_path, capsys):
    argv = ["optimise", "--target", "g", "--bands", "2", "--preset", "tiny"]
    argv += ["--no-folds", "--noise", "inf", "--out", str(tmp_path / "o")]
    refused(capsys, argv, "--noise", "finite")


def test_render_neighbourhood_needs_an_atmosphere(tmp_path, capsys):
    argv = ["render", "--layout", "single", "--neighbourhood", "uniform"]
    refused(capsys, [*argv, "--out", str(tmp_path / "o")], "--neighbourhood")
    assert not (tmp_path / "o").exists()


def _contiguous_bands(tmp_path):
    from bandopt.sensor import BandSet

    f = tmp_path / "c26.json"
    BandSet.contiguous(26).to_json(f)
    return f


def test_direct_needs_a_surface(tmp_path, capsys):
    lamp = _csv(tmp_path / "led.csv", _warm_led())
    argv = ["evaluate", "--bands", str(_contiguous_bands(tmp_path)), "--lamps"]
    argv += [str(lamp), "--estimator", "direct"]
    refused(capsys, argv, "--surface")


def test_direct_refuses_a_black_surface(tmp_path, capsys):
    lamp = _csv(tmp_path / "led.csv", _warm_led())
    black = _csv(tmp_path / "black.csv", np.zeros(W.size))
    argv = ["evaluate", "--bands", str(_contiguous_bands(tmp_path)), "--lamps"]
    argv += [str(lamp), "--estimator", "direct", "--surface", str(black)]
    refused(capsys, argv, str(black), "no positive value")


# item 7: seeds


@pytest.mark.parametrize(
    "argv",
    [
        ["simulate", "--bands", "sdgsat-1", *S, "--noise"],
        ["classify", "--bands", "sdgsat-1"],
        ["render", "--layout", "single"],
        ["radiometry", "--quick"],
        ["optimise", "--target", "g", "--bands", "2", "--preset", "tiny"],
    ],
    ids=lambda a: a[0],
)
@pytest.mark.parametrize("seed", ["100000000000000000000000", "-5", "1.5"])
def test_seed_out_of_range_is_refused_before_the_run(argv, seed, tmp_path, capsys):
    out = ["--out", str(tmp_path / "o")] if argv[0] != "classify" else []
    refused(capsys, [*argv, "--seed", seed, *out], "--seed")
    assert not (tmp_path / "o").exists()


# item 9: --nights bounded up front


def test_nights_beyond_the_calendar_are_refused_up_front(capsys):
    argv = ["moon", "--date", "2019-07-16", "--lat", "48", "--lon", "11"]
    last = refused(capsys, [*argv, "--nights", "100000000"], "--nights", "9999-12-31")
    assert "----" not in last and "after 2914804 nights" in last, last
    refused(capsys, [*argv, "--nights", "0"], "--nights")
    argv[2] = "2019-07-16T01:30"
    refused(capsys, [*argv, "--nights", "100000000"], "--nights", "9999-12-31")


def test_the_last_calendar_night_is_computed(capsys):
    argv = ["moon", "--date", "9999-12-30", "--lat", "48", "--lon", "11"]
    assert main([*argv, "--nights", "2", "--json"]) == 0
    assert len(json.loads(capsys.readouterr().out)) == 2


def test_east_longitude_beyond_180_is_the_same_place(capsys):
    """item 5: `--lon 200` is accepted as 0-360 east, the convention of many
    ephemerides, and is the same place as `--lon -160` (the help says so);
    400 is refused (above)."""
    argv = ["moon", "--date", "2019-07-16", "--lat", "48", "--nights", "2", "--json"]
    assert main([*argv, "--lon", "200"]) == 0
    east = json.loads(capsys.readouterr().out)
    assert main([*argv, "--lon", "-160"]) == 0
    west = json.loads(capsys.readouterr().out)
    assert east == west


# item 11: one reader for every spectral file


@pytest.mark.parametrize("style", ["header", "semicolons", "tabs", "comment", "plain"])
def test_reflectance_files_read_like_lamp_files(style, tmp_path):
    from bandopt.cli._cmd_evaluate import read_reflectance
    from bandopt.spectra import GRID_1NM

    grid = np.asarray(GRID_1NM, float)
    r = 0.05 + 0.1 * (W - 380) / 520
    sep = {"semicolons": ";", "tabs": "\t"}.get(style, ",")
    lines = [f"{a:g}{sep}{b:.6g}" for a, b in zip(W, r, strict=True)]
    if style == "header":
        lines.insert(0, "wavelength_nm,reflectance")
    if style == "comment":
        lines.insert(0, "# measured 2026-11-27")
    f = tmp_path / "road.csv"
    f.write_text("\n".join(lines))
    got = read_reflectance(f, grid)
    np.testing.assert_allclose(got, np.interp(grid, W, r), rtol=1e-5)  # 6 digits


def test_reflectance_above_one_is_refused(tmp_path, capsys):
    from bandopt.cli._cmd_evaluate import read_reflectance
    from bandopt.spectra import GRID_1NM

    f = _csv(tmp_path / "percent.csv", np.full(W.size, 12.0))
    with pytest.raises(ValueError, match="above 1") as err:
        read_reflectance(f, np.asarray(GRID_1NM, float))
    assert str(f) in str(err.value)


# item 13: one rule for bands beyond the data


def _band_file(tmp_path, centre, fwhm):
    f = tmp_path / "edge.json"
    f.write_text(json.dumps({"name": "edge", "bands": [
        {"name": "mid", "centre_nm": 550.0, "fwhm_nm": 50.0},
        {"name": "edge", "centre_nm": centre, "fwhm_nm": fwhm},
    ]}))  # fmt: skip
    return f


def test_a_band_partly_beyond_the_data_is_a_warning(tmp_path, capsys):
    f = _band_file(tmp_path, 880.0, 80.0)
    argv = ["simulate", "--bands", str(f), *S, "--out", str(tmp_path / "o"), "--json"]
    assert main(argv) == 0
    cap = capsys.readouterr()
    (w,) = json.loads(cap.out)["warnings"]
    assert "band edge loses" in w and "warning: " + w in cap.err


def test_a_band_mostly_beyond_the_data_is_refused(tmp_path, capsys):
    f = _band_file(tmp_path, 905.0, 40.0)
    argv = ["simulate", "--bands", str(f), *S, "--out", str(tmp_path / "o")]
    refused(capsys, argv, str(f), "edge", "% of its response")


def test_a_reference_sensors_documented_loss_is_not_repeated(tmp_path, capsys):
    argv = ["simulate", "--bands", "sdgsat-1", *S, "--out", str(tmp_path / "o")]
    assert main([*argv, "--json"]) == 0
    cap = capsys.readouterr()
    assert any("loses" in w for w in json.loads(cap.out)["warnings"])
    assert "loses" not in cap.err
    assert main(["bands", "sdgsat-1"]) == 0
    assert "%" in capsys.readouterr().out  # the loss, stated where the set is shown


# item 14: bounded lines, streamed PRN, short quotes, memory errors name the file


def test_a_one_line_file_is_refused_without_reading_it_whole(tmp_path, capsys):
    import tracemalloc

    from bandopt.datasets.loaders import read_spectrum

    f = tmp_path / "one_line.csv"
    f.write_text(",".join(["1.0"] * 2_000_000))  # 8 MB, no newline
    tracemalloc.start()
    try:
        with pytest.raises(ValueError, match="line 1: longer than") as err:
            read_spectrum(f)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak < f.stat().st_size / 8  # one bounded line, never the file
    assert str(f) in str(err.value) and len(str(err.value)) < 400
    last = refused(capsys, ["metrics", str(f)], str(f))
    assert len(last) < 400


@pytest.mark.parametrize("suffix", [".csv", ".prn"])
def test_a_bad_line_is_quoted_short(suffix, tmp_path, capsys):
    f = tmp_path / f"bad{suffix}"
    head = '"REM: test (ENER)"\n' if suffix == ".prn" else ""
    rows = "\n".join(f"{w:g} 1.0" for w in W[:20])
    f.write_text(f"{head}{rows}\n400 {'x' * 900}\n")
    last = refused(capsys, ["metrics", str(f)], str(f), "line 2", "characters)")
    assert len(last) < 300


def test_prn_is_streamed_with_the_row_limit(tmp_path, monkeypatch):
    from bandopt.datasets import loaders

    monkeypatch.setattr(loaders, "CSV_CHUNK_ROWS", 100)
    monkeypatch.setattr(loaders, "MAX_CSV_ROWS", 300)
    f = tmp_path / "long.prn"
    f.write_text(
        '"REM: test (ENER)"\n'
        + "\n".join(f"{380 + i * 0.01:.2f} 1.0" for i in range(1000))
    )
    with pytest.raises(ValueError, match="more than 300 rows") as err:
        loaders.read_prn(f)
    assert str(f) in str(err.value)


def test_out_of_memory_names_the_file(tmp_path, capsys, monkeypatch):
    from bandopt.datasets import loaders

    def too_big(*a, **kw):
        raise MemoryError

    monkeypatch.setattr(loaders, "_parse_chunk", too_big)
    f = _csv(tmp_path / "led.csv", _warm_led())
    rc = main(["metrics", str(f)])
    err = capsys.readouterr().err.strip().splitlines()[-1]
    assert rc == 1 and "out of memory" in err and str(f) in err


# item 16: words a user reads


def test_errors_name_the_options_not_library_fields(tmp_path, capsys):
    argv = ["moon", "--date", "2019-07-16", "--lat", "48", "--lon", "11"]
    last = refused(capsys, [*argv, "--overpass", "25:00"], "--overpass")
    assert "local_time" not in last
    argv = ["simulate", "--bands", "sdgsat-1", *S[:4], "--atmospheres"]
    argv += ["midlatitude_summer/urban/0", *S[6:], "--out", str(tmp_path / "o")]
    last = refused(capsys, argv, "--atmospheres")
    assert "visibility_km" not in last


@pytest.mark.filterwarnings("always")
def test_warnings_are_one_clean_line(tmp_path, capsys):
    s = _warm_led()
    s[-5:] = -1e-3 * s.max()  # small negative noise: clipped with a warning
    f = _csv(tmp_path / "noisy.csv", s)
    assert main(["metrics", str(f)]) == 0
    err = capsys.readouterr().err
    lines = [x for x in err.splitlines() if "warning" in x]
    assert lines and all(x.startswith("bandopt metrics: warning: ") for x in lines)
    assert "loaders.py" not in err and "SpectrumWarning" not in err


@pytest.mark.filterwarnings("always")
def test_numpy_warnings_are_one_clean_line(capsys, monkeypatch):
    from bandopt.cli import _cmd_surfaces

    real = _cmd_surfaces._summary

    def noisy(*a, **kw):
        np.log(np.zeros(1))  # a RuntimeWarning from numpy
        return real(*a, **kw)

    monkeypatch.setattr(_cmd_surfaces, "_summary", noisy)
    assert main(["surfaces", "--json"]) == 0
    err = capsys.readouterr().err
    assert "bandopt surfaces: warning: divide by zero encountered in log" in err
    assert "RuntimeWarning" not in err and ".py:" not in err


def test_a_folder_or_device_is_not_called_missing(tmp_path, capsys):
    last = refused(capsys, ["metrics", str(tmp_path)], str(tmp_path), "folder")
    assert "no such file" not in last
    last = refused(capsys, ["metrics", "/dev/null"], "/dev/null", "not a regular")
    assert "no such file" not in last
    last = refused(capsys, ["bands", str(tmp_path)], str(tmp_path), "folder")
    assert "Unknown reference sensor" not in last


def test_a_binary_band_file_is_named(tmp_path, capsys):
    f = tmp_path / "garbage.csv"
    f.write_bytes(bytes(range(256)) * 4)
    refused(capsys, ["bands", str(f)], str(f), "UTF-8")


def test_bands_json_reads_back(tmp_path, capsys):
    assert main(["bands", "sdgsat-1", "--json"]) == 0
    f = tmp_path / "sdgsat.json"
    f.write_text(capsys.readouterr().out)
    assert main(["bands", str(f), "--json"]) == 0
    back = json.loads(capsys.readouterr().out)
    orig = json.loads(f.read_text())
    for a, b in zip(orig["bands"], back["bands"], strict=True):
        assert a["centre_nm"] == b["centre_nm"] and a["fwhm_nm"] == b["fwhm_nm"]
    assert main(["bands", "nightsat", "--json"]) == 0
    f.write_text(capsys.readouterr().out)
    refused(capsys, ["bands", str(f)], str(f), "tabulated")


def test_evaluate_help_opens_with_the_default_estimator(capsys):
    with pytest.raises(SystemExit):
        main(["evaluate", "--help"])
    text = " ".join(capsys.readouterr().out.split())
    opening = text[text.index("Estimate LER") :].split(":")[0]
    assert "by default with the physics-based inversion" in opening
    assert "ridge" not in opening.split("inversion")[0]


def test_sigterm_gives_a_message(capsys, monkeypatch):
    import os
    import signal

    from bandopt.cli import _cmd_surfaces

    def killed(*a, **kw):
        os.kill(os.getpid(), signal.SIGTERM)
        raise AssertionError("SIGTERM did not stop the command")

    monkeypatch.setattr(_cmd_surfaces, "_summary", killed)
    assert main(["surfaces"]) == 143
    err = capsys.readouterr().err.strip().splitlines()
    assert err[-1] == "bandopt surfaces: error: terminated (SIGTERM)"


# item 12: a dot in an --out folder name


def test_simulate_out_folder_may_have_a_dot(tmp_path, capsys):
    out = tmp_path / "run_v1.2"
    assert main(["simulate", "--bands", "sdgsat-1", *S, "--out", str(out)]) == 0
    assert (out / "radiances.parquet").is_file()


# item 15: a user's files, failed runs, locks, permissions, reproducible JSON


@pytest.mark.parametrize("kind", ["simulate", "bands"])
def test_an_existing_file_is_replaced_only_with_force(kind, tmp_path, capsys):
    f = tmp_path / "mine.csv"
    f.write_text("my data\n")
    if kind == "simulate":
        argv = ["simulate", "--bands", "sdgsat-1", *S, "--out", str(f)]
    else:
        argv = ["bands", "sdgsat-1", "--export-csv", str(f)]
    refused(capsys, argv, str(f), "--force")
    assert f.read_text() == "my data\n"
    assert main([*argv, "--force"]) == 0
    assert f.read_text() != "my data\n"


def test_a_failed_run_leaves_no_folder_behind(tmp_path, capsys):
    out = tmp_path / "new"
    argv = ["simulate", "--bands", "sdgsat-1", *S[:8], "--classes", "P99"]
    refused(capsys, [*argv, "--out", str(out)], "P99")
    assert not out.exists()
    argv = ["optimise", "--target", "g", "--bands", "2", "--preset", "tiny"]
    refused(capsys, [*argv, "--noise", "bogus", "--out", str(out)], "--noise")
    assert not out.exists()  # nor a lock file in it


def test_a_finished_run_leaves_no_lock(tmp_path):
    from bandopt.cli._output import LOCK_NAME, OutputLock

    with OutputLock(tmp_path / "o") as lock:
        assert (lock.directory / LOCK_NAME).is_file()
    assert not (tmp_path / "o" / LOCK_NAME).exists()
    with OutputLock(tmp_path / "o"):  # and the folder can be locked again
        pass


def test_task_files_have_the_permissions_of_other_outputs(tmp_path):
    import os

    from bandopt.search._sweep import _write_json

    mask = os.umask(0o022)
    try:
        _write_json(tmp_path / "t.json", {"a": 1})
    finally:
        os.umask(mask)
    assert (tmp_path / "t.json").stat().st_mode & 0o777 == 0o644


def test_optimise_json_is_the_same_for_the_same_seed(tmp_path, capsys):
    def run(out):
        argv = ["optimise", "--target", "g", "--bands", "2", "--preset", "tiny"]
        argv += ["--no-folds", "--max-evals", "20", "--out", str(out), "--json"]
        assert main(argv) == 0
        metrics = json.loads(capsys.readouterr().out)
        timing = metrics.pop("timing")
        assert timing["final_search_global"]["wall_s"] >= 0.0
        return metrics

    assert run(tmp_path / "a") == run(tmp_path / "b")


# item 5 (continued): a --prior-lamps class that does not fit its spectrum


def test_prior_lamp_of_the_wrong_class_is_warned():
    from bandopt.cli._cmd_evaluate import prior_class_warning
    from bandopt.datasets.lamps import library
    from bandopt.spectra import GRID_1NM

    grid = np.asarray(GRID_1NM, float)
    blue = np.exp(-0.5 * ((grid - 450.0) / 8.0) ** 2)
    w = prior_class_warning("led_amber", "blue.csv", blue, grid)
    assert w is not None and "blue.csv" in w and "led_amber" in w and "450 nm" in w
    lib = library().select(lamps_only=True)
    amber = next(
        i
        for i, r in enumerate(lib.records)
        if r.level2 == "led_amber" and np.all(np.isfinite(lib.values[i]))
    )
    assert prior_class_warning("led_amber", "a.csv", lib.values[amber], grid) is None


def test_evaluate_prints_the_prior_class_warning(tmp_path, capsys, monkeypatch):
    from bandopt.cli import _cmd_evaluate

    def stop(*a, **kw):
        raise ValueError("stopped before training (test)")

    monkeypatch.setattr(_cmd_evaluate, "obtain_fitted", stop)
    lamp = _csv(tmp_path / "led.csv", _warm_led())
    blue = _csv(tmp_path / "blue.csv", _line(450.0))
    argv = ["evaluate", "--bands", "sdgsat-1", "--lamps", str(lamp)]
    argv += ["--prior-lamps", f"led_amber={blue}"]
    try:
        rc = main(argv)
    except SystemExit as e:
        rc = e.code
    err = capsys.readouterr().err
    assert rc == 2 and "stopped before training" in err
    assert f"warning: --prior-lamps led_amber={blue}: its visible centroid" in err
