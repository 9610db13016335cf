"""One name registry, one band-set loader, one atmosphere check (issue 16)."""

import json

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from bandopt.names import CanonicalMapping, canonical_key, validate_method
from bandopt.sensor import (
    REFERENCE_SENSORS,
    BandSet,
    load_band_set,
    reference_sensor,
    resolve_band_set,
)


def test_canonical_mapping_ignores_case_and_separators():
    m = CanonicalMapping({"super-gaussian": 1, "viirs_dnb": 2}, what="thing")
    assert m["Super Gaussian"] == 1 and m["VIIRS-DNB"] == 2
    assert "superGAUSSIAN" in m and "gaussian" not in m
    assert list(m) == ["super-gaussian", "viirs_dnb"] and len(m) == 2
    assert m.resolve("viirs.dnb") == "viirs_dnb"
    with pytest.raises(KeyError):
        m["nope"]
    with pytest.raises(ValueError, match=r"Unknown thing 'nope'; expected one of \["):
        m.resolve("nope")


def test_canonical_mapping_refuses_colliding_names_and_bad_aliases():
    with pytest.raises(ValueError, match="same canonical key"):
        CanonicalMapping({"a-b": 1, "A_B": 2})
    with pytest.raises(ValueError, match="unknown"):
        CanonicalMapping({"a": 1}, aliases={"x": "b"})


@settings(deadline=None, max_examples=50)
@given(st.text(max_size=20))
def test_canonical_key_is_idempotent_and_alphanumeric(s):
    k = canonical_key(s)
    assert canonical_key(k) == k
    assert all(c.isdigit() or ("a" <= c <= "z") for c in k)


def test_validate_method_and_the_registries_that_use_it():
    from bandopt.classify import resolve_level
    from bandopt.knn import resolve_kind

    assert validate_method("Log-Ratio", ("log_ratio", "sum_normalised")) == "log_ratio"
    for name in (1, "L1", "level-1", "LEVEL_1"):
        assert resolve_level(name) == "level1"
    assert resolve_level("l2") == "level2"
    assert resolve_kind("sum normalised") == "sum_normalised"
    with pytest.raises(ValueError, match=r"expected one of \['level1', 'level2'\]"):
        resolve_level(3)
    assert REFERENCE_SENSORS["VIIRS DNB"] is REFERENCE_SENSORS["viirs-dnb"]


def test_one_band_set_loader(tmp_path):
    a = load_band_set("Aerocube")
    ref = reference_sensor("aerocube")
    np.testing.assert_array_equal(np.asarray(a.centre_nm), np.asarray(ref.centre_nm))
    found = resolve_band_set("aerocube")
    assert found.entry is not None and found.path is None
    assert found.label == "aerocube"
    f = tmp_path / "mine.json"
    f.write_text(
        json.dumps({"bands": [{"name": "b", "centre_nm": 550.0, "fwhm_nm": 40.0}]})
    )
    found = resolve_band_set(f)
    assert isinstance(found.bands, BandSet) and found.label == "mine"
    assert float(found.bands.centre_nm[0]) == pytest.approx(550.0)
    with pytest.raises(ValueError, match="no such band-set file"):
        load_band_set(tmp_path / "missing.json")
    with pytest.raises(ValueError, match="Unknown reference sensor 'nope'"):
        load_band_set("nope")


def test_missing_atmosphere_tables_name_make_atmospheres(tmp_path, monkeypatch):
    from bandopt.datasets import atmosphere

    assert atmosphere.tables_available()  # shipped with the package
    atmosphere.require_tables()
    monkeypatch.setattr(atmosphere, "_TABLE", tmp_path / "sixs_tables.npz")
    assert not atmosphere.tables_available()
    with pytest.raises(FileNotFoundError, match="make atmospheres"):
        atmosphere.require_tables()


def test_algorithm_names_use_the_registry():
    from bandopt.classify import SearchBox, SearchData, nlopt_search
    from bandopt.search import global_search

    with pytest.raises(ValueError, match=r"Unknown algorithm 'bfgs'; expected one of"):
        global_search(lambda u: 0.0, lambda u: (0.0, u), 2, algorithm="bfgs")
    with pytest.raises(ValueError, match="derivative-free algorithm 'mlsl'"):
        w = np.arange(400.0, 900.0, 10.0)
        data = SearchData(np.ones((2, w.size)), w, np.array([0, 1]), np.array([0, 1]),
                          2, (), None, None)  # fmt: skip
        nlopt_search(data, SearchBox(2), algorithm="mlsl")


# -- the same spellings resolve everywhere -------------------------------------


def _resolvers():
    """(choices, resolve) of every name normaliser that used its own rule."""
    from bandopt.datasets import _atmosphere_build, atmosphere
    from bandopt.estimate import TARGETS, resolve_target
    from bandopt.radiometry._quantisers import make_quantiser
    from bandopt.scene import NEIGHBOURHOODS, resolve_neighbourhood, uplight_factor

    def quantiser(name):
        q = make_quantiser(name, 1e-9, 1e-6, 10, responsivity_e=1e9)
        return {"LinearQuantiser": "linear", "TwoGainQuantiser": "two-gain"}.get(
            type(q).__name__, "sqrt"
        )

    def uplight(name):
        profile = uplight_factor(0.1, model="profile")
        return "profile" if uplight_factor(0.1, model=name) == profile else "lambertian"

    def hood(name):
        target = resolve_neighbourhood(name)
        return next(k for k, v in NEIGHBOURHOODS.items() if v is target)

    def atm_index(choices, argument):
        return lambda n: choices[atmosphere._index(n, choices, argument)]

    return {
        "atmosphere": (
            atmosphere.ATMOSPHERES,
            atm_index(atmosphere.ATMOSPHERES, "atmosphere"),
        ),
        "aerosol": (atmosphere.AEROSOLS, atm_index(atmosphere.AEROSOLS, "aerosol")),
        "6S build atmosphere": (
            atmosphere.ATMOSPHERES,
            lambda n: _atmosphere_build._choose(n, atmosphere.ATMOSPHERES, "x"),
        ),
        "target": (tuple(TARGETS), resolve_target),
        "neighbourhood": (tuple(NEIGHBOURHOODS), hood),
        "uplight model": (("profile", "lambertian"), uplight),
        "quantiser": (("linear", "two-gain", "sqrt"), quantiser),
    }


def _spellings(name: str) -> list[str]:
    words = name.replace("-", "_").split("_")
    return [
        name,
        name.upper(),
        "-".join(words).title(),
        " ".join(words),
        "_".join(w.upper() for w in words),
        f" {name} ",
    ]


@pytest.mark.parametrize("what", list(_resolvers()))
def test_the_same_spellings_resolve_everywhere(what):
    """Every registry resolves a name by `bandopt.names.canonical_key`: case,
    separators and spaces are ignored, and a name with another key fails."""
    choices, resolve = _resolvers()[what]
    for c in choices:
        for s in _spellings(c):
            assert canonical_key(s) == canonical_key(c)
            assert resolve(s) == c, (what, s)
    with pytest.raises(ValueError, match="expected one of"):
        resolve(choices[0] + "x" if what != "quantiser" else "logarithmic")
