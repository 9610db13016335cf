"""Issue 15 items 6 and 7: conventions of well-kept command lines (--version,
bare help, --json everywhere, help with defaults, a fast listing) and a CSV
reader whose memory grows with the numbers, not the text."""

import argparse
import json
import os
import subprocess
import sys
import tracemalloc
from pathlib import Path

import numpy as np
import pytest

from bandopt.cli import build_parser, main


ROOT = Path(__file__).resolve().parents[1]


def _subparsers():
    parser = build_parser()
    sub = next(a for a in parser._actions if a.dest == "command")
    return sub.choices


def test_version(capsys):
    from bandopt import __version__

    with pytest.raises(SystemExit) as e:
        main(["--version"])
    assert e.value.code == 0
    assert capsys.readouterr().out.strip() == f"bandopt {__version__}"


def test_bare_bandopt_prints_help(capsys):
    assert main([]) == 2  # a usage error: no command
    err = capsys.readouterr().err
    assert err.startswith("usage: bandopt") and "library" in err and "render" in err


@pytest.mark.parametrize("name", ["simulate", "optimise", "radiometry", "render"])
def test_result_commands_have_json(name):
    opts = {o for a in _subparsers()[name]._actions for o in a.option_strings}
    assert "--json" in opts


def test_every_option_has_help_with_its_default():
    for name, p in _subparsers().items():
        for a in p._actions:
            if not a.option_strings or isinstance(a, argparse._HelpAction):
                continue
            assert a.help, (name, a.option_strings)
            text = a.help.lower()
            assert "default" in text or "required" in text, (name, a.option_strings)


def test_out_is_a_folder_everywhere():
    for name in ("optimise", "radiometry", "render", "simulate"):
        a = next(x for x in _subparsers()[name]._actions if "--out" in x.option_strings)
        assert a.metavar.startswith("DIR"), (name, a.metavar)


def test_help_points_to_commands_that_exist(capsys):
    """`classify --help` points to `bandopt bands --list`: it must exist."""
    with pytest.raises(SystemExit):
        main(["classify", "--help"])
    assert "bandopt bands --list" in " ".join(capsys.readouterr().out.split())
    assert main(["bands", "--list", "--json"]) == 0
    names = {r["name"] for r in json.loads(capsys.readouterr().out)}
    assert {"viirs-dnb", "sdgsat-1", "aerocube"} <= names
    assert main(["bands"]) == 2
    assert "--list" in capsys.readouterr().err


def test_simulate_out_folder(tmp_path, capsys):
    out = tmp_path / "sim"
    args = ["--bands", "aerocube", "--lamps", "nist_traditional_hps", "cie_led_b1",
            "--surfaces", "asphalt", "--moon", "none", "--json", "--classes", "P4",
            "--atmospheres", "none", "--out", str(out)]  # fmt: skip
    rc = main(["simulate", *args])
    assert rc == 0
    summary = json.loads(capsys.readouterr().out)
    assert summary["out"] == str(out / "radiances.parquet")
    names = sorted(p.name for p in out.iterdir())
    assert names == ["manifest.json", "radiances.parquet"]
    assert set(summary["per_band"]) == {"blue", "green", "red"}


def _run_library(env) -> tuple[str, bool]:
    code = (
        "import sys\n"
        "from bandopt.cli import main\n"
        "rc = main(['library', '--json'])\n"
        "print('jax imported:', 'jax' in sys.modules, file=sys.stderr)\n"
        "sys.exit(rc)\n"
    )
    p = subprocess.run(
        [sys.executable, "-c", code], env=env, capture_output=True, text=True
    )
    assert p.returncode == 0, p.stderr
    return p.stdout, "jax imported: True" in p.stderr


def test_library_listing_starts_without_jax_when_cached(tmp_path):
    """The second `bandopt library --json` reads the cached listing (same
    bytes as a fresh build) without importing JAX or building the library."""
    env = {
        **os.environ,
        "PYTHONPATH": str(ROOT),
        "BANDOPT_CACHE": str(tmp_path / "cache"),
    }
    env.pop("BANDOPT_NO_CACHE", None)
    fresh, jax_first = _run_library(env)
    cached, jax_second = _run_library(env)
    assert jax_first and not jax_second
    assert cached == fresh
    rows = json.loads(cached)
    assert len(rows) > 300 and {"id", "LER", "CCT"} <= set(rows[0])
    assert len(list((tmp_path / "cache").glob("library-*.json"))) == 1


def test_quick_compilations_reach_the_persistent_jax_cache(tmp_path):
    """The CLI's environment (set before JAX is imported) and `configure()`
    both cache every compiled program: a tiny jitted function, compiled in
    milliseconds, is written to the cache directory (at the old 0.5 s
    threshold nothing was)."""
    code = (
        "import os, sys\n"
        "from bandopt.cli import _configure_environment\n"
        "_configure_environment()\n"
        "assert 'jax' not in sys.modules\n"
        "print(os.environ['JAX_PERSISTENT_CACHE_MIN_COMPILE_TIME_SECS'])\n"
        "import jax\n"
        "print(jax.jit(lambda x: x * 3.0 + 1.0)(2.0))\n"
    )
    env = {
        **os.environ,
        "PYTHONPATH": str(ROOT),
        "BANDOPT_JAX_CACHE": str(tmp_path / "jax"),
    }
    p = subprocess.run(
        [sys.executable, "-c", code], env=env, capture_output=True, text=True
    )
    assert p.returncode == 0, p.stderr
    threshold, value = p.stdout.split()
    assert float(threshold) == 0.0 and float(value) == 7.0
    assert any((tmp_path / "jax").iterdir())
    import jax

    from bandopt._config import CACHE_MIN_COMPILE_S, configure

    configure(cache_dir=tmp_path / "jax2")
    assert jax.config.jax_persistent_cache_min_compile_time_secs == (
        CACHE_MIN_COMPILE_S
    )
    configure()  # back to the session's cache


def test_cache_key_changes_with_the_package(tmp_path, monkeypatch):
    from bandopt.cli import _cache

    k1 = _cache.key("library", {"counts": False})
    assert _cache.key("library", {"counts": True}) != k1
    monkeypatch.setenv("BANDOPT_LSPDD", "0")
    assert _cache.key("library", {"counts": False}) != k1


# -- item 6: the CSV reader -----------------------------------------------------


def _planck_csv(path: Path, n: int) -> Path:
    """A 2856 K Planck spectrum (CIE illuminant A) sampled n times in
    380-880 nm."""
    w = np.linspace(380.0, 880.0, n)
    v = w**-5 / np.expm1(1.438776877e7 / (w * 2856.0))
    with path.open("w") as fh:
        fh.write("wavelength_nm,value\n")
        np.savetxt(fh, np.c_[w, v / v.max()], fmt="%.6f,%.8g")
    return path


def test_csv_reader_memory_is_per_number_not_per_text(tmp_path, monkeypatch):
    """Five chunks of rows (50 000 rows in chunks of 10 000: 500 000 rows in
    the default chunks of 100 000 scaled down tenfold, the same peak per row,
    ~70 B, and a tenth of the rows to parse through the test suite's type
    checks, ~60 us a row): the former list-of-lists reader peaked at ~310
    bytes per row; the streamed reader holds float64 pairs (16 B per row)
    plus one chunk of text."""
    from bandopt.datasets import loaders

    monkeypatch.setattr(loaders, "CSV_CHUNK_ROWS", 10_000)
    n = 5 * loaders.CSV_CHUNK_ROWS
    f = _planck_csv(tmp_path / "big.csv", n)
    tracemalloc.start()
    try:
        s = loaders.read_csv(f)
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    assert s.wavelength_nm.shape == (n,)
    assert peak / n < 100, f"{peak / n:.0f} bytes per row"


def test_csv_reader_names_a_bad_line_in_a_later_chunk(tmp_path, monkeypatch):
    from bandopt.datasets import loaders

    monkeypatch.setattr(loaders, "CSV_CHUNK_ROWS", 50)
    w = np.arange(380.0, 781.0)
    lines = ["wavelength_nm,value"] + [f"{x:g},1.0" for x in w]
    lines[301] = "680,oops"  # file line 302
    f = tmp_path / "bad.csv"
    f.write_text("\n".join(lines) + "\n")
    with pytest.raises(ValueError, match=r"bad\.csv, line 302: cannot read numbers"):
        loaders.read_csv(f)
    lines[301] = "680,1.0,2.0"
    f.write_text("\n".join(lines) + "\n")
    with pytest.raises(ValueError, match=r"line 302: expected 2 columns"):
        loaders.read_csv(f)


def test_csv_reader_states_its_limit(tmp_path, monkeypatch):
    from bandopt.datasets import loaders

    monkeypatch.setattr(loaders, "CSV_CHUNK_ROWS", 100)
    monkeypatch.setattr(loaders, "MAX_CSV_ROWS", 150)
    f = _planck_csv(tmp_path / "long.csv", 1000)
    with pytest.raises(ValueError, match=r"long\.csv: more than 150 rows"):
        loaders.read_csv(f)


def test_csv_reader_chunks_agree_with_one_chunk(tmp_path, monkeypatch):
    from bandopt.datasets import loaders

    f = _planck_csv(tmp_path / "p.csv", 5000)
    one = loaders.read_csv(f)
    monkeypatch.setattr(loaders, "CSV_CHUNK_ROWS", 7)
    many = loaders.read_csv(f)
    np.testing.assert_array_equal(one.wavelength_nm, many.wavelength_nm)
    np.testing.assert_array_equal(one.values, many.values)
    # and with numpy's own reader of the same file
    ref = np.loadtxt(f, delimiter=",", skiprows=1)
    np.testing.assert_array_equal(one.wavelength_nm, ref[:, 0])


def test_progress_lines_with_time_left(tmp_path, monkeypatch):
    """A phase longer than FIRST_REPORT_S reports elapsed time; the time left
    comes from the last run of the same phase (never guessed)."""
    import io
    import time

    from bandopt.cli import _progress

    monkeypatch.setenv("BANDOPT_CACHE", str(tmp_path))
    monkeypatch.setenv("BANDOPT_PROGRESS", "1")
    monkeypatch.setattr(_progress, "FIRST_REPORT_S", 0.05)
    monkeypatch.setattr(_progress, "EVERY_S", 0.05)
    first, second = io.StringIO(), io.StringIO()
    with _progress.phase("train", "k", stream=first):
        time.sleep(0.3)
    assert "elapsed, time left unknown" in first.getvalue()
    assert _progress.last_duration("k") >= 0.3
    with _progress.phase("train", "k", stream=second):
        time.sleep(0.12)
    assert "left (last run: 0 s)" in second.getvalue()
    monkeypatch.setenv("BANDOPT_PROGRESS", "0")
    silent = io.StringIO()
    with _progress.phase("train", "k", stream=silent):
        time.sleep(0.12)
    assert silent.getvalue() == ""
