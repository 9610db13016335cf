import json
import os

import pytest

from bandopt.provenance import write_manifest


def test_manifest_records_what_made_a_result(tmp_path):
    path = write_manifest(tmp_path / "run", seed=7, config={"a": 1})
    m = json.loads(path.read_text())
    assert m["seed"] == 7 and m["config"] == {"a": 1}
    assert m["packages"]["jax"] and m["packages"]["colour-science"]
    assert {"lamps_li1800", "surfaces", "atmosphere", "moon"} <= set(m["data_versions"])
    lib = m["lamp_library"]
    assert lib["extended_spectra"] > 0 and "nir_extension" in lib
    assert "nist_traditional_lps" in lib["extended_unvalidated"]
    assert "command_line" in m and "git_commit" in m
    assert m["lamp_models"].startswith("not used")
    said = write_manifest(tmp_path / "models", lamp_models="used in training only")
    assert json.loads(said.read_text())["lamp_models"] == "used in training only"


def test_dirty_means_code_outside_results():
    """An experiment's own outputs (results/) do not make its manifest dirty;
    a changed module, a staged file or a rename does, named by its path."""
    from bandopt.provenance import _changed_code_paths, code_changes, manifest

    porcelain = "\n".join(
        [
            " M results/estimate/summary.json",
            "M  results/README.md",
            " M bandopt/inversion.py",
            "A  tests/test_new.py",
            'R  old name.py -> "bandopt/new name.py"',
        ]
    )
    assert _changed_code_paths(porcelain) == [
        "bandopt/inversion.py",
        "tests/test_new.py",
        "bandopt/new name.py",
    ]
    assert _changed_code_paths(" M results/a.json\n M results/b.png") == []
    m = manifest(seed=0)
    assert m["git_dirty"] == bool(code_changes())
    assert m["git_dirty_paths"] == code_changes()
    assert not any(p.startswith("results/") for p in m["git_dirty_paths"] or [])


def _git_repo(root):
    """A committed repository at `root` with one code file and results/."""
    import subprocess

    env = {
        "GIT_AUTHOR_NAME": "t", "GIT_AUTHOR_EMAIL": "t@t", "GIT_COMMITTER_NAME": "t",
        "GIT_COMMITTER_EMAIL": "t@t", "PATH": "/usr/bin:/bin", "HOME": str(root),
    }

    def git(*args):
        subprocess.run(["git", *args], cwd=root, env=env, check=True,
                       capture_output=True)

    root.mkdir()
    (root / "code.py").write_text("x = 1\n")
    (root / "results").mkdir()
    (root / "results" / "old.json").write_text("{}\n")
    git("init", "-q")
    git("add", ".")
    git("commit", "-q", "-m", "start")
    return root


@pytest.fixture
def repo(tmp_path, monkeypatch):
    """bandopt's git questions go to a fresh repository; no override set."""
    from bandopt import provenance

    root = _git_repo(tmp_path / "repo")
    monkeypatch.setattr(provenance, "CHECKOUT", root)
    monkeypatch.delenv(provenance.ALLOW_DIRTY_ENV, raising=False)
    return root


def test_results_are_written_from_a_clean_tree(repo):
    (repo / "results" / "old.json").write_text('{"new": 1}\n')  # outputs: not code
    m = json.loads(write_manifest(repo / "results" / "run").read_text())
    assert m["git_dirty"] is False and m["git_dirty_paths"] == []


def test_a_dirty_tree_is_refused_in_results_only(repo, tmp_path, monkeypatch):
    """Uncommitted code: no manifest in results/ (the error names the path
    and the override), elsewhere one marked dirty; the override writes it."""
    from bandopt.cli._output import write_manifest as cli_write_manifest
    from bandopt.provenance import ALLOW_DIRTY_ENV, DirtyTreeError

    (repo / "code.py").write_text("x = 2\n")
    target = repo / "results" / "run"
    for writer in (write_manifest, cli_write_manifest):
        with pytest.raises(DirtyTreeError, match=r"code\.py.*BANDOPT_ALLOW_DIRTY=1"):
            writer(target, seed=0)
        assert not (target / "manifest.json").exists()
    for elsewhere in (tmp_path / "scratch", repo / "results_old" / "run"):
        m = json.loads(write_manifest(elsewhere).read_text())
        assert m["git_dirty"] is True and m["git_dirty_paths"] == ["code.py"]
    monkeypatch.setenv(ALLOW_DIRTY_ENV, "1")
    m = json.loads(write_manifest(target).read_text())
    assert m["git_dirty"] is True and m["git_dirty_paths"] == ["code.py"]


def test_study_command_line_refuses_before_computing(repo, capsys):
    """A study's common parser refuses results/ from a dirty tree at once,
    and `--allow-dirty` lets it through for the manifest too."""
    import os

    from bandopt.provenance import ALLOW_DIRTY_ENV
    from bandopt.studies._units import partition_args

    out = str(repo / "results" / "study")
    args, _ = partition_args(["--out", out], "d", "results/x")  # clean: fine
    (repo / "code.py").write_text("x = 2\n")
    with pytest.raises(SystemExit) as exc:
        partition_args(["--out", out], "d", "results/x")
    assert exc.value.code == 2
    err = capsys.readouterr().err
    assert "code.py" in err and "--allow-dirty" in err
    args, _ = partition_args(["--out", out, "--allow-dirty"], "d", "results/x")
    assert args.allow_dirty and os.environ[ALLOW_DIRTY_ENV] == "1"
    write_manifest(out)


EXPERIMENTS_INTO_RESULTS = (
    ("experiments.search", ["run"], "results/search"),
    ("experiments.classify", [], "results/classify"),
    ("experiments.classify_partitions", [], "results/classify_partitions"),
    ("experiments.robustness", [], "results/robustness"),
    ("experiments.spatial", [], "results/spatial"),
    ("experiments.spatial_overlap", [], "results/spatial"),
    ("experiments.noise_aware", [], "results/noise_aware"),
    ("experiments.search_solvers", [], "results/search_solvers"),
    ("experiments.radiometry", [], "results/radiometry"),
    ("experiments.lamp_models", [], "results/library"),
    ("experiments.lamp_library", [], "results/library"),
    ("experiments.estimate", [], "results/estimate"),
    ("experiments.estimate_moon", [], "results/estimate_moon"),
    ("experiments.estimate_library", [], "results/estimate_library"),
    ("experiments.external_tm30", [], "results/external_tm30"),
    ("experiments.unseen_ceiling", [], "results/unseen_ceiling"),
    ("experiments.study", ["estimate-mix"], "results/estimate_mix"),
)


class _StopError(Exception):
    pass


@pytest.mark.parametrize(("module", "argv", "out"), EXPERIMENTS_INTO_RESULTS)
def test_experiments_check_the_tree_before_computing(module, argv, out, monkeypatch):
    """Every experiment that writes into results/ asks `check_clean_tree`
    about its output folder right after reading its command line (stopped
    there, so nothing is computed) and offers --allow-dirty."""
    import importlib

    from bandopt import provenance

    asked = []

    def stop(directory):
        asked.append(str(directory))
        raise _StopError

    monkeypatch.setattr(provenance, "check_clean_tree", stop)
    monkeypatch.delenv(provenance.ALLOW_DIRTY_ENV, raising=False)
    mod = importlib.import_module(module)
    main = getattr(mod, "main", None) or mod.cli
    with pytest.raises(_StopError):
        main([*argv, "--allow-dirty"])
    assert asked[0].replace("\\", "/").endswith(out), asked
    assert os.environ[provenance.ALLOW_DIRTY_ENV] == "1"
