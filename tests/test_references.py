"""Every bibliography key the code cites resolves in references.bib."""

import re
from pathlib import Path

import bandopt


ROOT = Path(bandopt.__file__).parent
BIB = ROOT / "datasets" / "references.bib"


def _bib_keys() -> set[str]:
    return set(re.findall(r"^@\w+\{([^,]+),", BIB.read_text(), flags=re.M))


def test_bib_keys_unique():
    keys = re.findall(r"^@\w+\{([^,]+),", BIB.read_text(), flags=re.M)
    assert len(keys) == len(set(keys)), sorted(k for k in keys if keys.count(k) > 1)


def test_lamp_sources_resolve():
    from bandopt.datasets.lamps import library

    keys = _bib_keys()
    assert {r.source for r in library().records} <= keys


def test_cited_keys_in_code_resolve():
    # Keys are cited in backticks in docstrings (`Key2019`) or as source="Key".
    keys = _bib_keys()
    cited = set()
    pattern = re.compile(
        r"(?:`|source=\"|\")([A-Z][A-Za-z]+(?:19|20)\d\d[a-z]?)(?:`|\")"
    )
    for path in ROOT.rglob("*.py"):
        cited |= set(pattern.findall(path.read_text()))
    missing = sorted(cited - keys)
    assert not missing, f"cited but not in references.bib: {missing}"


def test_top_level_bibliography_is_the_package_one():
    top = ROOT.parent / "references.bib"
    assert top.resolve() == BIB.resolve()


def test_keys_cited_in_the_docs_resolve():
    keys = _bib_keys()
    docs = ROOT.parent / "docs"
    cited = set()
    for path in docs.glob("*.rst"):
        cited |= set(re.findall(r"``([A-Z][A-Za-z]+(?:19|20)\d\d[a-z]?)``",
                                path.read_text()))
    assert cited, "the docs cite no bibliography key"
    assert not sorted(cited - keys), sorted(cited - keys)
