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
