"""Issue 15 item 3: every failure is one line on stderr naming the path and the
problem, with a non-zero exit status, never a traceback."""

import os
import subprocess
import sys
from pathlib import Path

import pytest

from bandopt.cli import main
from bandopt.cli._output import OutputLock


ROOT = Path(__file__).resolve().parents[1]


def _env():
    env = dict(os.environ)
    env["PYTHONPATH"] = str(ROOT) + os.pathsep + env.get("PYTHONPATH", "")
    env.pop("BANDOPT_TRACEBACK", None)
    return env


def _one_line_error(capsys, rc, *needles):
    err = capsys.readouterr().err.strip().splitlines()
    assert rc != 0
    assert len(err) >= 1
    last = err[-1]
    assert last.startswith("bandopt ") and ": error: " in last, err
    assert "Traceback" not in "\n".join(err)
    for n in needles:
        assert n in last, (n, last)
    return last


def _blocked(tmp_path) -> Path:
    """A path whose parent is a regular file: no one (root included) can
    create it, so the test holds whoever runs it."""
    f = tmp_path / "a_file"
    f.write_text("not a folder\n")
    return f / "sub"


UNWRITABLE = {
    "atmospheres": lambda o: ["atmospheres", "--plot", f"{o}/a.png"],
    "bands --plot": lambda o: ["bands", "viirs-dnb", "--plot", f"{o}/b.png"],
    "bands --export-csv": lambda o: [
        "bands", "viirs-dnb", "--export-csv", f"{o}/b.csv",
    ],
    "library": lambda o: ["library", "--plot", f"{o}/l.png"],
    "moon": lambda o: [
        "moon", "--date", "2019-07-16", "--lat", "48", "--lon", "11", "--plot",
        f"{o}/m.png",
    ],
    "surfaces": lambda o: ["surfaces", "--plot", f"{o}/s.png"],
    "simulate": lambda o: [
        "simulate", "--bands", "sdgsat-1", "--lamps", "nist_traditional_hps",
        "--out", f"{o}/r.parquet",
    ],
    "optimise": lambda o: [
        "optimise", "--target", "cct", "--bands", "2", "--preset", "tiny",
        "--no-folds", "--out", f"{o}/opt",
    ],
    "render": lambda o: ["render", "--layout", "single", "--out", f"{o}/render"],
    "radiometry": lambda o: [
        "radiometry", "--bands", "aerocube", "--quick", "--out", f"{o}/rad",
    ],
}  # fmt: skip


@pytest.mark.parametrize("name", sorted(UNWRITABLE))
def test_unwritable_output_is_one_line(name, tmp_path, capsys):
    blocked = _blocked(tmp_path)
    rc = main(UNWRITABLE[name](blocked))
    line = _one_line_error(capsys, rc, str(tmp_path / "a_file"))
    assert "Not a directory" in line or "not a folder" in line
    assert not blocked.exists()


@pytest.mark.skipif(os.geteuid() == 0, reason="root ignores directory permissions")
def test_read_only_folder_is_one_line(tmp_path, capsys):
    ro = tmp_path / "ro"
    ro.mkdir()
    ro.chmod(0o555)
    try:
        rc = main(["surfaces", "--plot", str(ro / "s.png")])
    finally:
        ro.chmod(0o755)
    _one_line_error(capsys, rc, str(ro))


def test_closed_pipe_is_one_line():
    """`bandopt library | head -1` with the reader gone before the output."""
    p = subprocess.Popen(
        [sys.executable, "-m", "bandopt", "library"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        env=_env(),
    )
    p.stdout.close()  # the reader closes the pipe at once
    err = p.stderr.read().decode()
    p.stderr.close()
    p.wait(timeout=300)
    assert p.returncode == 141, err
    lines = err.strip().splitlines()
    assert lines == ["bandopt library: error: stdout: broken pipe (the reading "
                     "process closed it)"], err  # fmt: skip


def test_render_dx_zero(tmp_path, capsys):
    rc = main(["render", "--layout", "single", "--out", str(tmp_path), "--dx", "0"])
    assert rc == 2
    _one_line_error(capsys, rc, "--dx 0")


def _layout(path: Path, *, length_m: float, x_m: float) -> Path:
    path.write_text(
        f'name = "{path.stem}"\nlength_m = {length_m}\nwidth_m = 200.0\n\n'
        f"[[lamp]]\nx_m = {x_m}\ny_m = 2.5\nmounting_height_m = 8.0\n"
        'luminaire = "road-optic"\nlamp = "nist_traditional_hps"\nflux_lm = 4000.0\n'
    )
    return path


def test_huge_layout_is_refused_before_allocating(tmp_path, capsys):
    lay = _layout(tmp_path / "huge.toml", length_m=1e6, x_m=300.0)
    rc = main(["render", "--layout", str(lay), "--out", str(tmp_path / "o")])
    assert rc == 2
    line = _one_line_error(capsys, rc, "huge", "GiB", "--dx")
    assert "4000000 x 800 pixel" in line
    assert not (tmp_path / "o").exists()


def test_memory_error_is_one_line(tmp_path, capsys, monkeypatch):
    """A MemoryError raised anywhere (numpy's `_ArrayMemoryError` is one) is
    reported in one line. numpy raises it for an impossible allocation."""
    import numpy as np

    from bandopt.cli import _cmd_surfaces

    def too_big(_):
        return [np.empty((2**62,), np.uint8)]

    monkeypatch.setattr(_cmd_surfaces, "_summary", too_big)
    rc = main(["surfaces"])
    assert rc == 1
    _one_line_error(capsys, rc, "out of memory")


def _task_file(out: Path) -> Path:
    from bandopt.search import make_task
    from bandopt.search._sweep import task_path

    task = make_task(
        target="cct",
        n_bands=2,
        pan="none",
        fold="final",
        seed=0,
        max_evals=400,
        preset="tiny",
        noise=None,
    )
    return task_path(out, task)


def test_truncated_task_file_is_named(tmp_path, capsys):
    out = tmp_path / "opt"
    path = _task_file(out)
    path.parent.mkdir(parents=True)
    path.write_text('{"task": {"target": "cct"}, "loss": 0.1')  # cut short
    args = ["optimise", "--target", "cct", "--bands", "2", "--preset", "tiny"]
    rc = main([*args, "--no-folds", "--out", str(out)])
    assert rc == 2
    _one_line_error(capsys, rc, str(path), "corrupt task file", "--force")
    assert path.is_file()  # never deleted without --force


def test_force_removes_the_corrupt_task_file(tmp_path, capsys):
    from bandopt.cli._cmd_optimise import check_task_files
    from bandopt.search import make_task

    out = tmp_path / "opt"
    path = _task_file(out)
    path.parent.mkdir(parents=True)
    path.write_text("{")
    task = make_task(
        target="cct",
        n_bands=2,
        pan="none",
        fold="final",
        seed=0,
        max_evals=400,
        preset="tiny",
        noise=None,
    )
    check_task_files([task], out, force=True, log=sys.stderr)
    assert not path.exists()  # run_sweep recomputes it
    assert "recomputing (--force)" in capsys.readouterr().err


def test_load_results_names_a_corrupt_file(tmp_path):
    from bandopt.search import make_task
    from bandopt.search._sweep import load_results, task_path

    task = make_task(
        target="cct",
        n_bands=2,
        pan="none",
        fold="final",
        seed=0,
        max_evals=400,
        preset="tiny",
        noise=None,
    )
    path = task_path(tmp_path, task)
    path.parent.mkdir(parents=True)
    path.write_text("[1, 2")
    with pytest.raises(ValueError, match="corrupt task file") as err:
        load_results([task], tmp_path)
    assert str(path) in str(err.value)


def test_second_run_on_a_locked_folder_is_refused(tmp_path, capsys):
    out = tmp_path / "opt"
    with OutputLock(out):
        args = ["optimise", "--target", "g", "--bands", "2", "--preset", "tiny"]
        rc = main([*args, "--no-folds", "--out", str(out)])
    assert rc == 2
    _one_line_error(capsys, rc, str(out), "another bandopt run")
    assert sorted(p.name for p in out.iterdir()) == []  # no lock left behind


def test_lock_is_released_when_the_holder_dies(tmp_path):
    """A run killed with SIGKILL never blocks the folder: the kernel drops
    its flock with the process."""
    out = tmp_path / "o"
    code = (
        "import sys, time\n"
        "from bandopt.cli._output import OutputLock\n"
        f"with OutputLock({str(out)!r}):\n"
        "    print('locked', flush=True)\n"
        "    time.sleep(60)\n"
    )
    p = subprocess.Popen(
        [sys.executable, "-c", code], stdout=subprocess.PIPE, env=_env()
    )
    try:
        assert p.stdout.readline().strip() == b"locked"
        with pytest.raises(ValueError, match=r"another bandopt run \(pid"):
            OutputLock(out).__enter__()
        p.kill()
        p.wait(timeout=30)
        with OutputLock(out):
            pass
    finally:
        if p.poll() is None:
            p.kill()
            p.wait()
        p.stdout.close()


def test_internal_error_is_one_line(capsys, monkeypatch):
    from bandopt.cli import _cmd_surfaces

    def broken(_):
        raise KeyError("x")

    monkeypatch.setattr(_cmd_surfaces, "_summary", broken)
    monkeypatch.delenv("BANDOPT_TRACEBACK", raising=False)
    rc = main(["surfaces"])
    assert rc == 70
    _one_line_error(capsys, rc, "internal error KeyError", "BANDOPT_TRACEBACK")
