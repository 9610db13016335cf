"""A fitted estimator as a file (`bandopt.estimators.save_fitted`,
`load_fitted`, `fit_cached`; `bandopt fit`, `bandopt evaluate --model`):
loaded, every registered estimator predicts exactly what the fitted one
does; a file fitted for other bands, options, data or code is refused
naming the file and the field; a cached entry that is stale or unreadable
is refitted, never trusted; nothing but bandopt's own dataclasses is ever
built from a file."""

import json
import zipfile

import numpy as np
import pytest

import bandopt.search
from bandopt import inversion as inv_mod
from bandopt.cli import main
from bandopt.estimators import (
    ESTIMATORS,
    FingerprintMismatchError,
    ModelFileError,
    Surface,
    _artefact,
    cache_dir,
    configure,
    fingerprint,
    fit_cached,
    load_fitted,
    read_fingerprint,
    save_fitted,
)
from bandopt.estimators._serial import decode, encode
from bandopt.search import get_context
from bandopt.sensor import BandSet

from .test_estimators import BANDS, SMALL


@pytest.fixture(scope="module")
def tiny():
    """The tiny scenario set, every registered estimator fitted on it with
    `SMALL`'s quick options, and every third of its pixels with the surface
    unknown: (context, fitted by name, radiance, surface)."""
    ctx = get_context("tiny", None, 0, "none")
    fits = {}
    for name in ESTIMATORS:
        config = configure(name, **SMALL.get(name, {}))
        fits[name] = config.fit(ctx, BANDS, surface_mode="unknown")
    rows = np.arange(0, ctx.table.lamp_of.size, 3)
    surface = Surface("unknown", None, inv_mod.surface_basis(ctx.wavelength_nm).mean)
    return ctx, fits, ctx.radiance(BANDS)[rows], surface


@pytest.fixture(scope="module")
def fitted(tiny):
    return tiny[1]


@pytest.fixture(scope="module")
def pixels(tiny):
    return tiny[2:]


@pytest.fixture
def tiny_context(tiny, monkeypatch):
    """`fit_cached` (and so the CLI) trains on the tiny scenario set: a fit
    in a second, not a minute (the fingerprint still names evaluate's)."""
    monkeypatch.setattr(bandopt.search, "get_context", lambda *a: tiny[0])


def _fp(name="inversion", bands=BANDS, **options):
    config = configure(name, **{**SMALL.get(name, {}), **options})
    return fingerprint(config, bands, surface_mode="unknown")


def _same(a, b) -> bool:
    """Two `Estimates` equal in every value (NaN where NaN) and row."""
    return (
        np.array_equal(a.values, b.values, equal_nan=True)
        and np.array_equal(a.interval90, b.interval90, equal_nan=True)
        and all(a.row(i) == b.row(i) for i in range(len(a)))
    )


def _leaves(x) -> tuple[object, list]:
    """`encode`'s tree of `x` and its arrays in tree order: equal for two
    objects when every field and array is equal bit for bit."""
    tree, arrays = encode(x)
    return tree, [arrays[k] for k in sorted(arrays, key=lambda k: int(k[1:]))]


@pytest.mark.parametrize("name", list(ESTIMATORS))
def test_a_loaded_estimator_is_the_fitted_one_field_for_field(name, fitted, tmp_path):
    path = save_fitted(tmp_path / f"{name}.npz", fitted[name], _fp(name))
    loaded = load_fitted(path, _fp(name))
    assert type(loaded) is type(fitted[name])
    assert loaded.description == fitted[name].description
    assert loaded.report() == fitted[name].report()
    (t1, a1), (t2, a2) = _leaves(loaded), _leaves(fitted[name])
    assert t1 == t2 and len(a1) == len(a2)
    for x, y in zip(a1, a2, strict=True):
        assert x.dtype == y.dtype and np.array_equal(x, y, equal_nan=True)
    assert read_fingerprint(path) == _fp(name)


@pytest.mark.parametrize("name", ["inversion", "direct"])
def test_a_loaded_estimator_predicts_exactly_what_the_fitted_one_does(
    name, fitted, pixels, tmp_path
):
    """(The regression baselines' first prediction trains the lamp-type
    classifier, half a minute: their fields are compared above.)"""
    loaded = load_fitted(save_fitted(tmp_path / "m.npz", fitted[name], _fp(name)))
    rad, surface = pixels
    assert _same(loaded.predict(rad, surface), fitted[name].predict(rad, surface))


def test_the_file_is_an_npz_with_a_json_header_and_no_pickle(fitted, tmp_path):
    path = save_fitted(tmp_path / "m.npz", fitted["inversion"], _fp())
    with zipfile.ZipFile(path) as z:
        names = z.namelist()
    assert "header.npy" in names
    with np.load(path, allow_pickle=False) as npz:  # every array loads so
        header = json.loads(bytes(npz["header"]).decode())
        for k in npz.files:
            assert npz[k].dtype != object
    assert header["format"] == "bandopt-fitted-estimator"
    assert header["fingerprint"]["estimator"]["mixtures"] == 0


@pytest.mark.parametrize(
    ("asked", "field"),
    [
        (dict(mixtures=3), "estimator.mixtures"),
        (dict(bands=BandSet.contiguous(7)), "bands.centre_nm"),
        (dict(name="ridge"), "estimator.name"),
    ],
)
def test_a_model_fitted_for_other_bands_or_options_is_refused(
    asked, field, fitted, tmp_path
):
    path = save_fitted(tmp_path / "m.npz", fitted["inversion"], _fp())
    name = asked.pop("name", "inversion")
    with pytest.raises(FingerprintMismatchError) as info:
        load_fitted(path, _fp(name, **asked))
    assert field in info.value.fields
    assert str(path) in str(info.value) and field in str(info.value)


def test_other_code_data_or_surface_knowledge_is_refused(fitted, tmp_path):
    fp = _fp()
    path = save_fitted(tmp_path / "m.npz", fitted["inversion"], fp)
    for edit, field in [
        (lambda f: f["code"].update(source="0" * 16), "code.source"),
        (lambda f: f["data"].update(lamps_lspdd="0" * 16), "data.lamps_lspdd"),
        (lambda f: f.update(surface_mode="class"), "surface_mode"),
    ]:
        other = json.loads(json.dumps(fp))
        edit(other)
        with pytest.raises(FingerprintMismatchError, match=field.replace(".", r"\.")):
            load_fitted(path, other)


def test_the_fingerprint_holds_bands_configuration_data_and_code():
    fp = _fp()
    assert fp["bands"]["centre_nm"] == pytest.approx(
        np.asarray(BANDS.centre_nm).tolist(), abs=0
    )
    assert len(fp["bands"]["fwhm_nm"]) == len(fp["bands"]["shape_k"]) == 8
    assert fp["estimator"]["name"] == "inversion"
    assert fp["estimator"]["peak_shifts_nm"] == []
    assert {"lamps_lspdd", "surfaces", "atmosphere", "moon"} <= set(fp["data"])
    assert set(fp["code"]) >= {"bandopt", "source", "numpy", "jax"}
    assert _fp() == fp  # deterministic
    assert _fp(planck=True) != fp


@pytest.mark.parametrize("damage", ["truncated", "flipped", "not a model", "empty"])
def test_an_unreadable_model_file_is_refused_naming_it(damage, fitted, tmp_path):
    path = save_fitted(tmp_path / "m.npz", fitted["direct"], _fp("direct"))
    data = path.read_bytes()
    if damage == "truncated":
        path.write_bytes(data[: len(data) // 2])
    elif damage == "flipped":  # one byte in the middle of the stored arrays
        mid = len(data) // 2
        path.write_bytes(data[:mid] + bytes([data[mid] ^ 0xFF]) + data[mid + 1 :])
    elif damage == "not a model":
        np.savez(path, x=np.zeros(3))
    else:
        path.write_bytes(b"")
    with pytest.raises(ModelFileError, match=str(path)):
        load_fitted(path, _fp("direct"))


def test_only_bandopt_dataclasses_are_written_or_built():
    with pytest.raises(ValueError, match=r"fitted\[0\].*dtype object"):
        encode((np.array([1, "a"], dtype=object),))
    with pytest.raises(ValueError, match="cannot be stored"):
        encode({"f": print})
    for name in ("os:system", "subprocess:Popen", "bandopt.cli:main"):
        with pytest.raises(ValueError, match="not"):
            decode({"class": name, "fields": {}}, {})
    with pytest.raises(ValueError, match="fields"):  # a class with other fields
        decode({"class": "bandopt.estimators._contract:Surface", "fields": {}}, {})
    x = {"a": (1, 2.5, float("inf"), None), 3: [np.float64(0.1), "s"], "b": True}
    tree, arrays = encode(x)
    assert json.loads(json.dumps(tree, allow_nan=False)) == tree
    assert decode(tree, arrays) == x


def test_the_cache_fits_once_then_loads(tiny_context, fitted, pixels, monkeypatch):
    config = configure("inversion", **SMALL["inversion"])
    first, o1 = fit_cached(config, BANDS, surface_mode="unknown")
    assert o1.action == "fitted" and o1.path.is_file()
    assert o1.path.parent == cache_dir() / "models"
    second, o2 = fit_cached(config, BANDS, surface_mode="unknown")
    assert o2.action == "loaded" and o2.path == o1.path
    rad, surface = pixels
    fresh = fitted["inversion"].predict(rad, surface)
    assert _same(first.predict(rad, surface), fresh)
    assert _same(second.predict(rad, surface), fresh)
    monkeypatch.setenv("BANDOPT_NO_CACHE", "1")
    _, o3 = fit_cached(config, BANDS, surface_mode="unknown")
    assert o3.action == "uncached"


@pytest.mark.parametrize("entry", ["stale", "truncated", "garbage"])
def test_a_stale_or_corrupt_cache_entry_is_refitted_and_replaced(
    entry, tiny_context, fitted, pixels
):
    """The entry is made wrong on purpose: a stale one holds another
    estimator (the ridge) under a fingerprint of other code, so trusting it
    would change the answer."""
    config = configure("inversion", **SMALL["inversion"])
    fp = fingerprint(config, BANDS, surface_mode="unknown")
    path = _artefact.cache_path(fp)
    if entry == "stale":
        old = json.loads(json.dumps(fp))
        old["code"]["source"] = "0" * 16
        save_fitted(path, fitted["ridge"], old)
    else:
        save_fitted(path, fitted["inversion"], fp)
        data = path.read_bytes()
        path.write_bytes(data[:1000] if entry == "truncated" else b"x" * len(data))
    est, outcome = fit_cached(config, BANDS, surface_mode="unknown")
    assert outcome.action == "refitted" and outcome.path == path
    assert ("code.source" if entry == "stale" else str(path)) in outcome.reason
    rad, surface = pixels
    assert _same(est.predict(rad, surface), fitted["inversion"].predict(rad, surface))
    assert read_fingerprint(path) == fp  # replaced
    _, o2 = fit_cached(config, BANDS, surface_mode="unknown")
    assert o2.action == "loaded"


def test_the_cache_folder_follows_the_environment(monkeypatch, tmp_path):
    monkeypatch.setenv("BANDOPT_CACHE_DIR", str(tmp_path / "a"))
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "x"))
    assert cache_dir() == tmp_path / "a"
    monkeypatch.delenv("BANDOPT_CACHE_DIR")
    assert cache_dir() == tmp_path / "x" / "bandopt"
    monkeypatch.delenv("XDG_CACHE_HOME")
    monkeypatch.setenv("HOME", str(tmp_path / "h"))
    assert cache_dir() == tmp_path / "h" / ".cache" / "bandopt"


SMALL_CLI = [
    "--mixtures", "0", "--cross-mixtures", "0", "--peak-shifts", "off",
    "--planck", "off", "--sigma", "joint", "--intervals", "known-types",
    "--interval-unit", "half-width",
]  # fmt: skip
"""`SMALL`'s inversion as evaluate's options."""


def _run(capsys, argv):
    rc = main(argv)
    cap = capsys.readouterr()
    return rc, cap.out, cap.err


def test_fit_then_evaluate_with_the_model_gives_evaluates_answer(
    tiny_context, tmp_path, capsys, monkeypatch
):
    w = np.arange(380.0, 901.0)
    lamps = []
    for centre in (500.0, 600.0):
        f = tmp_path / f"l{centre:g}.csv"
        v = np.exp(-0.5 * ((w - centre) / 60) ** 2)
        f.write_text("\n".join(f"{a:g},{b:.17g}" for a, b in zip(w, v, strict=True)))
        lamps.append(str(f))
    ev = ["evaluate", "--bands", "sdgsat-1", *SMALL_CLI, "--lamps", *lamps, "--json"]
    monkeypatch.setenv("BANDOPT_NO_CACHE", "1")  # a fresh fit, no cache
    rc, plain, err = _run(capsys, ev)
    assert rc == 0 and "not cached" in err
    model = tmp_path / "model.npz"
    fit = ["fit", "--bands", "sdgsat-1", *SMALL_CLI, "--out", str(model), "--json"]
    rc, out, _ = _run(capsys, fit)
    assert rc == 0 and json.loads(out)["model"] == str(model)
    assert json.loads(out)["fingerprint"] == read_fingerprint(model)
    rc, with_model, _ = _run(capsys, [*ev, "--model", str(model)])
    assert rc == 0 and with_model == plain
    monkeypatch.delenv("BANDOPT_NO_CACHE")  # the cache gives the same again
    assert _run(capsys, ev)[1] == plain
    rc, cached, err = _run(capsys, ev)
    assert rc == 0 and cached == plain and "loaded from the cache" in err
    # the model refused for other options, naming the file and the field
    rc, _, err = _run(capsys, [*ev, "--model", str(model), "--mixtures", "2"])
    assert rc == 2 and str(model) in err and "estimator.mixtures" in err
    rc, _, err = _run(capsys, [*ev, "--model", str(tmp_path / "none.npz")])
    assert rc == 2 and "none.npz" in err
