"""The lamp library: counts, typology, deduplication, units, NIR extension flags."""

import re

import colour
import numpy as np
import pytest
from colour.colorimetry.datasets.light_sources import sds as light_sources

from bandopt.datasets import _lamp_sources, lamps
from bandopt.datasets.lamps import LEVEL1, LEVEL2, library


@pytest.fixture(scope="module")
def lib():
    return library()


def test_at_least_60_distinct_measured_lamps(lib):
    measured = [r for r in lib.records if not r.modelled]
    assert len(measured) >= 60
    assert len({r.id for r in lib.records}) == len(lib.records)


def test_identifiers_are_the_fixed_ones(lib):
    for r in lib.records:
        assert r.level1 in LEVEL1
        assert r.level2 is None or r.level2 in LEVEL2
        if r.level2 is not None:
            assert lamps.LEVEL2_PARENT[r.level2] == r.level1


def test_every_class_the_sources_allow_is_present(lib):
    present = {r.level2 for r in lib.records if not r.modelled}
    for l2 in LEVEL2:
        assert l2 in present, l2
    counts = {c["level2"]: c for c in lib.counts()}
    # Amber LEDs: photobiology emitters (direct), the measured Lumileds PC-amber
    # and LedEngin PC-amber channel, the filtered street luminaires.
    assert counts["led_amber"]["lamps"] >= lamps.MIN_LAMPS_FOR_SCORING
    assert counts["led_amber"]["status"] == "scored"


def test_insufficient_classes_follow_the_rule(lib):
    counts = {c["level2"]: c["lamps"] for c in lib.counts() if c["level2"]}
    for l2, n in counts.items():
        assert (l2 in lib.insufficient) == (n < lamps.MIN_LAMPS_FOR_SCORING)
    scored = lib.select(scored_only=True)
    assert all(r.level2 not in lib.insufficient for r in scored.records)
    assert all(r.level2 != "led_rgb" and r.excluded is None for r in scored.records)


def test_known_duplicate_removed(lib):
    # NIST "Incandescent" and Philips "60 A/W (Soft White)" are the same lamp.
    ids = set(lib.ids)
    assert ("nist_traditional_incandescent" in ids) != (
        "nist_philips_60_a_w_soft_white" in ids
    )
    a = light_sources.SDS_LIGHT_SOURCES_NIST_TRADITIONAL["Incandescent"].values
    b = light_sources.SDS_LIGHT_SOURCES_NIST_PHILIPS["60 A/W (Soft White)"].values
    np.testing.assert_allclose(a / a.sum(), b / b.sum(), rtol=0.03)


def test_no_remaining_pair_is_a_duplicate(lib):
    measured = lib.select()
    w = measured.wavelength_nm
    grid = np.arange(380.0, 780.1, 5.0)
    shapes = np.array([np.interp(grid, w, v) for v in measured.values])
    shapes /= np.trapezoid(shapes, grid, axis=1)[:, None]
    for i in range(len(shapes)):
        d = np.sqrt(np.mean((shapes[i + 1 :] - shapes[i]) ** 2, axis=1))
        mean = np.mean((shapes[i + 1 :] + shapes[i]) / 2, axis=1)
        assert np.all(d >= lamps.DUPLICATE_RMS * mean)


def test_coloured_tubes_and_rgb_mixes_not_scored(lib):
    by_id = {r.id: r for r in lib.records}
    for tube in ("li1800_philips_tld36w_15", "li1800_philips_tld36w_18"):
        assert by_id[tube].level2 is None and by_id[tube].excluded
        assert not lib.is_scored(by_id[tube])
    rgb = [r for r in lib.records if r.level2 == "led_rgb"]
    assert len(rgb) >= 9 and not any(lib.is_scored(r) for r in rgb)


def test_led_warm_cool_split_by_cct(lib):
    by_id = {r.id: r for r in lib.records}
    # CIE 015:2018 LED-B1 (2733 K) is warm, LED-B5 (6598 K) cool.
    assert by_id["cie_led_b1"].level2 == "led_warm"
    assert by_id["cie_led_b5"].level2 == "led_cool"
    for r in lib.records:
        if r.level2 in ("led_warm", "led_cool") and not r.modelled:
            cct, _ = _lamp_sources._cct_duv(
                lib.wavelength_nm[:401], lib.values[lib.index(r.id), :401]
            )
            assert (cct <= lamps.LED_WARM_MAX_CCT_K) == (r.level2 == "led_warm")


def test_values_are_per_lumen(lib):
    v = colour.SDS_LEFS["CIE 1924 Photopic Standard Observer"]
    w = lib.wavelength_nm
    vis = w <= 780
    lum = 683.0 * np.trapezoid(lib.values[:, vis] * v[w[vis]], w[vis], axis=1)
    np.testing.assert_allclose(lum, 1.0, rtol=1e-12)
    assert np.all(lib.values >= 0)


def test_shape_matches_source_spectrum(lib):
    sd = light_sources.SDS_LIGHT_SOURCES_NIST_TRADITIONAL["HPS"]
    row = lib.values[lib.index("nist_traditional_hps")]
    ratio = row[np.isin(lib.wavelength_nm, sd.wavelengths)] / sd.values
    ok = sd.values > 0.01 * sd.values.max()
    np.testing.assert_allclose(ratio[ok], ratio[ok][0], rtol=1e-10)


def test_li1800_photon_to_energy(lib, shared_dir):
    # Raw file value at 820 nm (photon units) -> energy -> same shape as the library.
    raw = np.loadtxt(
        shared_dir / "data/lamps_nir_li1800/Osram.Super.Vialox.PRN", comments='"'
    )
    energy = raw[:, 1] * 119.627 / raw[:, 0]
    row = lib.values[lib.index("li1800_osram_super_vialox")]
    at = lambda w, s, x: np.interp(x, w, s)  # noqa: E731
    np.testing.assert_allclose(
        at(lib.wavelength_nm, row, 820.0) / at(lib.wavelength_nm, row, 600.0),
        at(raw[:, 0], energy, 820.0) / at(raw[:, 0], energy, 600.0),
        rtol=1e-10,
    )


def test_extension_flags_and_switch(lib):
    off = library(extend_nir=False)
    for r_on, r_off, v_on, v_off in zip(
        lib.records, off.records, lib.values, off.values, strict=True
    ):
        beyond = lib.wavelength_nm > r_on.measured_range_nm[1]
        if r_on.nir_measured:  # held over the last < EDGE_HOLD_NM, not extended
            assert r_on.measured_range_nm[1] >= 900.0 - lamps.EDGE_HOLD_NM
            beyond[:] = False
        assert r_on.extended == bool(beyond.any()) and not r_off.extended
        assert np.all(np.isnan(v_off[beyond])) and np.all(np.isfinite(v_on))
        inside = ~beyond
        if r_on.measured_range_nm[1] < 780.0:
            # Cut below 780 nm: the extension's part up to 780 nm adds to the
            # lumen only when on, so the two rows agree up to their scale.
            v_on, v_off = v_on / np.max(v_on[inside]), v_off / np.max(v_off[inside])
        np.testing.assert_allclose(v_on[inside], v_off[inside], rtol=1e-12)
    by_id = {r.id: r for r in lib.records}
    assert by_id["li1800_osram_super_vialox"].extended is False
    assert by_id["nist_traditional_hps"].extension_validated is True
    assert by_id["nist_traditional_lps"].extension_validated is False
    # LEDs: now validated on measured LED tails (LSPDD, photobiology).
    assert by_id["cie_led_b1"].extension_validated is True
    assert by_id["nist_traditional_mercury"].extension_validated is False


def test_hps_extension_has_sodium_doublet(lib):
    row = lib.values[lib.index("nist_philips_c100s54_hps")]
    w = lib.wavelength_nm
    nirpart = w > 780
    assert 815 <= w[nirpart][np.argmax(row[nirpart])] <= 822


def test_modelled_spectra_labelled_not_counted(lib):
    modelled = [r for r in lib.records if r.modelled]
    assert {r.level1 for r in modelled} == {"incandescent", "fire"}
    # Lamps in a class but excluded (a datasheet-like curve) are listed apart.
    total = sum(c["lamps"] + c.get("excluded", 0) for c in lib.counts())
    assert total == len(lib) - len(modelled)


def test_planck_matches_colour(lib):
    w = np.arange(380.0, 901.0, 5.0)
    ours = lamps.planck_spectrum(w, 2856.0)  # [W m-2 sr-1 nm-1]
    # colour's default c2 is the CIE's rounded 1.4388e-2 m K; pass the exact h c / k.
    c2 = 6.62607015e-34 * 2.99792458e8 / 1.380649e-23
    ref = (
        colour.colorimetry.planck_law(w * 1e-9, 2856.0, c2=c2) * 1e-9
    )  # per m -> per nm
    np.testing.assert_allclose(ours, ref, rtol=1e-6)


def test_validation_sets_never_in_library(lib):
    assert {r.source_set for r in lib.records} <= {
        "li1800",
        "nist_philips",
        "nist_traditional",
        "nist_led",
        "cie015",
        "color_pollution",
        "photobiology",
        "lspdd",
        "planck",
    }
    assert not any("tm30" in r.id or "luxpy" in r.id for r in lib.records)


def test_bad_grid_rejected():
    with pytest.raises(ValueError, match="380-900"):
        library(wavelength_nm=np.arange(300.0, 901.0, 1.0))
    with pytest.raises(ValueError, match="uniform"):
        library(wavelength_nm=np.array([380.0, 381.0, 390.0]))


def test_new_sets_present_with_their_ids(lib):
    by_id = {r.id: r for r in lib.records}
    lspdd = [r for r in lib.records if r.source_set == "lspdd"]
    assert len(lspdd) >= 150
    assert all(re.fullmatch(r"lspdd_\d+", r.id) for r in lspdd)
    # The LSPDD record number is kept: 2608 is the Philips RoadStar road
    # luminaire (4100 K), a cool LED measured to 899.5 nm whose near-infrared
    # is clipped (not NIR evidence): extended from 780 nm.
    road = by_id["lspdd_2608"]
    assert "RoadStar" in road.name and road.level2 == "led_cool"
    assert road.extended and not road.nir_measured and road.licence.startswith("CC")
    assert "clipped" in road.cut_reason and road.source_range_nm[1] == 899.5
    assert by_id["lspdd_2481"].level2 == "metal_halide"
    assert by_id["photobiology_epileds_3w_590nm"].subtype == "direct_amber"
    assert by_id["color_pollution_philips_amber_pc_led"].subtype == "pc_amber"
    assert by_id["color_pollution_lps"].provenance_documented is False
    assert by_id["color_pollution_philips_amber_pc_led"].provenance_documented
    # The 13 LI-1800 lamps of the photobiology data are not taken twice.
    assert not any(
        "licor" in r.id or "vialox" in r.id
        for r in lib.records
        if r.source_set == "photobiology"
    )


def test_measured_to_900_nm_never_extended(lib):
    for r in lib.records:
        if r.source_set in ("lspdd", "photobiology", "color_pollution"):
            if r.measured_range_nm[1] >= 900.0 - lamps.EDGE_HOLD_NM:
                assert r.nir_measured and not r.extended, r.id
            elif r.source_range_nm is not None:  # cut: rejected NIR, zeros
                assert r.extended and r.cut_reason, r.id


def test_library_builds_without_lspdd(monkeypatch):
    off = library(lspdd=False)
    assert not any(r.id.startswith("lspdd_") for r in off.records)
    assert "lspdd" not in off.source_sets and len(off) < len(library())
    monkeypatch.setenv(lamps.LSPDD_ENV, "0")
    assert library().ids == off.ids
    monkeypatch.setenv(lamps.LSPDD_ENV, "1")
    assert any(i.startswith("lspdd_") for i in library().ids)


def test_lspdd_vendored_verbatim(shared_dir):
    vendored = sorted((_lamp_sources._LSPDD).glob("*.json"))
    assert len(vendored) >= 150
    for p in vendored:
        src = shared_dir / "data" / "lamps_lspdd" / p.name
        assert p.read_bytes() == src.read_bytes(), p.name


def test_lspdd_parser_handles_every_layout():
    text = "wavelength,relativeIntensity\n273.5,0,00E+00\r\n 300.00,1.3620E-005\r\n"
    text += "301,-0.000006\n,\n:5\n\n302,2.5E-01\n" + "".join(
        f"{400 + i},{i / 100:.4f}\n" for i in range(60)
    )
    w, v = lamps.parse_lspdd_spectrum(text)
    assert w[:4].tolist() == [273.5, 300.0, 301.0, 302.0]
    assert v[:4].tolist() == [0.0, 1.362e-5, 0.0, 0.25]
    with pytest.raises(ValueError, match="header"):
        lamps.parse_lspdd_spectrum("300,1\n")


def test_scored_classes_have_three_distinct_measured_lamps(lib):
    for c in lib.counts():
        if c["status"] == "scored":
            assert c["lamps"] >= lamps.MIN_LAMPS_FOR_SCORING, c
            assert c["lamps"] - c["cie_typical"] >= lamps.MIN_LAMPS_FOR_SCORING, c
    status = {c["level2"]: c["status"] for c in lib.counts()}
    assert status["led_amber"] == "scored"
    # Only two distinct measured LPS lamps exist here (NIST, color-pollution).
    assert status["lps"] == "insufficient for scoring"


def test_dedup_runs_against_cie_and_nist():
    fl2 = colour.SDS_ILLUMINANTS["FL2"]
    cie = _lamp_sources._Raw(
        "cie_fl2",
        "CIE FL2",
        "CIE2018",
        "cie015",
        "fluorescent_linear",
        fl2.wavelengths,
        fl2.values,
    )
    rng = np.random.default_rng(0)
    copy = _lamp_sources._Raw(
        "lspdd_copy",
        "copy",
        "LSPDD2016",
        "lspdd",
        "fluorescent_linear",
        fl2.wavelengths,
        3.0 * fl2.values * (1 + 0.01 * rng.standard_normal(81)),
    )
    other = _lamp_sources._Raw(
        "lspdd_other",
        "other",
        "LSPDD2016",
        "lspdd",
        "fluorescent_linear",
        fl2.wavelengths,
        fl2.values[::-1],
    )
    kept, dup_of, removed = _lamp_sources._dedup([copy, other, cie])
    assert removed == [("lspdd_copy", "cie_fl2")]
    assert sorted(kept) == [1, 2] and dup_of == {2: ["lspdd_copy"]}


def _peak(w, s, centre, half=0.8):
    m = (w >= centre - half) & (w <= centre + half)
    return float(w[m][np.argmax(s[m])]), float(s[m].max())


def test_color_pollution_lines_at_nist_wavelengths(lib):
    # Provenance of these tables is undocumented: their emission lines must sit
    # at the NIST air wavelengths (NISTASD) within 0.5 nm (0.5 nm resampled grid
    # + calibration), as local maxima standing out of their +-3 nm surroundings.
    hg = (404.66, 435.83, 546.07, 576.96, 579.07)
    cases = {
        "color_pollution_hgv": hg,
        "color_pollution_mh": (*hg, 819.48),
        "color_pollution_lps": (589.3, 568.82, 819.48),  # D lines unresolved
        "color_pollution_hps": (568.82, 818.9),  # doublet broadened, unresolved
    }
    meta = _lamp_sources._long_csv(_lamp_sources._COLOR_POLLUTION / "spectra.csv")
    for lamp_id, lines in cases.items():
        w, s = meta[
            lamp_id.removeprefix("color_pollution_").upper()
            if lamp_id != "color_pollution_hgv"
            else "HgV"
        ]
        for c in lines:
            at, peak = _peak(w, s, c)
            assert abs(at - c) <= 0.5, (lamp_id, c, at)
            around = (np.abs(w - c) > 2.5) & (np.abs(w - c) < 3.5)
            assert peak > 1.5 * s[around].max(), (lamp_id, c)
    # HPS: the Na D line is self-reversed (a dip at 589 nm between its wings).
    w, s = meta["HPS"]
    dip = s[(w > 588.5) & (w < 590.0)].min()
    assert dip < 0.5 * s[(w > 583) & (w < 588)].max()
    assert dip < 0.5 * s[(w > 590) & (w < 598)].max()


def _line(w, v, centre, half=2.0, contrast=1.3):
    m = (w >= centre - half) & (w <= centre + half)
    around = (np.abs(w - centre) > 4) & (np.abs(w - centre) < 7)
    return v[m].max() > contrast * v[around].max()


def test_new_sets_spectra_look_like_their_class(lib):
    # The classes of the new sets come from metadata (LSPDD `category`, R object
    # names, file names): check each against the physics of its class.
    w = lib.wavelength_nm
    new = ("lspdd", "photobiology", "color_pollution")

    def members(*l2):
        return [
            (r, v)
            for r, v in zip(lib.records, lib.values, strict=True)
            if r.level2 in l2 and r.source_set in new and r.excluded is None
        ]

    # Metal halide: Hg 546.1 nm, Na D and the Na 819 nm doublet.
    mh = members("metal_halide")
    assert len(mh) == 4
    for r, v in mh:
        assert _line(w, v, 546.0), r.id
        assert _line(w, v, 589.0, 3) and _line(w, v, 819.0, 3), r.id
    # CFLs: Hg 546.1 nm and the Eu3+ 611 nm phosphor line (85 %: a few LSPDD
    # records are too noisy for the 546 nm test).
    cfl = members("fluorescent_compact")
    ok = [_line(w, v, 546.0) and _line(w, v, 611.0) for _, v in cfl]
    assert len(cfl) >= 25 and np.mean(ok) >= 0.85
    # Incandescent/halogen: a smooth thermal spectrum rising through the visible
    # (20 nm means correlate with wavelength, r > 0.95, and double from 450 to
    # 730 nm), no line above 1.3x its 11 nm running mean (LSPDD noise is up to
    # 7 % per sample). The 20 nm blocks skip 570-610 nm and beyond 730 nm: the
    # neodymium-glass bulbs (GE Reveal, LSPDD 2484 and 2511, like NIST's
    # "Neodimium Incandescent") absorb there.
    for r, v in members("incandescent_halogen"):
        starts = [*range(450, 570, 20), *range(610, 730, 20)]
        blocks = [v[(w >= a) & (w < a + 20)].mean() for a in starts]
        run = np.convolve(v, np.ones(11) / 11, "same")
        m = (w >= 450) & (w <= 750)
        rising = np.corrcoef(blocks, np.arange(len(blocks)))[0, 1]
        assert rising > 0.95 and blocks[-1] > 2 * blocks[0], r.id
        assert np.max(v[m] / run[m]) < 1.3, r.id
    # White LEDs: a blue/violet pump (400-475 nm), a dip (to < 0.9 of the pump:
    # high-CRI packages fill the cyan), a phosphor band.
    for r, v in members("led_warm", "led_cool"):
        pump, dip = v[(w >= 400) & (w <= 475)].max(), v[(w >= 470) & (w <= 510)].min()
        # and a phosphor band rising above the dip (> 1.02x: high-CRI packages such
        # as the Bridgelux BXRE-50S2001-C-73 fill the cyan, so their phosphor peak
        # is only 1.06-1.18x the dip)
        assert dip < 0.9 * pump and v[(w >= 520) & (w <= 660)].max() > 1.02 * dip, r.id


def test_manifest_records_the_lamp_sets():
    from bandopt.provenance import lamp_library_info

    info = lamp_library_info()
    assert info["lspdd"] is True and info["source_sets"]["lspdd"] >= 150
    assert {"color_pollution", "photobiology", "li1800"} <= set(info["source_sets"])


def test_counts_table_pairs_classes_before_and_after():
    """A class absent before reads 0 lamps and "absent"; `|` in a status is
    escaped in the Markdown table."""
    from bandopt.datasets.lamp_report import counts_markdown, counts_table

    before = [{"level1": "hid", "level2": "hps", "lamps": 3, "status": "scored"}]
    after = [
        {"level1": "hid", "level2": "hps", "lamps": 7, "cie_typical": 1,
         "nir_measured": 2, "status": "scored"},
        {"level1": "led", "level2": None, "lamps": 0, "cie_typical": 0,
         "excluded": 4, "status": "excluded: |Duv| too large"},
    ]  # fmt: skip
    rows = counts_table(before, after)
    assert [r["lamps_before"] for r in rows] == [3, 0]
    assert [r["status_before"] for r in rows] == ["scored", "absent"]
    assert rows[1]["excluded_after"] == 4 and rows[0]["nir_measured_after"] == 2
    text = counts_markdown(rows, 3, 11)
    assert "| hid | hps | 3 | 7 | 1 | 2 | scored | scored |" in text
    assert "| 0 | absent | excluded: \\|Duv\\| too large |" in text
