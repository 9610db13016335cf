"""`bandopt library` and `bandopt metrics`: output schema and values."""

import json

import colour
import numpy as np
import pytest

from bandopt.cli import build_parser, main


def test_every_command_has_help(capsys):
    parser = build_parser()
    sub = next(a for a in parser._actions if a.dest == "command")
    assert {"library", "metrics"} <= set(sub.choices)
    for name in sub.choices:
        with pytest.raises(SystemExit) as e:
            main([name, "--help"])
        assert e.value.code == 0
        assert "usage: bandopt " + name in capsys.readouterr().out


def test_library_json(capsys):
    assert main(["library", "--json"]) == 0
    rows = json.loads(capsys.readouterr().out)
    keys = {
        "id",
        "name",
        "level1",
        "level2",
        "source",
        "measured_range_nm",
        "extended",
        "LER",
        "G",
        "CCT",
        "Duv",
    }
    assert all(keys <= set(r) for r in rows)
    hps = next(r for r in rows if r["id"] == "nist_traditional_hps")
    sd = (
        colour.SDS_LIGHT_SOURCES["HPS"]
        .copy()
        .align(
            colour.SpectralShape(380, 780, 1), interpolator=colour.LinearInterpolator
        )
    )
    assert hps["LER"] == pytest.approx(colour.luminous_efficacy(sd), rel=1e-6)
    assert hps["level1"] == "hid" and hps["extended"] is True


def test_library_counts_json(capsys):
    assert main(["library", "--counts", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert {"counts", "rules"} <= set(out)
    assert sum(c["lamps"] for c in out["counts"]) >= 60


def test_library_plot(tmp_path):
    path = tmp_path / "lamps.png"
    assert main(["library", "--plot", str(path)]) == 0
    assert path.stat().st_size > 10_000


def test_metrics_json_in_input_order(tmp_path, capsys, shared_dir):
    w = np.arange(380.0, 781.0, 5.0)
    files = []
    for name in ("LED-B1", "LED-B5"):
        sd = colour.SDS_ILLUMINANTS[name]
        p = tmp_path / f"{name}.csv"
        p.write_text("wavelength_nm,value\n" + "\n".join(f"{x},{sd[x]}" for x in w))
        files.append(str(p))
    files.append(str(shared_dir / "data/lamps_nir_li1800/Osram.Super.Vialox.PRN"))
    assert main(["metrics", *files, "--json"]) == 0
    rows = json.loads(capsys.readouterr().out)
    assert [r["file"] for r in rows] == files
    assert set(rows[0]) == {
        "file",
        "LER",
        "LER_full_range",
        "G",
        "G_flag",
        "CCT",
        "Duv",
        "CCT_flag",
    }
    # Published CIE 015:2018 G values (JRC) within the summation-rule tolerance.
    assert rows[0]["G"] == pytest.approx(1.5304, abs=0.02)
    assert rows[1]["G"] == pytest.approx(0.3102, abs=0.02)
    # LER over 300-900 nm of a HPS lamp with strong NIR emission is lower.
    assert rows[2]["LER_full_range"] < rows[2]["LER"]


def test_metrics_bad_file_exit_code(tmp_path, capsys):
    bad = tmp_path / "bad.csv"
    bad.write_text("wavelength_nm,value\n380,1\n380,2\n")
    assert main(["metrics", str(bad)]) == 2
    err = capsys.readouterr().err
    assert "bad.csv" in err
