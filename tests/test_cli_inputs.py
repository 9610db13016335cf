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
