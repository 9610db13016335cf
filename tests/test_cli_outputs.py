"""Issue 15 items 1 and 4: a command writes only where it is told, records how
its results were made, and writes its top-level files atomically under a lock.
"""

import hashlib
import json
import os
from pathlib import Path

import pytest

from bandopt.cli import main
from bandopt.cli._output import OutputLock, atomic_path, atomic_write_json


def _tree(root: Path) -> dict:
    """Relative path -> sha256 of every file under `root`."""
    return {
        str(p.relative_to(root)): hashlib.sha256(p.read_bytes()).hexdigest()
        for p in sorted(root.rglob("*"))
        if p.is_file()
    }


def _few_lamps():
    from bandopt.datasets.lamps import library

    return tuple(library().select(scored_only=True).ids[::12])


def test_radiometry_quick_leaves_results_untouched(tmp_path, monkeypatch, capsys):
    """Run from a scratch copy of results/ (the repository layout): the
    committed tables and recommendation.json are not rewritten; the output
    goes only to --out and records mode 'quick'."""
    results = tmp_path / "results"
    (results / "radiometry").mkdir(parents=True)
    (results / "radiometry" / "summary.json").write_text('{"mode": "full"}\n')
    (results / "recommendation.json").write_text(
        json.dumps({"radiometry": {"bit_depth": 12}, "spectral": {"bands": []}})
    )
    before = _tree(results)
    monkeypatch.chdir(tmp_path)
    args = ["--bands", "aerocube", "--quick", "--no-bit-depth", "--out", "scratch"]
    rc = main(["radiometry", *args, "--lamps", *_few_lamps()])
    assert rc == 0, capsys.readouterr().err
    assert _tree(results) == before  # nothing under results/ changed
    out = tmp_path / "scratch"
    summary = json.loads((out / "summary.json").read_text())
    assert summary["mode"] == "quick" and summary["config"]["mode"] == "quick"
    assert (out / "limits.csv").is_file() and (out / "manifest.json").is_file()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["results", "scratch"]


def test_radiometry_needs_an_explicit_out(capsys):
    with pytest.raises(SystemExit) as e:
        main(["radiometry", "--quick"])
    assert e.value.code == 2
    assert "--out" in capsys.readouterr().err


def test_ours_is_not_read_behind_the_users_back(tmp_path, capsys):
    rc = main(["radiometry", "--bands", "ours", "--out", str(tmp_path / "o")])
    assert rc == 2
    assert "results/recommendation.json" in capsys.readouterr().err


def test_recommendation_file_as_band_source(tmp_path):
    from bandopt.radiometry import load_band_set

    rec = tmp_path / "rec.json"
    rec.write_text(
        json.dumps(
            {
                "spectral": {
                    "bands": [
                        {"name": "b1", "centre_nm": 500.0, "fwhm_nm": 40.0},
                        {"name": "b2", "centre_nm": 600.0, "fwhm_nm": 40.0},
                    ]
                }
            }
        )
    )
    bands, label, note = load_band_set(str(rec))
    assert label == "ours" and list(bands.names) == ["b1", "b2"]
    assert str(rec) in note


def test_recommend_records_mode_and_settings(tmp_path):
    from bandopt.cli import run_radiometry
    from bandopt.radiometry import RadiometryConfig, load_band_set

    bands, _, _ = load_band_set("aerocube")
    cfg = RadiometryConfig.quick(bit_depth_table=False, lamps=_few_lamps())
    run_radiometry(
        bands,
        "aerocube",
        tmp_path / "out",
        config=cfg,
        recommend=tmp_path / "recommendation.json",
        log=lambda *_: None,
    )
    rec = json.loads((tmp_path / "recommendation.json").read_text())["radiometry"]
    assert rec["mode"] == "quick" and rec["made_by"]["mode"] == "quick"
    assert rec["settings"]["radiometry"]["mode"] == "quick"
    assert rec["settings"]["radiometry"]["lamps"] == list(_few_lamps())


# -- item 4: atomic files and the lock -----------------------------------------


def test_atomic_write_never_leaves_a_partial_file(tmp_path):
    path = tmp_path / "metrics.json"
    atomic_write_json(path, {"target": "cct"})
    with pytest.raises(RuntimeError), atomic_path(path) as tmp:
        Path(tmp).write_text('{"target": "g", "cut')  # a crash mid-write
        raise RuntimeError("killed")
    assert json.loads(path.read_text()) == {"target": "cct"}
    assert sorted(p.name for p in tmp_path.iterdir()) == ["metrics.json"]
    assert oct(path.stat().st_mode & 0o777) == oct(0o666 & ~_umask())


def _umask():
    m = os.umask(0)
    os.umask(m)
    return m


def test_lock_refuses_a_second_holder(tmp_path):
    with OutputLock(tmp_path / "o") as lock:
        assert str(os.getpid()) in lock.path.read_text()
        with pytest.raises(ValueError, match="another bandopt run"):
            OutputLock(tmp_path / "o").__enter__()
    with OutputLock(tmp_path / "o"):  # released on exit
        pass


@pytest.mark.slow  # two real optimise runs (~1 min each on 2 cores)
def test_two_concurrent_optimise_runs(tmp_path):
    import subprocess
    import sys

    root = Path(__file__).resolve().parents[1]
    env = {**os.environ, "PYTHONPATH": str(root)}
    out = tmp_path / "o"
    base = [sys.executable, "-m", "bandopt", "optimise", "--bands", "2"]
    tail = ["--preset", "tiny", "--max-evals", "5", "--no-folds", "--out", str(out)]
    first = subprocess.Popen(
        [*base, "--target", "cct", *tail], env=env, stderr=subprocess.PIPE
    )
    import time

    lock = out / ".bandopt.lock"
    for _ in range(600):
        if lock.is_file() and lock.read_text().strip():
            break
        time.sleep(0.1)
    second = subprocess.run(
        [*base, "--target", "g", *tail], env=env, capture_output=True, text=True
    )
    first.communicate(timeout=600)
    assert first.returncode == 0
    assert second.returncode == 2 and "another bandopt run" in second.stderr
    manifest = json.loads((out / "manifest.json").read_text())
    metrics = json.loads((out / "metrics.json").read_text())
    assert metrics["target"] == "cct"
    assert manifest["config"]["tasks"][0]["target"] == "cct"
