"""Photometric file parsers (EULUMDAT, IES LM-63, Illumina .lop) and luminaires.

The writers below are independent of the parsers: they follow the format
descriptions (EULUMDAT fixed line positions, LM-63-2002 layout) directly and
write *synthetic* files (no real product).
"""

import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from bandopt.spatial import (
    LOP_UPLIGHT_PERCENT,
    cutoff,
    from_file,
    from_lop,
    lambertian,
    luminaire,
    read_ies,
    read_ldt,
    read_lop,
    road_optic,
)
from bandopt.spatial._luminaire import C_DEG, GAMMA_DEG, SOLID_ANGLE_WEIGHTS


SYNTH = (
    Path(__file__).resolve().parents[1] / "bandopt" / "spatial" / "data" / "synthetic"
)


LDT_MC1_MC2 = {
    0: lambda mc: (1, mc),
    1: lambda mc: (1, 1),
    2: lambda mc: (1, mc // 2 + 1),
    3: lambda mc: (3 * mc // 4 + 1, 3 * mc // 4 + 1 + mc // 2),
    4: lambda mc: (1, mc // 4 + 1),
}


def ldt_text(
    full: np.ndarray,
    isym: int,
    dg: float,
    *,
    flux_lm: float = 1000.0,
    name: str = "synthetic",
) -> str:
    """EULUMDAT text of `full` (Mc, Ng) intensities [cd/klm] on C = 0, 360/Mc, ...
    and G = 0, dg, ..., storing only the planes symmetry `isym` needs."""
    mc, ng = full.shape
    dc = 360.0 / mc
    c = np.arange(mc) * dc
    g = np.arange(ng) * dg
    mc1, mc2 = LDT_MC1_MC2[isym](mc)
    planes = [full[(k - 1) % mc] for k in range(mc1, mc2 + 1)]
    lines = [
        "SYNTHETIC test file (not a product)",
        "1",
        str(isym),
        str(mc),
        f"{dc:g}",
        str(ng),
        f"{dg:g}",
        "report-0",
        name,
        "L-0",
        "synthetic.ldt",
        "2026-01-01",
        "500",
        "200",
        "100",
        "400",
        "150",
        "0",
        "0",
        "0",
        "0",
        "100",
        "80",
        "1.0",
        "0",
        "1",
        "1",
        "synthetic lamp",
        f"{flux_lm:g}",
        "3000",
        "80",
        "100",
        *["0.5"] * 10,
        *[f"{x:.12g}" for x in c],
        *[f"{x:.12g}" for x in g],
        *[f"{v:.6f}" for p in planes for v in p],
    ]
    return "\n".join(lines) + "\n"


def ies_text(
    horizontal: np.ndarray,
    vertical: np.ndarray,
    cand: np.ndarray,
    *,
    lumens: float = 1000.0,
    multiplier: float = 1.0,
    tilt: str = "NONE",
    ptype: int = 1,
    per_line: int = 7,
) -> str:
    """LM-63-2002 text with `cand` (h, v) [cd] on the given angles."""

    def block(values):
        vals = [f"{v:.12g}" for v in values]
        return [" ".join(vals[i : i + per_line]) for i in range(0, len(vals), per_line)]

    lines = [
        "IESNA:LM-63-2002",
        "[TEST] synthetic test file (not a product)",
        "[LUMINAIRE] synthetic",
        f"TILT={tilt}",
        f"1 {lumens:g} {multiplier:g} {len(vertical)} {len(horizontal)} {ptype} "
        "2 0.3 0.5 0.1",
        "1.0 1.0 100",
        *block(vertical),
        *block(horizontal),
    ]
    for row in cand:
        lines += block(row / multiplier)
    return "\r\n".join(lines) + "\r\n"


def symmetric_full(rng: np.random.Generator, mc: int, ng: int, isym: int) -> np.ndarray:
    """Random (mc, ng) intensities with the symmetry of `isym` on C = k 360/mc."""
    c = np.arange(mc) * 360.0 / mc
    base = rng.uniform(0.0, 500.0, size=(mc, ng))
    idx = {round(x, 6): k for k, x in enumerate(c)}

    def at(angle):
        return base[idx[round(angle % 360.0, 6)]]

    out = np.empty_like(base)
    for k, x in enumerate(c):
        if isym == 0:
            out[k] = base[k]
        elif isym == 1:
            out[k] = base[0]
        elif isym == 2:  # I(C) = I(360 - C)
            out[k] = at(x) if x <= 180 else at(360 - x)
        elif isym == 3:  # I(C) = I(180 - C)
            out[k] = at(x) if 90 <= x <= 270 else at(180 - x)
        elif isym == 4:
            y = x % 180.0
            y = y if x <= 180 else 360 - x
            out[k] = at(y if y <= 90 else 180 - y)
    return out


def _full_on(table, mc, gdeg):
    """The parsed table sampled at C = k 360/mc and the written G angles."""
    c = np.arange(mc) * 360.0 / mc
    out = np.empty((mc, gdeg.size))
    for k, ck in enumerate(c):
        row = [
            np.interp(ck, table.c_deg, table.intensity[:, m])
            for m in range(table.gamma_deg.size)
        ]
        out[k] = np.interp(gdeg, table.gamma_deg, row)
    return out


@settings(deadline=None, max_examples=25)
@given(
    isym=st.sampled_from([0, 1, 2, 3, 4]),
    mc=st.sampled_from([4, 8, 12, 24, 36]),
    ng=st.integers(3, 19),
    seed=st.integers(0, 2**31 - 1),
)
def test_ldt_symmetry_expansion_recovers_every_plane(
    tmp_path_factory, isym, mc, ng, seed
):
    """Writing only the planes a symmetry needs and parsing gives back every plane."""
    rng = np.random.default_rng(seed)
    full = symmetric_full(rng, mc, ng, isym)
    dg = 180.0 / (ng - 1)
    path = tmp_path_factory.mktemp("ldt") / "f.ldt"
    path.write_text(ldt_text(full, isym, dg))
    table = read_ldt(path)
    assert table.c_deg[0] == 0 and table.c_deg[-1] == 360
    np.testing.assert_allclose(table.intensity[0], table.intensity[-1])
    got = _full_on(table, mc, np.arange(ng) * dg)
    np.testing.assert_allclose(got, full, atol=1e-5)  # 6 decimals written


@settings(deadline=None, max_examples=25)
@given(
    kind=st.sampled_from(["rot", "quad", "bilat", "full", "bilat90"]),
    nv=st.integers(3, 15),
    per_line=st.integers(1, 12),
    mult=st.sampled_from([1.0, 0.5, 2.0]),
    seed=st.integers(0, 2**31 - 1),
)
def test_ies_symmetry_expansion(tmp_path_factory, kind, nv, per_line, mult, seed):
    rng = np.random.default_rng(seed)
    mc = 24
    isym = {"rot": 1, "quad": 4, "bilat": 2, "full": 0, "bilat90": 3}[kind]
    full = symmetric_full(rng, mc, nv, isym)
    c = np.arange(mc) * 15.0
    keep = {
        "rot": c == 0,
        "quad": c <= 90,
        "bilat": c <= 180,
        "full": np.ones(mc, bool),
        "bilat90": (c >= 90) & (c <= 270),
    }[kind]
    h = c[keep]
    cand = full[keep]
    if kind == "full":
        h = np.append(h, 360.0)
        cand = np.vstack([cand, cand[:1]])
    v = np.linspace(0.0, 180.0, nv)
    path = tmp_path_factory.mktemp("ies") / "f.ies"
    path.write_text(ies_text(h, v, cand, multiplier=mult, per_line=per_line))
    table = read_ies(path)
    np.testing.assert_allclose(_full_on(table, mc, v), full, rtol=1e-5, atol=1e-3)


def test_shipped_synthetic_files_agree_with_their_formula():
    """I = 100 cos γ (1 + 0.5 cos 2C) cd/klm, read from the files."""
    t = read_ldt(SYNTH / "batwing_isym4.ldt")
    for c, g in [(0, 0), (120, 30), (210, 60), (300, 80), (90, 120)]:
        j = int(np.flatnonzero(t.c_deg == c)[0])
        k = int(np.flatnonzero(t.gamma_deg == g)[0])
        ref = (
            100
            * max(math.cos(math.radians(g)), 0)
            * (1 + 0.5 * math.cos(math.radians(2 * c)))
        )
        assert t.intensity[j, k] == pytest.approx(ref, abs=1e-5)
    assert t.lamp_flux_lm == 1000.0
    i = read_ies(SYNTH / "batwing_quadrant.ies")
    assert i.lamp_flux_lm == 5000.0
    # the two files describe one distribution: equal once normalised to 1 lm
    a = np.asarray(from_file(SYNTH / "batwing_isym4.ldt").intensity_cd_per_lm)
    b = np.asarray(from_file(SYNTH / "batwing_quadrant.ies").intensity_cd_per_lm)
    np.testing.assert_allclose(a, b, atol=1e-5 * a.max())


def _ldt_lines():
    return ldt_text(np.ones((4, 5)), 0, 45.0).splitlines()


@settings(deadline=None, max_examples=20)
@given(line=st.integers(3, 50), junk=st.sampled_from(["abc", "1.2.3", "nan", "x7"]))
def test_ldt_malformed_number_names_file_and_line(tmp_path_factory, line, junk):
    lines = _ldt_lines()
    numeric = {3, 4, 5, 6, 7, 26, 29} | set(range(43, len(lines) + 1))
    if line not in numeric or line > len(lines):
        return
    lines[line - 1] = junk
    path = tmp_path_factory.mktemp("bad") / "broken.ldt"
    path.write_text("\n".join(lines))
    with pytest.raises(ValueError, match=rf"broken\.ldt: line {line}\b"):
        read_ldt(path)


@settings(deadline=None, max_examples=20)
@given(cut=st.integers(5, 60))
def test_truncated_files_raise_naming_the_file(tmp_path_factory, cut):
    d = tmp_path_factory.mktemp("trunc")
    lines = _ldt_lines()
    p = d / "short.ldt"
    p.write_text("\n".join(lines[: min(cut, len(lines) - 1)]))
    with pytest.raises(ValueError, match=r"short\.ldt: line \d+"):
        read_ldt(p)
    txt = ies_text(np.array([0.0]), np.array([0.0, 90.0, 180.0]), np.ones((1, 3)))
    toks = txt.split()
    q = d / "short.ies"
    q.write_text(" ".join(toks[: min(cut, len(toks) - 1)]))
    with pytest.raises(ValueError, match=r"short\.ies: line \d+"):
        read_ies(q)


def test_ies_refusals(tmp_path):
    v, h = np.array([0.0, 90.0]), np.array([0.0])
    p = tmp_path / "tilt.ies"
    p.write_text(ies_text(h, v, np.ones((1, 2)), tilt="INCLUDE"))
    with pytest.raises(ValueError, match=r"tilt\.ies: line 4: only TILT=NONE"):
        read_ies(p)
    p = tmp_path / "typeb.ies"
    p.write_text(ies_text(h, v, np.ones((1, 2)), ptype=2))
    with pytest.raises(ValueError, match=r"typeb\.ies: line 5: photometric type 2"):
        read_ies(p)
    p = tmp_path / "neg.ies"
    p.write_text(ies_text(h, v, -np.ones((1, 2))))
    with pytest.raises(ValueError, match=r"neg\.ies: line \d+: negative"):
        read_ies(p)
    p = tmp_path / "extra.ies"
    p.write_text(ies_text(h, v, np.ones((1, 2))) + "7\n")
    with pytest.raises(ValueError, match=r"extra\.ies: line 10: unexpected extra"):
        read_ies(p)
    with pytest.raises(ValueError, match="unknown photometric file type"):
        from_file(tmp_path / "x.txt")


def test_lop_files_match_their_shared_copies(shared_dir):
    for p in LOP_UPLIGHT_PERCENT:
        ours = read_lop(SYNTH.parent / "luminaires" / f"{p}_pcUPLIGHT.lop")
        raw = np.loadtxt(shared_dir / "data" / "luminaires" / f"{p}_pcUPLIGHT.lop")
        # γ = 180 - zenith: the downward value (zenith 180) is at γ = 0
        np.testing.assert_allclose(ours.intensity[0], raw[::-1, 0])
        np.testing.assert_allclose(ours.gamma_deg, 180.0 - raw[::-1, 1])


def test_lop_uplight_fractions():
    """0 % has none; 50 % is isotropic (exactly half up, and its zenith intensity
    is 1/(4π) per lumen); the others grow with the label (measured values, the
    1-2 % files send their light near the horizon)."""
    f = [from_lop(p).uplight_fraction for p in LOP_UPLIGHT_PERCENT]
    assert f[0] == pytest.approx(0.0, abs=1e-12)
    assert f[-1] == pytest.approx(0.5, abs=1e-3)
    assert np.all(np.diff(f) >= -1e-9)
    assert from_lop(50).zenith_cd_per_lm == pytest.approx(1 / (4 * math.pi), rel=1e-3)
    assert from_lop(20).uplight_fraction == pytest.approx(0.20, abs=0.01)


@pytest.mark.parametrize(
    "lum",
    [lambertian(), cutoff(), road_optic(), road_optic(uplight_fraction=0.2)],
    ids=lambda lum: lum.source[:30],
)
def test_normalised_to_one_lumen(lum):
    """Independent quadrature: midpoints in γ (4 per table step) and C, on the
    bilinear interpolant."""
    import jax.numpy as jnp

    from bandopt.spatial import lookup_cd_per_lm

    n_g = 1440  # midpoints, Δγ = 0.125°
    g = (np.arange(n_g) + 0.5) * math.pi / n_g
    wg = np.full(n_g, math.pi / n_g)
    c = (np.arange(288) + 0.5) * 2 * math.pi / 288
    cc, gg = np.meshgrid(c, g, indexing="ij")
    tab = lum.intensity_cd_per_lm[None]
    i = np.asarray(
        lookup_cd_per_lm(
            tab, jnp.zeros(cc.shape, int), jnp.asarray(cc), jnp.asarray(gg)
        )
    )
    flux = np.sum(i * np.sin(gg) * wg[None, :]) * 2 * math.pi / 288
    assert flux == pytest.approx(1.0, abs=2e-3)  # grid vs interpolant quadrature
    assert np.sum(np.asarray(lum.intensity_cd_per_lm) * SOLID_ANGLE_WEIGHTS) == (
        pytest.approx(1.0, rel=1e-12)
    )


def test_lambertian_and_road_optic_shapes():
    lam = np.asarray(lambertian().intensity_cd_per_lm)
    np.testing.assert_allclose(
        lam[0], np.maximum(np.cos(np.radians(GAMMA_DEG)), 0) / math.pi, atol=1e-3
    )
    ro = np.asarray(road_optic().intensity_cd_per_lm)
    c0 = int(np.argmin(np.abs(C_DEG - 0)))
    c90 = int(np.argmin(np.abs(C_DEG - 90)))
    c270 = int(np.argmin(np.abs(C_DEG - 270)))
    assert GAMMA_DEG[np.argmax(ro[c0])] == pytest.approx(68.0, abs=0.5)
    assert GAMMA_DEG[np.argmax(ro[c90])] == pytest.approx(45.0, abs=0.5)
    assert GAMMA_DEG[np.argmax(ro[c270])] == pytest.approx(15.0, abs=0.5)


def test_luminaire_registry():
    assert luminaire("Road_Optic") is luminaire("road-optic")
    assert luminaire("LOP 5").name == "lop-5pc"
    with pytest.raises(ValueError, match=r"Unknown luminaire 'nope'.*lambertian"):
        luminaire("nope")
    with pytest.raises(ValueError, match="uplight_percent=3"):
        from_lop(3)
