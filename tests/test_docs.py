"""Documentation: the Sphinx build works offline (in `make test`), and quick checks that
the docs, the README and the tutorial say what the code does."""

import importlib
import re
import socket
from pathlib import Path

import pytest


ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"

README_HEAD = """# bandopt

```sh
make run    # set up .venv, install, and run the main job on the built-in data
make test   # set up .venv with test extras, and run the test suite
```
"""


def test_readme_starts_with_its_two_commands():
    assert (ROOT / "README.md").read_text().startswith(README_HEAD)


def test_readme_tour_picture_exists_and_is_small():
    text = (ROOT / "README.md").read_text()
    pics = re.findall(r"!\[[^\]]*\]\(([^)]+)\)", text)
    assert len(pics) == 1, pics
    path = ROOT / pics[0]
    assert path.is_file() and path.stat().st_size < 300_000


def test_toctree_and_automodules_resolve():
    index = (DOCS / "index.rst").read_text()
    entries = re.findall(r"^   (\w+)$", index, flags=re.M)
    assert {"guide", "tutorial", "report", "api", "references"} <= set(entries)
    for e in entries:
        assert (DOCS / f"{e}.rst").is_file(), e
    modules = re.findall(r"^\.\. automodule:: ([\w.]+)", (DOCS / "api.rst").read_text(),
                         flags=re.M)
    assert "bandopt.report" in modules and "bandopt.results" in modules
    for m in modules:
        importlib.import_module(m)


def test_docs_config_needs_no_network():
    conf = (DOCS / "conf.py").read_text()
    assert "sphinx.ext.intersphinx" not in conf
    assert not re.search(r"https?://", conf)


def test_tutorial_doc_matches_the_script():
    from bandopt import tutorial

    doc = (DOCS / "tutorial.rst").read_text()
    for lamp in tutorial.LAMPS:
        assert lamp in doc
    for bands in ("viirs-dnb", "sdgsat-1", "results/recommendation.json"):
        assert bands in doc
    assert "BANDOPT_LSPDD=0" in doc and "--estimator inversion" in doc
    script = Path(tutorial.__file__).read_text()
    assert '"BANDOPT_LSPDD": "0"' in script and '"--estimator", "inversion"' in script


TUTORIAL_QUOTES = (
    # (the quote, its number or word as a group; the results file; what that
    # file says the group must be)
    (
        r"(\d+) free bands \+ a fixed panchromatic",
        "recommendation.json",
        lambda d: sum(b["name"].upper() != "PAN" for b in d["spectral"]["bands"]),
    ),
    (
        r"on the (\d+) lamps the search scored",
        "search/compare.json",
        lambda d: d["context"]["n_lamps"],
    ),
    (
        r"chosen\s+by the shipped (\w+) as the judge",
        "recommendation.json",
        lambda d: d["spectral"]["estimator"].split()[1],
    ),
)
"""Every result the tutorial quotes, with the file it comes from."""

TUTORIAL_CONSTANTS = {
    "2 cores": "the machine its run time refers to",
    "380-900 nm": "the LSPDD's measured range (bandopt.tutorial.LAMPS)",
    "90 % intervals": "the inversion's interval level",
    "EN 13201 class P4": "the lighting class of the default scene",
    "SDGSAT-1": "a sensor's name",
}
"""Numbers in the tutorial's prose that are not results."""


def _tutorial_prose() -> str:
    """docs/tutorial.rst without code blocks, inline literals and section
    numbers: the text whose numbers a reader takes as results."""
    lines, in_code = [], False
    for line in (DOCS / "tutorial.rst").read_text().splitlines():
        if line.startswith(".. code-block::"):
            in_code = True
            continue
        if in_code and (not line.strip() or line.startswith("   ")):
            continue
        in_code = False
        lines.append(re.sub(r"^\d+\. ", "", line))
    return re.sub(r"``[^`]*``", "", "\n".join(lines))


def _drifted(prose: str) -> list[str]:
    import json

    drift = []
    for pattern, rel, expected in TUTORIAL_QUOTES:
        m = re.search(pattern, prose)
        if m is None:
            drift.append(f"docs/tutorial.rst no longer quotes /{pattern}/ (from "
                         f"results/{rel}): update TUTORIAL_QUOTES")
            continue
        want = expected(json.loads((ROOT / "results" / rel).read_text()))
        if m.group(1) != str(want):
            drift.append(f"docs/tutorial.rst says {m.group(0)!r}, but results/{rel} "
                         f"gives {want}")
    return drift


def _unsourced_numbers(prose: str) -> list[str]:
    for pattern, _, _ in TUTORIAL_QUOTES:
        prose = re.sub(pattern, " ", prose)
    for phrase in TUTORIAL_CONSTANTS:
        prose = prose.replace(phrase, " ")
    prose = re.sub(r"\s+", " ", prose)
    return [
        prose[max(0, m.start() - 30): m.end() + 20]
        for m in re.finditer(r"\d+(?:[.,]\d+)?", prose)
    ]


def test_tutorial_numbers_come_from_the_results():
    """Each result the tutorial quotes equals its committed file, and the
    tutorial quotes no number that no file backs (a run time, an error copied
    from one run): those drift silently."""
    prose = _tutorial_prose()
    assert not _drifted(prose), "\n".join(_drifted(prose))
    found = _unsourced_numbers(prose)
    assert not found, (
        "numbers in docs/tutorial.rst with no source (add them to "
        f"TUTORIAL_QUOTES with their file, or drop them): {found}"
    )


def test_tutorial_number_check_can_fail():
    """A stale band count, a stale lamp count and a copied run time are each
    caught, named with the file they contradict."""
    prose = _tutorial_prose()
    stale = re.sub(r"\d+( free bands)", r"99\1", prose)
    assert any("recommendation.json gives" in d for d in _drifted(stale))
    stale = re.sub(r"the \d+ lamps", "the 111 lamps", prose)
    assert any("compare.json gives" in d for d in _drifted(stale))
    assert _unsourced_numbers(prose + " (about 4 min each)")


def test_tutorial_summary_holds_what_the_doc_says(tmp_path):
    """The tutorial's summary.json has the estimator, the mean absolute error
    per sensor and metric (lamps without an estimate left out) and the run
    times the tutorial page points readers to, in strict JSON."""
    import json

    from bandopt import tutorial

    rows = [
        {"sensor": "a", "lamp": "x", "metric": m, "abs_error": e}
        for m, e in (("LER", 2.0), ("G", 0.5), ("CCT", None))
    ] + [
        {"sensor": "a", "lamp": "y", "metric": m, "abs_error": e}
        for m, e in (("LER", 4.0), ("G", float("nan")), ("CCT", None))
    ]
    ev = {"estimator": "inversion", "seconds": {"a": 41.5}}
    path = tutorial.write_summary(ev, rows, tmp_path)
    got = json.loads(path.read_text(), parse_constant=lambda c: pytest.fail(c))
    assert got["estimator"] == "inversion"
    assert got["evaluate_seconds"] == {"a": 41.5}
    assert got["mean_abs_error"]["a"]["LER"] == 3.0
    assert got["mean_abs_error"]["a"]["CCT"] is None
    assert got["mean_abs_error"]["a"]["G"] is None  # NaN mean: undefined, null
    assert "summary.json" in (DOCS / "tutorial.rst").read_text()


def test_guide_dask_option_exists():
    guide = (DOCS / "guide.rst").read_text()
    assert "--scheduler tcp://" in guide
    search = (ROOT / "experiments" / "search.py").read_text()
    assert 'add_argument("--scheduler"' in search


# Sphinx 9's own napoleon extension uses an API Sphinx 9 deprecates
@pytest.mark.filterwarnings("ignore:The mapping interface for autodoc options")
def test_sphinx_build_offline(tmp_path, monkeypatch):
    """The whole documentation, API reference included, builds with every
    network connection refused and no warning (`-W`, as `make docs`)."""
    from sphinx.cmd import build as sphinx_build  # in the test extra: must not skip

    def refuse(*args, **kwargs):
        raise OSError("network access during the docs build")

    monkeypatch.setattr(socket.socket, "connect", refuse)
    monkeypatch.setattr(socket, "create_connection", refuse)
    out = tmp_path / "html"
    rc = sphinx_build.build_main(
        ["-b", "html", "-q", "-W", "--keep-going", "-E", str(DOCS), str(out)]
    )
    assert rc == 0
    api = (out / "api.html").read_text()
    for name in ("build_report", "update_recommendation", "check_consistency"):
        assert name in api
    assert (out / "guide.html").is_file() and (out / "tutorial.html").is_file()


def _make_docs_sphinx_args() -> list[str]:
    """The arguments of the `sphinx` call in the Makefile's `docs` target."""
    make = (ROOT / "Makefile").read_text()
    recipe = make[make.index("\ndocs:"):].split("\n\n")[0]
    line = next(x for x in recipe.splitlines() if "-m sphinx" in x)
    return line.split("-m sphinx", 1)[1].split()


def test_make_docs_fails_on_a_warning(tmp_path):
    """`make docs` rebuilds every page (`-E`: autodoc pages are otherwise not
    re-read when only a docstring changed, and their warnings vanish) and its
    exact Sphinx options turn one warning into a nonzero exit."""
    from sphinx.cmd import build as sphinx_build

    args = _make_docs_sphinx_args()
    assert {"-W", "--keep-going", "-E"} <= set(args)
    assert args[-2:] == ["docs", "docs/_build/html"]
    src = tmp_path / "src"
    src.mkdir()
    (src / "conf.py").write_text("")
    (src / "index.rst").write_text("Title\n=====\n\n:doc:`no-such-page`\n")
    options = args[:-2]
    assert sphinx_build.build_main([*options, str(src), str(tmp_path / "bad")]) != 0
    (src / "index.rst").write_text("Title\n=====\n\nFine.\n")
    assert sphinx_build.build_main([*options, str(src), str(tmp_path / "ok")]) == 0


def _guide_block(title: str) -> str:
    """The first python code block under the guide's section `title`."""
    text = (DOCS / "guide.rst").read_text()
    part = text[text.index(title):]
    m = re.search(r"\.\. code-block:: python\n\n((?:   .*\n|\n)+)", part)
    return "\n".join(line[3:] for line in m.group(1).splitlines())


def test_guide_own_surface_snippet_runs(tmp_path, monkeypatch):
    """The guide's 'own surfaces' code works on a measured reflectance file."""
    import numpy as np

    from bandopt.datasets.surfaces import mean_reflectance

    _, refl = mean_reflectance(["sidewalk"])
    w = np.arange(380, 901)
    (tmp_path / "my_pavement.txt").write_text(
        "".join(f"{a} {b:.5f}\n" for a, b in zip(w, refl[0], strict=True))
    )
    monkeypatch.chdir(tmp_path)
    ns: dict = {}
    exec(_guide_block("Bring your own surfaces"), ns)
    scen = ns["scen"]
    assert scen.surface_labels == ("my_pavement",)
    np.testing.assert_allclose(
        np.asarray(scen.factors.reflectance)[0], refl[0], atol=1e-5
    )


def test_guide_own_lamp_snippet_runs(tmp_path, monkeypatch):
    from bandopt.tutorial import export_lamps

    files = export_lamps(tmp_path)
    assert [f.stem for f in files] == sorted(["lspdd_2469", "lspdd_2470", "lspdd_2481"])
    files[0].rename(tmp_path / "my_hps.csv")
    monkeypatch.chdir(tmp_path)
    exec(_guide_block("Bring your own lamp spectra"), {})


def test_guide_estimator_snippet_runs(capsys):
    """The guide's 'new question' code fits a registered estimator by name and
    predicts typed estimates."""
    ns: dict = {}
    exec(_guide_block("Ask a new question of the estimator"), ns)
    est = ns["est"]
    assert len(est) == 5 and est.values.shape == (5, 3)
    assert "ridge regression" in capsys.readouterr().out


def test_tutorial_picks_the_estimator_from_the_help(monkeypatch):
    from bandopt import tutorial

    opt, label = tutorial.estimator_option()
    import subprocess

    helptext = subprocess.run(
        [*tutorial.bandopt_cmd(), "evaluate", "--help"], capture_output=True,
        text=True, check=True,
    ).stdout
    offered = "--estimator" in helptext and "inversion" in helptext
    assert (opt == ["--estimator", "inversion"]) == offered
    assert ("ridge" in label) == (opt == [])
