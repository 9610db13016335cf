"""A user's own measured lamps in the inversion's prior (`own_lamps`,
`bandopt evaluate --prior-lamps CLASS=FILE`): what an own lamp is (the
spectrum at one lumen by colour-science's V, labelled with its class and
family), bad input refused with the lamp named, and that a lamp of a kind
the prior lacks is estimated far better once its measured spectrum is in
it (the in-library bound of `make estimate-library`)."""

import numpy as np
import pytest

from bandopt import inversion as inv_mod
from bandopt.estimate import lamp_truth
from tests._bands import GRID
from tests.test_inversion_models import _pixels
from tests.test_inversion_shifts import _lumen


@pytest.fixture(scope="module")
def lib():
    return inv_mod.library_lamps(GRID, scored=True)


def test_an_own_lamp_is_the_spectrum_at_one_lumen(lib):
    i = lib.level2.index("metal_halide")
    fine = np.arange(380.0, 901.0, 0.5)
    raw = 37.0 * np.interp(fine, GRID, lib.spectra[i])  # any scale, another grid
    own = inv_mod.own_lamps(["my mh"], raw, fine, GRID, ["metal_halide"])
    assert own.ids == ("own:my mh",)
    assert own.level1 == ("hid",) and own.level2 == ("metal_halide",)
    assert _lumen(own.spectra[0]) == pytest.approx(1.0, rel=2e-3)
    np.testing.assert_allclose(own.spectra[0], lib.spectra[i], rtol=1e-2, atol=1e-9)


def test_bad_own_lamps_are_refused_by_name(lib):
    s = lib.spectra[:1]
    with pytest.raises(ValueError, match="'sodium' is not a level-2 class"):
        inv_mod.own_lamps(["a"], s, GRID, GRID, ["sodium"])
    with pytest.raises(ValueError, match="1 names, 2 classes and 1 spectra"):
        inv_mod.own_lamps(["a"], s, GRID, GRID, ["hps", "hps"])
    dark = np.where(GRID > 800.0, 1.0, 0.0)[None]
    with pytest.raises(ValueError, match="b emits no light in 380-780 nm"):
        inv_mod.own_lamps(["a", "b"], np.vstack([s, dark]), GRID, GRID, ["hps"] * 2)
    empty = inv_mod.own_lamps([], np.zeros((0, GRID.size)), GRID, GRID, [])
    assert empty.ids == () and empty.spectra.shape == (0, GRID.size)


def test_a_lamp_the_prior_lacks_is_found_once_it_is_in_it(lib):
    """A metal halide lamp, with a prior of other classes' lamps only: its
    LER is far off; with its own measured spectrum added, near exact."""
    mh = lib.level2.index("metal_halide")
    others = [i for i, c in enumerate(lib.level2)
              if c in ("hps", "led_warm", "fluorescent_linear")][:12]  # fmt: skip
    train = lib.take(others)
    target = lib.take([mh])
    _, rad, w = _pixels(target)
    cond = inv_mod.Conditions.clear(GRID)
    basis = inv_mod._basis(GRID)
    truth, _ = lamp_truth(target.spectra, GRID)
    errs = {}
    for with_own in (False, True):
        prior = train
        if with_own:
            prior = train + inv_mod.own_lamps(
                ["mh"], target.spectra, GRID, GRID, ["metal_halide"]
            )
        inv = inv_mod.build_inversion(prior, w, cond, basis, "unknown", 0.003)
        res = inv.predict(rad)
        errs[with_own] = np.abs(res.estimate[:, 0] - truth[0, 0]).mean()
        if with_own:
            assert all(x == "metal_halide" for x in res.level2)
    assert errs[False] > 20.0  # lm/W
    assert errs[True] < 1.0


# -- bandopt evaluate --prior-lamps CLASS=FILE ---------------------------------


def test_prior_lamp_entries_are_checked_before_any_file_is_read():
    from bandopt.cli._cmd_evaluate import parse_prior_lamps, prior_lamp_names

    assert parse_prior_lamps(["hps=a.csv", "led_warm=dir/b=c.csv"]) == [
        ("hps", "a.csv"),
        ("led_warm", "dir/b=c.csv"),
    ]
    with pytest.raises(ValueError, match=r"'a\.csv': expected CLASS=FILE"):
        parse_prior_lamps(["a.csv"])
    with pytest.raises(ValueError, match="class 'sodium' is not a level-2 class"):
        parse_prior_lamps(["sodium=a.csv"])
    with pytest.raises(ValueError, match=r"a\.csv is given twice"):
        parse_prior_lamps(["hps=a.csv", "led_warm=a.csv"])
    # two files of one name are told apart by their paths
    assert prior_lamp_names(["x/a.csv", "y/a.csv", "b.csv"]) == [
        "x/a.csv",
        "y/a.csv",
        "b.csv",
    ]


def test_evaluate_puts_your_lamps_into_the_prior(monkeypatch, tmp_path, lib, capsys):
    """`_fit` hands `fit_inversion` the Planck spectra and your lamps (at
    one lumen, labelled) as always-in-prior lamps; the CLI reads the files
    before training and refuses the option for the ridge."""
    import types

    from bandopt.cli import _cmd_evaluate, main
    from bandopt.spectra import GRID_1NM
    from tests._bands import FIVE
    from tests.test_inversion_models import StopAtFitError, _case, stop_at_fit

    case = _case()
    ctx, seen = stop_at_fit(monkeypatch, case)
    i = lib.level2.index("hps")
    fine = np.asarray(GRID_1NM, float)
    own = (["my_hps.csv"], 5.0 * np.interp(fine, GRID, lib.spectra[i])[None], ["hps"])
    args = types.SimpleNamespace(
        estimator="inversion", modelled_per_class=0, intervals="any-type",
        mixtures=0, cross_mixtures=0, sigma="per-metric", interval_unit="narrowest",
        peak_shifts="off", planck="on", tm30="off", own_lamps=own,
    )  # fmt: skip
    with pytest.raises(StopAtFitError):
        _cmd_evaluate._fit(args, ctx, FIVE, "unknown")
    always = seen["always"]
    assert always.ids == (*inv_mod.planck_lamps(GRID).ids, "own:my_hps.csv")
    assert always.level2[-1] == "hps" and always.level1[-1] == "hid"
    np.testing.assert_allclose(always.spectra[-1], lib.spectra[i], rtol=2e-2, atol=1e-9)

    spec = tmp_path / "l.csv"
    spec.write_text(
        "".join(f"{x},{v}\n" for x, v in zip(GRID, lib.spectra[i], strict=True))
    )
    argv = ["evaluate", "--bands", "sdgsat-1", "--lamps", str(spec)]
    assert main([*argv, "--estimator", "ridge", "--prior-lamps", f"hps={spec}"]) == 2
    assert "--estimator inversion only" in capsys.readouterr().err
    assert main([*argv, "--prior-lamps", "hps=missing.csv"]) == 2
    assert "missing.csv" in capsys.readouterr().err
    assert main([*argv, "--prior-lamps", str(spec)]) == 2
    assert "expected CLASS=FILE" in capsys.readouterr().err
