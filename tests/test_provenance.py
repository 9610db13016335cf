import json

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
