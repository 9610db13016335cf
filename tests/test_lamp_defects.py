"""The lamp-data defects of the audit, each with a check that the library no
longer carries it: rejected near-infrared simulated as measured, a spectrum
contaminated into the visible, the mercury 765-780 nm plateau, spectra
truncated to zeros, the mercury extension as an upper bound, mixed lamps and
surfaces in `simulate`, and the extension's measured error per class."""

import dataclasses

import numpy as np
import pandas as pd
import pytest

from bandopt.cli import main
from bandopt.datasets import nir
from bandopt.datasets.lamps import library, nir_quality, usable_range


@pytest.fixture(scope="module")
def lib():
    return library()


@pytest.fixture(scope="module")
def raw():
    """Source spectra of the library's lamps by id (native grid)."""
    from bandopt.datasets._lamp_sources import _classified

    raws, _, kept, _, _ = _classified(True)
    return {raws[i].id: raws[i] for i in kept}


def _power(w, v, lo, hi):
    m = (w >= lo) & (w <= hi)
    return float(np.trapezoid(v[m], w[m]))


AUDITED_REJECTED = (
    "lspdd_2519",
    "lspdd_2523",
    "lspdd_2525",
    "lspdd_2479",
    "lspdd_2598",
    "lspdd_2538",
    "lspdd_2504",
)
"""Lamps the audit found simulated with near-infrared flagged as no evidence."""


def test_rejected_nir_is_replaced_by_the_extension(lib, raw):
    w = lib.wavelength_nm
    n_rejected = 0
    for r, v in zip(lib.records, lib.values, strict=True):
        src = raw.get(r.id)
        if src is None or src.wavelength_nm[-1] < 895.0:
            continue
        quality = nir_quality(src.wavelength_nm, src.values)
        if quality is None:
            continue
        n_rejected += 1
        assert r.extended and not r.nir_measured, r.id
        assert r.measured_range_nm[1] <= nir.EXTENSION_START_NM, r.id
        assert "not NIR evidence" in r.nir_note, r.id
        assert r.cut_reason and "not NIR evidence" in r.cut_reason, r.id
        # The part beyond the cut is the technology's extension of the kept part.
        end = r.measured_range_nm[1]
        kept = usable_range(src.wavelength_nm, src.values, r.level2).values
        keep = src.wavelength_nm <= end
        beyond = w > end
        tech = nir.technology_of(r.level2, r.level1)
        ext = nir.extend_spectrum(src.wavelength_nm[keep], kept[keep], tech, w[beyond])
        at = int(np.argmax(np.where(beyond, -np.inf, v)))  # the peak: > 0
        scale = v[at] / np.interp(w[at], src.wavelength_nm, kept)
        np.testing.assert_allclose(v[beyond], scale * ext, rtol=1e-9, atol=0.0)
    # 27 of the 31 compact fluorescents among them.
    cfl = [
        r
        for r in lib.records
        if r.level2 == "fluorescent_compact"
        and r.cut_reason
        and "not NIR evidence" in r.cut_reason
    ]
    assert len(cfl) == 27 and n_rejected >= 100


def test_audited_lamps_nir_is_the_extensions_level(lib):
    # Their 780-900 nm power was 0.2-1.3x their visible power (detector edges,
    # clipped noise); a fluorescent or LED extension holds a few per cent.
    w = lib.wavelength_nm
    for lamp_id in AUDITED_REJECTED:
        v = lib.values[lib.index(lamp_id)]
        ratio = _power(w, v, 780.0, 900.0) / _power(w, v, 380.0, 780.0)
        assert ratio < 0.06, (lamp_id, ratio)


def test_contaminated_visible_tail_is_cut(lib):
    # lspdd_2523 carries a rising background from about 700 nm: 10.8 % of its
    # visible power in 700-780 nm against a class median of 3.7 %.
    w = lib.wavelength_nm
    share = {}
    for r, v in zip(lib.records, lib.values, strict=True):
        if r.level2 == "led_warm" and not r.modelled and r.excluded is None:
            share[r.id] = _power(w, v, 700.0, 780.0) / _power(w, v, 380.0, 780.0)
    median = float(np.median(list(share.values())))
    rec = lib.records[lib.index("lspdd_2523")]
    assert "rising background" in rec.cut_reason and "subtracted" in rec.cut_reason
    assert rec.excluded is None
    # Within the class's own spread: below its 95th percentile.
    assert share["lspdd_2523"] < np.quantile(list(share.values()), 0.95)
    assert share["lspdd_2523"] < 1.6 * median
    # Contaminated below CUT_MIN_NM: kept out of scoring.
    assert "contaminated" in lib.records[lib.index("lspdd_2519")].excluded


def test_contamination_rule_is_general():
    from bandopt.datasets.lamps import contamination_start

    w = np.arange(380.0, 900.1, 0.5)
    lamp = np.exp(-0.5 * ((w - 600.0) / 60.0) ** 2)
    clean = lamp + 1e-4
    assert contamination_start(w, clean) is None
    background = 0.5 * np.exp((w - 900.0) / 70.0)
    cut = contamination_start(w, lamp + background)
    # Where the background reaches CONTAMINATION_MAX_FRACTION of the total.
    frac = background / (lamp + background)
    first = w[np.flatnonzero((frac >= 0.1) & (w >= 380.0))[0]]
    assert cut is not None and abs(cut - first) <= 2.0


@pytest.mark.parametrize(
    "lamp_id",
    ["nist_philips_h38ht_100_mercury", "nist_philips_h38ja_100_dx_mercury_dx"],
)
def test_mercury_plateau_cut_and_extended(lib, lamp_id):
    w = lib.wavelength_nm
    v = lib.values[lib.index(lamp_id)]
    rec = lib.records[lib.index(lamp_id)]
    plateau = float(np.mean(v[(w >= 770.0) & (w <= 780.0)]))
    at_760 = float(v[w == 760.0][0])
    # 2x: the flat 760-780 nm level of the two mercury spectra without the
    # plateau (NIST traditional, color-pollution HgV) varies by < 1.3x.
    assert plateau < 2.0 * at_760, (lamp_id, plateau / at_760)
    assert rec.measured_range_nm[1] < 765.0 and rec.extended
    assert "plateau" in rec.cut_reason


def test_trailing_zeros_end_the_measurement(lib, raw):
    from bandopt.datasets.lamps import measured_end

    w = lib.wavelength_nm
    for k in (1, 2, 3, 4):
        lamp_id = f"nist_led_phos_{k}"
        rec = lib.records[lib.index(lamp_id)]
        src = raw[lamp_id]
        s = src.values
        last = float(src.wavelength_nm[np.flatnonzero(s > 1e-5 * s.max())[-1]])
        assert last < 780.0, lamp_id
        assert rec.measured_range_nm[1] == last, lamp_id
        assert rec.extended and "zeros" in rec.cut_reason, lamp_id
        v = lib.values[lib.index(lamp_id)]
        assert np.all(v[w > last] > 0), lamp_id  # the LED tail, not zeros
    # The rule on its own: zeros to the end after a non-zero tail beyond
    # TRUNCATION_MIN_NM; a dark gap before it (low-pressure sodium) is data.
    x = np.arange(380.0, 781.0, 5.0)
    s = np.exp(-0.5 * ((x - 600.0) / 40.0) ** 2)
    s[x > 740.0] = 0.0
    assert measured_end(x, s) == 740.0
    s2 = s.copy()
    s2[x > 600.0] = 0.0
    assert measured_end(x, s2) == 780.0
    assert measured_end(x, s + 1e-3) == 780.0


def test_mercury_extension_is_an_upper_bound(lib):
    assert "upper bound" in nir.__doc__
    assert nir.UPPER_BOUND == ("mercury",)
    for r in lib.records:
        if r.level2 == "mercury" and r.extended:
            assert "upper bound" in r.nir_note, r.id


# ------------------------------------------------------------------------------
# extension_error


def test_extension_error_is_the_leave_one_out_quantiles():
    rows = nir.validate_extension()

    def ratios(pick):
        out = []
        for r in rows:
            b = r["bands"]["780-900"]
            if r["leave_one_out"] and pick(r) and b["extended"] > 0:
                out.append(b["measured"] / b["extended"] - 1.0)
        return np.array(out)

    e = nir.extension_error("incandescent_halogen", "incandescent")
    ref = ratios(lambda r: r["level2"] == "incandescent_halogen")
    assert e.validated and e.n_lamps == ref.size >= 5
    assert e.low == pytest.approx(np.quantile(ref, 0.05), rel=1e-12)
    assert e.high == pytest.approx(np.quantile(ref, 0.95), rel=1e-12)
    assert "leave-one-out" in e.basis and "incandescent_halogen" in e.basis
    # HPS: two validated lamps, fewer than 5: the technology's pool.
    hps = nir.extension_error("hps", "hps")
    pool = ratios(lambda r: r["technology"] == "hps")
    assert hps.validated and hps.n_lamps == pool.size
    assert hps.low == pytest.approx(np.quantile(pool, 0.05), rel=1e-12)
    assert "pooled" in hps.basis
    # The technology follows from the class when not given.
    assert nir.extension_error("incandescent_halogen", None) == e
    with pytest.raises(dataclasses.FrozenInstanceError):
        e.low = 0.0  # type: ignore[misc]


def test_extension_error_without_validation_says_so():
    hg = nir.extension_error("mercury", "mercury")
    assert (hg.low, hg.high) == (-1.0, 0.0) and not hg.validated
    assert "upper bound" in hg.basis
    validated = [
        nir.extension_error(c, None)
        for c in ("incandescent_halogen", "led_warm", "led_cool", "metal_halide")
    ]
    for lamp_class, tech in [("lps", "lps"), ("led_rgb", "led"), (None, None)]:
        u = nir.extension_error(lamp_class, tech)
        assert not u.validated and "no leave-one-out" in u.basis, lamp_class
        # At least as wide as every validated class.
        assert u.low <= min(x.low for x in validated)
        assert u.high >= max(x.high for x in validated)
    son = nir.extension_error("hps", "hps", subtype="white_son")
    assert not son.validated and "White SON" in son.basis


# ------------------------------------------------------------------------------
# mixed lamps and surfaces in simulate


def test_to_frame_labels_mixed_lamps_and_surfaces():
    from bandopt.forward import simulate, to_frame
    from bandopt.scene import build_scenarios
    from bandopt.sensor import BandSet

    scen = build_scenarios(
        lamps=["nist_traditional_hps", ("nist_traditional_hps", "cie_led_b3", 0.3)],
        surfaces=["asphalt", ("asphalt", "grass", 0.5)],
        atmospheres=["none"],
        moons=[None],
        classes=["P1"],
    )
    df = to_frame(scen, simulate(scen, BandSet.from_physical([560.0], [60.0])))
    mixed = df[df.lamp == "nist_traditional_hps+cie_led_b3@0.3"].iloc[0]
    assert mixed.level1 == "hid+led@0.3" and mixed.level2 == "hps+led_cool@0.3"
    assert set(df.surface) == {"asphalt", "asphalt+grass@0.5"}
    assert df[df.lamp == "nist_traditional_hps"].level2.eq("hps").all()


def test_simulate_cli_takes_mixed_lamps_and_surfaces(tmp_path, capsys):
    out = tmp_path / "mix.csv"
    code = main(
        [
            "simulate",
            "--bands",
            "sdgsat-1",
            "--lamps",
            "nist_traditional_hps",
            "nist_traditional_hps+cie_led_b3@0.3",
            "--surfaces",
            "asphalt",
            "asphalt+grass@0.5",
            "--atmospheres",
            "none",
            "--moon",
            "none",
            "--classes",
            "P1",
            "--out",
            str(out),
        ]
    )
    assert code == 0
    df = pd.read_csv(out)
    assert len(df) == 4
    assert "hps+led_cool@0.3" in set(df.level2)
    assert set(df.surface) == {"asphalt", "asphalt+grass@0.5"}


def test_simulate_cli_refuses_a_bad_mix(tmp_path, capsys):
    code = main(
        [
            "simulate",
            "--bands",
            "sdgsat-1",
            "--lamps",
            "nist_traditional_hps+cie_led_b3@1.5",
            "--out",
            str(tmp_path / "x.csv"),
        ]
    )
    assert code == 2 and "fraction" in capsys.readouterr().err
