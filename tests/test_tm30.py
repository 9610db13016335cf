"""The IES TM-30-15 set's measured lamps as extra prior lamps
(`library(tm30=True)`, `inversion.tm30_lamps`, `with_tm30_lamps`, estimator
`...-planck-tm30`, `leave_one_class_out(tm30=True)`, `bandopt evaluate
--tm30`): the vendored files are the documented ones, only measured lamps are
read, the default library is unchanged, no TM-30 lamp copies a library lamp,
they are one lumen, they train and never score, and an unseen class never
trains on its own TM-30 lamps."""

import hashlib
import re
import types
from pathlib import Path

import colour
import numpy as np
import pytest

from bandopt import inversion as inv_mod
from bandopt.cli import _cmd_evaluate, main
from bandopt.datasets import _lamp_readers, _lamp_sources as src
from bandopt.datasets.lamps import library
from tests._bands import FIVE, GRID
from tests.test_inversion_mixtures import spy_priors
from tests.test_inversion_models import (
    StopAtFitError,
    _case,
    _fake_context,
    patch_case,
    stop_at_fit,
)


DATA = Path(src.__file__).parent / "data" / "lamps_ies_tm30"


@pytest.fixture(scope="module")
def tm30():
    return inv_mod.tm30_lamps(GRID)


def test_vendored_files_are_the_documented_ones():
    readme = (DATA / "README.md").read_text()
    for name in ("IESTM30_15_Sspds.dat", "IESTM30_15_Sinfo.txt"):
        digest = hashlib.sha256((DATA / name).read_bytes()).hexdigest()
        assert re.search(rf"`{re.escape(name)}` \| `{digest}`", readme), name


def test_only_measured_lamps_of_lamp_technologies_are_read():
    info = (DATA / "IESTM30_15_Sinfo.txt").read_text().splitlines()[1:]
    rows = [r.split(",") for r in info]
    expected = {
        int(r[0]) for r in rows
        if r[3].strip() in ("Commercial", "Experimental") and r[2].strip() != "Other"
    }  # fmt: skip
    raws = src._tm30_sources()
    assert {int(r.id.split("_")[2]) for r in raws} == expected
    assert len({r.id for r in raws}) == len(raws)
    by_name = {r.name: r.level2 for r in raws}
    assert by_name["CDM 830 (1) - Metal Halide"] == "metal_halide"
    assert by_name["C100S54 (1) - HPS Standard"] == "hps"
    assert by_name["H38HT-100 (2) - Mercury"] == "mercury"
    assert by_name["F32T8/830 (1)"] == "fluorescent_linear"
    assert by_name["LED Phosphor Blue Pump (01)"] is None  # decided by its spectrum
    assert not any(n.startswith("CIE ") or "Planckian" in n for n in by_name)
    with pytest.raises(ValueError, match=r"IESTM30_15_Sinfo\.txt.*'Xenon short arc'"):
        src._tm30_level2("Xenon short arc", "High Intensity Discharge")


def test_the_default_library_is_unchanged_and_no_tm30_lamp_copies_one():
    base, more = library(), library(tm30=True)
    index = {r.id: i for i, r in enumerate(more.records)}
    for i, r in enumerate(base.records):
        np.testing.assert_array_equal(base.values[i], more.values[index[r.id]])
    assert [r.id for r in more.records if r.source_set != "ies_tm30"] == [
        r.id for r in base.records
    ]
    assert "ies_tm30" not in {r.source_set for r in base.records}
    # the library's duplicate rule, recomputed: 5 nm visible shapes (unit area)
    # of every kept TM-30 lamp differ from every measured library lamp by more
    # than DUPLICATE_RMS of their mean

    def shapes(lib, keep):
        g = np.arange(380.0, 780.1, 5.0)
        out = []
        for i, r in enumerate(lib.records):
            if keep(r):
                v = np.interp(g, lib.wavelength_nm, lib.values[i])
                out.append(v / np.trapezoid(v, g))
        return np.array(out)

    ours = shapes(base, lambda r: not r.modelled)
    theirs = shapes(more, lambda r: r.source_set == "ies_tm30")
    assert len(theirs) > 150
    for s in theirs:
        rms = np.sqrt(np.mean((ours - s) ** 2, axis=1))
        assert np.all(rms >= src.DUPLICATE_RMS * np.mean((ours + s) / 2, axis=1))
    removed = [
        d for r in more.records for d in r.duplicates if d.startswith("ies_tm30_")
    ]
    assert len(removed) > 20  # the NIST Philips copies among them
    assert "ies_tm30_072_h38ht_100_1_mercury" in removed


def test_tm30_lamps_are_one_lumen_measured_and_extended_beyond_780nm(tm30):
    assert len(tm30.ids) > 150 and all(i.startswith("ies_tm30_") for i in tm30.ids)
    assert {"led_warm", "led_cool", "fluorescent_linear", "metal_halide", "hps",
            "mercury", "incandescent_halogen"} <= set(tm30.level2)  # fmt: skip
    v = colour.SDS_LEFS["CIE 1924 Photopic Standard Observer"]
    vis = GRID <= 780.0
    lum = 683.0 * np.trapezoid(tm30.spectra[:, vis] * v[GRID[vis]], GRID[vis], axis=1)
    np.testing.assert_allclose(lum, 1.0, rtol=2e-3)
    assert np.all(np.isfinite(tm30.spectra)) and np.all(tm30.spectra >= 0)
    recs = {r.id: r for r in library(tm30=True).records}
    assert all(recs[i].extended and not recs[i].modelled for i in tm30.ids)
    # Measured 380-780 nm; tables that end in zeros end where the zeros start
    # (`lamps.measured_end`).
    assert all(
        recs[i].measured_range_nm == (380.0, 780.0)
        or (recs[i].measured_range_nm[1] < 780.0 and "zeros" in recs[i].cut_reason)
        for i in tm30.ids
    )


def test_an_unseen_class_drops_its_own_tm30_lamps(tm30):
    kept = inv_mod.with_tm30_lamps(None, GRID, drop_class="mercury")
    assert "mercury" in tm30.level2 and "mercury" not in kept.level2
    assert len(kept.ids) == len(tm30.ids) - tm30.level2.count("mercury")
    planck = inv_mod.planck_lamps(GRID)
    both = inv_mod.with_tm30_lamps(planck, GRID)
    assert both.ids[: len(planck.ids)] == planck.ids
    assert both.ids[len(planck.ids) :] == tm30.ids


def test_leave_one_class_out_never_trains_on_the_held_out_class(monkeypatch, tm30):
    case = _case()
    lamps = case[0]
    patch_case(monkeypatch, case, moon=False)
    ctx = _fake_context(case)
    built = spy_priors(monkeypatch)
    recs = inv_mod.leave_one_class_out(ctx, FIVE, tm30=True)
    assert {r["held_out_class"] for r in recs} == set(lamps.level2)
    of = dict(zip(tm30.ids, tm30.level2, strict=True))
    for r in recs:
        assert r["tm30_in_prior"] == len(tm30.ids) - tm30.level2.count(r["level2"])
        assert not r["lamp"].startswith("ies_tm30_")
    # every prior built holds TM-30 lamps, and none of one class is missing
    # from all priors but that class's own
    assert all(any(i.startswith("ies_tm30_") for i in ids) for ids in built)
    missing = {
        c for c in set(tm30.level2)
        if any(not any(of.get(i) == c for i in ids) for ids in built)
    }  # fmt: skip
    assert missing == set(lamps.level2) & set(tm30.level2)


def test_cross_validate_tm30_rows_say_so_and_score_library_lamps(monkeypatch, tm30):
    case = _case()
    lamps = case[0]
    patch_case(monkeypatch, case)
    built = spy_priors(monkeypatch)
    recs = inv_mod.cross_validate(
        _fake_context(case), FIVE, estimators=(inv_mod.TM30_ESTIMATOR,), folds=[0]
    )
    assert recs and {r.lamp for r in recs} <= set(lamps.ids)
    for r in recs:
        assert r.tm30_in_prior == len(tm30.ids)
        assert r.modelled_in_prior == list(inv_mod.planck_lamps(GRID).ids)
        assert r.out_of_range == 0
    assert all(set(tm30.ids) <= set(ids) for ids in built)


def test_evaluate_tm30_option(monkeypatch, capsys, tmp_path):
    ctx, seen = stop_at_fit(monkeypatch, _case())
    for on, n in (("on", len(inv_mod.tm30_lamps(GRID).ids)), ("off", 0)):
        args = types.SimpleNamespace(
            estimator="inversion", modelled_per_class=0, intervals="any-type",
            mixtures=0, cross_mixtures=0, sigma="per-metric", interval_unit="narrowest",
            peak_shifts="off", planck="on", tm30=on, own_lamps=None,
        )  # fmt: skip
        with pytest.raises(StopAtFitError):
            _cmd_evaluate._fit(args, ctx, FIVE, "unknown")
        ids = seen["always"].ids
        assert sum(i.startswith("ies_tm30_") for i in ids) == n
        assert ids[:5] == inv_mod.planck_lamps(GRID).ids
    spec = tmp_path / "l.csv"
    spec.write_text("".join(f"{x},{1.0 + x / 1000}\n" for x in GRID))
    other = "on" if _cmd_evaluate.TM30_DEFAULT == "off" else "off"
    argv = ["evaluate", "--bands", "sdgsat-1", "--lamps", str(spec)]
    assert main([*argv, "--estimator", "ridge", "--tm30", other]) == 2
    assert f"--tm30 {other}: the TM-30 lamps go into the prior of" in (
        capsys.readouterr().err
    )


@pytest.mark.parametrize(
    "info, spd, match",
    [
        ("nr,name,type,category,\n1, A,LED Phosphor,Commercial,\n",
         "380,1\n", r"must rise over 380-780 nm"),
        ("nr,name,type,category,\n1, A,LED Phosphor,Commercial,\n2, B,LED Phosphor,"
         "Commercial,\n", None, r"1 spectra for the 2 sources"),
        ("nr,name,type,category,\n1, A,Laser,Commercial,\n", None,
         r"Sinfo\.txt: row 2: unknown type 'Laser'"),
        ("nr,name,type,category,\n1, A,LED Phosphor\n", None,
         r"Sinfo\.txt: row 2 has 3 fields, not 4"),
        ("nr,name,type,category,\n1, A,LED Phosphor,Commercial,\n", "neg",
         r"Sspds\.dat: source 1 \(A\) has negative or no power"),
    ],
)  # fmt: skip
def test_bad_tm30_files_are_refused_naming_file_and_row(
    tmp_path, monkeypatch, info, spd, match
):
    w = np.arange(380.0, 781.0)
    v = np.where(spd == "neg", -1.0, 1.0) * np.ones_like(w)
    if spd is None or spd == "neg":
        spd = "".join(f"{x:g},{y:g}\n" for x, y in zip(w, v, strict=True))
    (tmp_path / "IESTM30_15_Sinfo.txt").write_text(info)
    (tmp_path / "IESTM30_15_Sspds.dat").write_text(spd)
    # the reader reads the folder from its own module at call time
    monkeypatch.setattr(_lamp_readers, "_IES_TM30", tmp_path)
    with pytest.raises(ValueError, match=match):
        src._tm30_sources()
