"""Issue 33, property test: every numeric option gets its edge values (0,
negative, NaN, infinity, huge, tiny) and every file option an empty, a
binary, a huge-line, a headered and a semicolon-separated file. Each input
either exits 2 with the option (or file) a user typed on the last stderr
line, or gives a physical answer (strict JSON, finite numbers in range).

A parametrised table, not hypothesis: the inputs are the edge values
themselves. Commands that run in seconds on the tiny scenario set are run
to the end; for the commands that train estimators or search bands
(`optimise`, `classify`, `evaluate`, `radiometry`, `render`) the numbers are
run through the parser, where every bound is enforced (a non-finite value a
command checks itself is run: it must stop before any work), and their file
options are fed to the command up to the point where the file is read
(before any training) or to the reader the command uses.
"""

import json
import math
from dataclasses import dataclass

import numpy as np
import pytest

from bandopt.cli import build_parser, main


FLOAT_EDGES = ("0", "-1", "nan", "inf", "-inf", "1e308", "1e-308")
INT_EDGES = ("0", "-1", "nan", "1.5", "1e308", "100000000000000000000000")

S = [
    "--lamps", "nist_traditional_hps", "--surfaces", "asphalt",
    "--atmospheres", "none", "--moon", "none", "full", "--classes", "P4",
]  # fmt: skip


@dataclass(frozen=True)
class Numeric:
    argv: tuple[str, ...]  # the command and what it needs, before the option
    option: str
    kind: str  # "float" or "int"
    run: bool  # run to the end (seconds) or through the parser only
    tail: tuple[str, ...] = ()  # after the value (a second value)

    @property
    def id(self) -> str:
        return f"{self.argv[0]} {self.option}"


NUMERIC = [
    Numeric(("simulate", "--bands", "sdgsat-1", *S, "--noise"), "--moon-zenith",
            "float", True),
    Numeric(("simulate", "--bands", "sdgsat-1", *S, "--noise"), "--uplight",
            "float", True),
    Numeric(("simulate", "--bands", "sdgsat-1", *S, "--noise"), "--gsd",
            "float", True),
    Numeric(("simulate", "--bands", "sdgsat-1", *S[:10], "P4", "P6"), "--bits",
            "int", True),
    Numeric(("simulate", "--bands", "sdgsat-1", *S, "--noise"), "--seed",
            "int", True),
    Numeric(("moon", "--date", "2019-07-16", "--lon", "11"), "--lat", "float",
            True),
    Numeric(("moon", "--date", "2019-07-16", "--lat", "48"), "--lon", "float",
            True),
    Numeric(("moon", "--date", "2019-07-16", "--lat", "48", "--lon", "11"),
            "--nights", "int", True),
    Numeric(("surfaces",), "--percentiles", "float", True, ("95",)),
    Numeric(("surfaces", "--percentiles", "5"), "", "float", True),
    *(Numeric(("radiometry", "--quick"), o, "float", False)
      for o in ("--snr", "--dim-percentile", "--headroom", "--gsd",
                "--read-noise", "--dark-current")),
    *(Numeric(("radiometry", "--quick"), o, "int", False)
      for o in ("--tdi", "--seed")),
    *(Numeric(("render", "--layout", "single"), o, "float", False)
      for o in ("--gsd", "--dx", "--mtf-nyquist")),
    Numeric(("render", "--layout", "single"), "--seed", "int", False),
    *(Numeric(("optimise", "--target", "g", "--preset", "tiny"), o, "int", False)
      for o in ("--bands",)),
    *(Numeric(("optimise", "--target", "g", "--bands", "2", "--preset", "tiny"),
              o, "int", False)
      for o in ("--max-evals", "--seed")),
    Numeric(("optimise", "--target", "g", "--bands", "2", "--preset", "tiny"),
            "--noise", "float", False),
    *(Numeric(("classify", "--bands", "sdgsat-1"), o, "int", False)
      for o in ("--modelled-per-class", "--mixtures", "--seed")),
    *(Numeric(("evaluate", "--bands", "sdgsat-1", "--lamps", "x.csv"), o, "int",
              False)
      for o in ("--modelled-per-class", "--mixtures")),
]  # fmt: skip

NUMERIC_CASES = [
    pytest.param(n, v, id=f"{n.id or n.argv[0] + ' HIGH'}={v}")
    for n in NUMERIC
    for v in (FLOAT_EDGES if n.kind == "float" else INT_EDGES)
]


def _exit(argv, capsys):
    """(exit status, stdout, last stderr line) of an in-process run."""
    try:
        rc = main(argv)
    except SystemExit as e:  # argparse's usage errors and --help
        rc = e.code
    cap = capsys.readouterr()
    err = cap.err.strip().splitlines()
    assert "Traceback" not in cap.err
    return rc, cap.out, (err[-1] if err else "")


def strict(text: str):
    def bad(c):
        raise ValueError(f"invalid JSON constant {c}")

    return json.loads(text, parse_constant=bad)


def _finite_numbers(obj) -> bool:
    if isinstance(obj, float):
        return math.isfinite(obj)
    if isinstance(obj, dict):
        return all(_finite_numbers(v) for v in obj.values())
    if isinstance(obj, list):
        return all(_finite_numbers(v) for v in obj)
    return True


def _physical(command: str, out: str) -> None:
    """The answer of an accepted edge value is a physical one."""
    data = strict(out)
    assert _finite_numbers(data)
    if command == "simulate":
        for band in data["per_band"].values():
            assert band["min"] is not None and band["max"] is not None, data
    elif command == "moon":
        for night in data if isinstance(data, list) else [data]:
            assert 0.0 <= night["zenith_deg"] <= 180.0
            irr = night["irradiance"]
            assert irr is not None or night["reason"]
            if irr is not None:
                assert irr["illuminance_toa_horizontal_lx"] >= 0.0
    elif command == "surfaces":
        assert data


@pytest.mark.parametrize(("case", "value"), NUMERIC_CASES)
def test_numeric_edge_values(case, value, tmp_path, capsys):
    option = case.option or "--percentiles"
    argv = [*case.argv, *([case.option] if case.option else []), value, *case.tail]
    if case.argv[0] in ("simulate", "radiometry", "render", "optimise"):
        argv += ["--out", str(tmp_path / "o")]
    if not case.run:
        try:
            build_parser().parse_args(argv)
        except SystemExit as e:
            assert e.code == 2
            last = capsys.readouterr().err.strip().splitlines()[-1]
            assert option in last, last
            return
        if math.isfinite(float(value)):
            return  # accepted by the parser: a finite number within range
        # a non-finite value the command checks itself, before any work
        rc, _, last = _exit(argv, capsys)
        assert rc == 2 and option in last, (rc, last)
        assert not (tmp_path / "o").exists()
        return
    if case.argv[0] in ("simulate", "moon", "surfaces"):
        argv.append("--json")
    rc, out, last = _exit(argv, capsys)
    if rc == 2:
        assert option in last, last
    else:
        assert rc == 0, (rc, last)
        _physical(case.argv[0], out)


# -- file options ---------------------------------------------------------------

W = np.arange(380.0, 901.0)
LED = 0.4 * np.exp(-0.5 * ((W - 450) / 10) ** 2) + np.exp(
    -0.5 * ((W - 610) / 60) ** 2
)


def _rows(sep=",", w=W, s=LED):
    return "\n".join(f"{a:g}{sep}{b:.8g}" for a, b in zip(w, s, strict=True))


FILES = {
    "empty": b"",
    "binary": bytes(range(256)) * 16,
    "huge-line": ("380," + "1" * 2_000_000).encode(),
    "headered": ("wavelength_nm,value\n" + _rows()).encode(),
    "semicolons": _rows(";").encode(),
}
GOOD = {"headered", "semicolons"}  # a spectrum file: readable, physical


def _file(tmp_path, kind, name="f.csv"):
    path = tmp_path / name
    path.write_bytes(FILES[kind])
    return path


@pytest.mark.parametrize("kind", sorted(FILES))
def test_metrics_file(kind, tmp_path, capsys):
    f = _file(tmp_path, kind)
    rc, out, last = _exit(["metrics", str(f), "--json"], capsys)
    if kind in GOOD:
        assert rc == 0
        (row,) = strict(out)
        assert 0.0 < row["LER"] <= 683.002 and 0.0 < row["G"] < 10.0
        assert 1000.0 <= row["CCT"] <= 25000.0
    else:
        assert rc == 2 and str(f) in last, last


def _evaluate(tmp_path, *extra):
    lamp = tmp_path / "lamp.csv"
    lamp.write_text(_rows())
    return ["evaluate", "--bands", "sdgsat-1", "--lamps", str(lamp), *extra]


@pytest.mark.parametrize("kind", sorted(FILES))
@pytest.mark.parametrize("option", ["--lamps", "--surface", "--prior-lamps", "--nir"])
def test_evaluate_file_options(option, kind, tmp_path, capsys):
    """A bad file is refused before anything trains; a good one is read by
    the command's own reader into a physical spectrum."""
    from bandopt.cli._cmd_evaluate import load_user_lamp, read_reflectance
    from bandopt.spectra import GRID_1NM

    f = _file(tmp_path, kind)
    if option == "--lamps":
        argv = ["evaluate", "--bands", "sdgsat-1", "--lamps", str(f)]
    elif option == "--surface":
        argv = _evaluate(tmp_path, "--surface", str(f))
    elif option == "--prior-lamps":
        argv = _evaluate(tmp_path, "--prior-lamps", f"led_warm={f}")
    else:  # the lamp ends at 780 nm, so its NIR part is read from the file
        lamp = tmp_path / "short.csv"
        lamp.write_text(_rows(w=W[W <= 780], s=LED[W <= 780]))
        argv = ["evaluate", "--bands", "sdgsat-1", "--lamps", str(lamp)]
        argv += ["--nir", str(f)]
    if kind not in GOOD:
        rc, _, last = _exit(argv, capsys)
        assert rc == 2 and str(f) in last, last
        return
    grid = np.asarray(GRID_1NM, float)
    if option == "--surface":
        r = read_reflectance(f, grid)  # the LED shape as a reflectance 0-1
        assert np.all((r >= 0.0) & (r <= 1.0)) and r.max() > 0.0
    elif option == "--nir":
        spectra, _ = load_user_lamp(tmp_path / "short.csv", str(f))
        assert np.all(np.isfinite(spectra)) and spectra.min() >= 0.0
    else:
        spectra, _ = load_user_lamp(f)
        assert np.all(np.isfinite(spectra)) and spectra.max() == 1.0


@pytest.mark.parametrize("kind", sorted(FILES))
@pytest.mark.parametrize("command", ["bands", "simulate", "render"])
def test_json_and_toml_file_options(command, kind, tmp_path, capsys):
    """Band-set and layout files are JSON (or TOML): none of these files is
    one, and each is refused naming it."""
    f = _file(tmp_path, kind, "f.toml" if command == "render" else "f.json")
    argv = {
        "bands": ["bands", str(f)],
        "simulate": ["simulate", "--bands", str(f), *S,
                     "--out", str(tmp_path / "o")],
        "render": ["render", "--layout", str(f), "--out", str(tmp_path / "o")],
    }[command]  # fmt: skip
    rc, _, last = _exit(argv, capsys)
    assert rc == 2 and str(f) in last, last
    assert len(last) < 600  # a bad line is quoted short, never whole
    assert not (tmp_path / "o").exists()


def test_the_gsd_bound_is_the_sensor_models_earth():
    from bandopt.cli._options import EARTH_CIRCUMFERENCE_M
    from bandopt.sensor._photon import _R_EARTH_M

    assert EARTH_CIRCUMFERENCE_M == pytest.approx(2 * math.pi * _R_EARTH_M, rel=1e-12)


@pytest.mark.parametrize("gsd", ["1e-300", "1e-308"])
def test_a_gsd_that_collects_no_light_is_named(gsd, tmp_path, capsys):
    """Refused before the run starts (no --out folder is made)."""
    argv = ["radiometry", "--quick", "--gsd", gsd, "--out", str(tmp_path / "o")]
    rc, _, last = _exit(argv, capsys)
    assert rc == 2 and "--gsd" in last and "collects no light" in last, last
    assert not (tmp_path / "o").exists()
