"""`bandopt map`: a GeoTIFF that `bandopt render --geotiff` wrote with known
lamps, mapped back to lamp types (right where a lamp dominates, dark road
masked), its georeference kept, resumed tile by tile, and bad rasters
refused or masked with messages naming the file and the fix.

The estimator is the tiny scenario set's quick inversion (as
`test_estimators_artefact`), fitted once by `bandopt fit`."""

import json
import shutil
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
import rasterio

import bandopt.search
from bandopt.cli import main
from bandopt.cli._map_raster import quiet
from bandopt.search import get_context

from .test_estimators_artefact import SMALL_CLI


LAYOUT = """
name = "two"
road_width_m = 7.0
length_m = 160.0
width_m = 40.0

[surfaces]
road = "asphalt"
sidewalk = "asphalt"
verge = "asphalt"

[[lamp]]
x_m = 20.0
y_m = 4.5
mounting_height_m = 8.0
lamp = "nist_traditional_hps"
flux_lm = 10000.0

[[lamp]]
x_m = 60.0
y_m = 4.5
mounting_height_m = 8.0
lamp = "cie_led_b3"
flux_lm = 10000.0
"""
"""An HPS and an LED lamp at one end of a 160 m road (the far end is dark), on
asphalt only: the tiny scenario set's estimator knows asphalt only (on the
default grass verge it calls most LED pixels HID)."""

ROOT = Path(__file__).resolve().parents[1]

DARK = 1e-7
"""--dark-below [W m-2 sr-1 nm-1]: above zero, below two quantisation steps of
the 14-bit render (6e-8), so unlit pixels and lone noise counts are dark."""


@pytest.fixture(scope="module")
def world(tmp_path_factory):
    """(folder, rendered TOA GeoTIFF, truth GeoTIFF, truth JSON, model file,
    cache folder): the scene rendered once, the estimator fitted once."""
    d = tmp_path_factory.mktemp("map")
    (d / "two.toml").write_text(LAYOUT)
    ctx = get_context("tiny", None, 0, "none")
    with pytest.MonkeyPatch.context() as mp:
        mp.setenv("BANDOPT_CACHE_DIR", str(d / "cache"))
        mp.setattr(bandopt.search, "get_context", lambda *a: ctx)
        render = [
            "render",
            "--layout",
            str(d / "two.toml"),
            "--gsd",
            "4",
            "--dx",
            "0.5",
            "--bands",
            "sdgsat-1",
            "--out",
            str(d / "r"),
            "--geotiff",
        ]
        assert main(render) == 0
        model = d / "model.npz"
        assert (
            main(["fit", "--bands", "sdgsat-1", *SMALL_CLI, "--out", str(model)]) == 0
        )
    r = d / "r"
    return (
        d,
        r / "two_gsd4m_toa.tif",
        r / "two_gsd4m_truth.tif",
        r / "two_gsd4m_truth.json",
        model,
    )


@pytest.fixture
def tiny_context(monkeypatch):
    ctx = get_context("tiny", None, 0, "none")
    monkeypatch.setattr(bandopt.search, "get_context", lambda *a: ctx)


def _map(image, out, *extra, model=None):
    argv = ["map", str(image), "--bands", "sdgsat-1", *SMALL_CLI, "--out", str(out)]
    if model is not None:
        argv += ["--model", str(model)]
    return main([*argv, *extra])


def _read(path, band=1):
    with rasterio.open(path) as src:
        return src.read(band)


def test_render_then_map_finds_the_lamp_types_and_masks_the_dark_road(
    world, tiny_context, tmp_path, capsys
):
    _, toa, truth_tif, truth_json, _ = world
    out = tmp_path / "m"
    assert _map(toa, out, "--dark-below", f"{DARK:g}") == 0  # fitted via the cache
    assert "estimator fitted and cached" in capsys.readouterr().err
    classes = json.loads((out / "classes.json").read_text())
    codes = json.loads(truth_json.read_text())["codes"]
    truth = _read(truth_tif, 1)
    share = _read(truth_tif, 2)
    mapped = _read(out / "level1.tif", 1)
    mask = _read(out / "mask.tif", 1)
    names = {**{int(k): v for k, v in classes["level1"].items()}, -1: None}
    true_l1 = np.array(
        [codes[str(int(c))]["level1"] if c >= 0 else "" for c in truth.ravel()]
    ).reshape(truth.shape)
    got_l1 = np.vectorize(lambda c: names.get(int(c), "masked"))(mapped)
    # lamp-lit pixels where one lamp gives >= 90 % of the light
    dominant = (share >= 0.9) & (mask == 0)
    assert dominant.sum() >= 100
    right = np.mean(got_l1[dominant] == true_l1[dominant])
    assert right >= 0.7, right  # a clear majority (measured 0.81; chance ~1/5)
    with rasterio.open(toa) as src:
        rad = src.read()
    bright = dominant & (rad.min(0) > 5 * 6.1e-8)  # every band >= 5 14-bit steps
    assert bright.sum() >= 30
    assert np.mean(got_l1[bright] == true_l1[bright]) >= 0.9  # measured 0.97
    assert {"hid", "led"} <= set(true_l1[dominant])
    # dark pixels (every band below --dark-below) are masked, nothing else is
    dark = (rad < DARK).all(0)
    assert np.array_equal(mask == 3, dark)
    road = np.abs(np.arange(10)[::-1] * 4.0 - 20.0 + 2.0) <= 3.5  # rows on the road
    far = np.zeros_like(dark)
    far[:, 35:] = True  # x >= 140 m: 80 m beyond the last lamp
    assert (mask[road[:, None] & far] == 3).all()
    assert (mapped[mask == 3] == classes["nodata"]).all()
    summary = json.loads((out / "map.json").read_text())
    assert summary["counts"]["dark"] == int(dark.sum())
    assert summary["dark"]["from"] == "--dark-below"


def test_outputs_keep_the_georeference_and_write_a_manifest(world, tmp_path, capsys):
    _, toa, *_, model = world
    out = tmp_path / "m"
    assert _map(toa, out, "--dark-below", f"{DARK:g}", "--json", model=model) == 0
    printed = json.loads(capsys.readouterr().out)
    assert printed == json.loads((out / "map.json").read_text())
    assert printed["image_bands"]["georeferenced"] is True
    with rasterio.open(toa) as src:
        crs, transform = src.crs, src.transform
    assert crs is not None and not transform.is_identity
    tifs = sorted(out.glob("*.tif"))
    assert len(tifs) == 7
    for f in tifs:
        with rasterio.open(f) as o:
            assert (o.crs, o.transform, o.dtypes[0]) == (crs, transform, "float32")
            assert o.nodata == -9999.0
    manifest = json.loads((out / "manifest.json").read_text())
    assert manifest["config"]["model"] == str(model)


def test_resume_skips_finished_tiles(world, tmp_path, capsys):
    _, toa, *_, model = world
    full = tmp_path / "full"
    args = ("--dark-below", f"{DARK:g}", "--tile", "16")
    assert _map(toa, full, *args, model=model) == 0
    ledger = (full / "tiles.jsonl").read_text().splitlines()
    assert len(ledger) == 1 + 3  # header, tiles of 16 x 16 over 10 x 40 pixels
    # a run killed after its first tile: the ledger's header and first tile
    part = tmp_path / "part"
    shutil.copytree(full, part)
    (part / "tiles.jsonl").write_text("\n".join(ledger[:2]) + "\n")
    with rasterio.open(part / "LER.tif", "r+") as dst:  # a mark in each tile
        v = dst.read()
        v[:, :, 0] = 7.0
        v[:, :, 20] = 7.0
        dst.write(v)
    capsys.readouterr()
    assert _map(toa, part, *args, model=model) == 2  # not without --resume
    assert "--resume" in capsys.readouterr().err
    assert _map(toa, part, *args, "--resume", model=model) == 0
    ler = _read(part / "LER.tif")
    assert (ler[:, 0] == 7.0).all()  # tile 0 was finished: skipped
    assert np.array_equal(ler[:, 20], _read(full / "LER.tif")[:, 20])  # redone
    summary = json.loads((part / "map.json").read_text())
    assert summary["tiles_skipped_on_resume"] == 1
    assert summary["counts"] == json.loads((full / "map.json").read_text())["counts"]
    # resuming with other options is refused, naming what differs
    assert (
        _map(toa, part, "--dark-below", "1e-6", "--tile", "16", "--resume", model=model)
        == 2
    )
    assert "dark" in capsys.readouterr().err


def _write(path, data, *, crs="EPSG:32632", scales=None, offsets=None, nodata=None):
    from affine import Affine

    data = np.asarray(data)
    kw = (
        {}
        if crs is None
        else {"crs": crs, "transform": Affine(4, 0, 691000, 0, -4, 5335020)}
    )
    with (
        quiet(),
        rasterio.open(
            path,
            "w",
            driver="GTiff",
            dtype=data.dtype,
            count=data.shape[0],
            height=data.shape[1],
            width=data.shape[2],
            nodata=nodata,
            **kw,
        ) as dst,
    ):
        dst.write(data)
        if scales is not None:
            dst.scales, dst.offsets = scales, offsets
    return path


@pytest.fixture
def patch(world):
    """8 x 8 pixels of the rendered image near the HPS lamp (4 bands), floored
    at one 14-bit step so that none is dark [W m-2 sr-1 nm-1]."""
    with rasterio.open(world[1]) as src:
        return np.maximum(src.read()[:, 1:9, :8].astype(np.float64), 6.1e-8)


def test_wrong_band_count_is_refused_naming_the_file(world, patch, tmp_path, capsys):
    f = _write(tmp_path / "three.tif", patch[:3].astype(np.float32))
    assert _map(f, tmp_path / "m", model=world[4]) == 2
    err = capsys.readouterr().err
    assert "three.tif" in err and "band count 3" in err and "4 bands" in err


def test_no_georeference_is_refused_unless_allowed(world, patch, tmp_path, capsys):
    f = _write(tmp_path / "plain.tif", patch.astype(np.float32), crs=None)
    assert _map(f, tmp_path / "m", model=world[4]) == 2
    err = capsys.readouterr().err
    assert (
        "plain.tif" in err and "no georeference" in err and "--allow-no-georef" in err
    )
    assert _map(f, tmp_path / "m", "--allow-no-georef", model=world[4]) == 0
    assert (_read(tmp_path / "m" / "mask.tif") == 0).all()


def test_nan_pixels_are_masked_counted_and_reported(world, patch, tmp_path, capsys):
    img = patch.astype(np.float32)
    img[2, 1, 1] = np.nan
    img[:, 5, 6] = np.nan
    img[:, 7, 7] = -1.0  # input nodata
    f = _write(tmp_path / "nan.tif", img, nodata=-1.0)
    assert _map(f, tmp_path / "m", model=world[4]) == 0
    assert "2 pixels with NaN" in capsys.readouterr().err
    mask = _read(tmp_path / "m" / "mask.tif")
    assert mask[1, 1] == 2 and mask[5, 6] == 2 and mask[7, 7] == 1
    counts = json.loads((tmp_path / "m" / "map.json").read_text())["counts"]
    assert counts["NaN_in_a_band"] == 2 and counts["input_nodata"] == 1
    assert counts["estimated"] == 64 - 3
    assert _read(tmp_path / "m" / "LER.tif")[1, 1] == -9999.0


def test_integer_dn_needs_a_calibration(world, patch, tmp_path, capsys):
    gain, offset = 1e-8, -2e-8
    dn = np.round((patch - offset) / gain).astype(np.uint16)
    f = _write(tmp_path / "dn.tif", dn)
    assert _map(f, tmp_path / "m0", model=world[4]) == 2
    err = capsys.readouterr().err
    assert "dn.tif" in err and "integer DN (uint16)" in err and "--gain" in err
    ref = tmp_path / "ref"
    radiance = (gain * dn.astype(np.float64) + offset).astype(np.float32)
    assert _map(_write(tmp_path / "rad.tif", radiance), ref, model=world[4]) == 0
    # with --gain/--offset, or with the scales/offsets stored in the GeoTIFF
    assert (
        _map(
            f,
            tmp_path / "m1",
            "--gain",
            f"{gain:g}",
            f"--offset={offset:g}",  # = : the value is negative
            model=world[4],
        )
        == 0
    )
    stored = _write(
        tmp_path / "dn_scaled.tif", dn, scales=[gain] * 4, offsets=[offset] * 4
    )
    assert _map(stored, tmp_path / "m2", model=world[4]) == 0
    want = _read(ref / "LER.tif")
    for run in ("m1", "m2"):
        np.testing.assert_allclose(_read(tmp_path / run / "LER.tif"), want, rtol=1e-4)
    calib = json.loads((tmp_path / "m2" / "map.json").read_text())["image_bands"]
    assert calib["calibration"] == "the GeoTIFF's band scales/offsets"


@pytest.mark.slow
def test_a_million_pixels_stay_within_one_gigabyte(world, patch, tmp_path):
    """Peak RSS of a child process mapping 1000 x 1000 pixels <= 1 GB."""
    img = np.tile(patch, (1, 125, 125)).astype(np.float32)  # none dark
    f = _write(tmp_path / "big.tif", img)
    code = (
        "import resource, sys\n"
        "from bandopt.cli import main\n"
        f"rc = main(['map', {str(f)!r}, '--bands', 'sdgsat-1', *{SMALL_CLI!r}, "
        f"'--out', {str(tmp_path / 'm')!r}, '--model', {str(world[4])!r}])\n"
        "print(rc, resource.getrusage(resource.RUSAGE_SELF).ru_maxrss)\n"
    )
    done = subprocess.run(
        [sys.executable, "-c", code],
        capture_output=True,
        text=True,
        check=True,
        timeout=3600,
        cwd=ROOT,  # this checkout's bandopt
    )
    rc, peak_kib = done.stdout.split()[-2:]
    assert rc == "0"
    print(f"peak RSS of the child mapping 1e6 pixels: {int(peak_kib) / 1024:.0f} MiB")
    assert int(peak_kib) * 1024 <= 1e9, f"peak RSS {int(peak_kib) / 1024:.0f} MiB"


def test_progress_says_how_many_tiles_and_the_time_left(monkeypatch):
    import io

    from bandopt.cli import _progress

    monkeypatch.setenv("BANDOPT_PROGRESS", "1")
    monkeypatch.setattr(_progress, "FIRST_REPORT_S", 0.0)
    stream = io.StringIO()
    steps = _progress.Steps("bandopt map: tiles", 10, skipped=4, stream=stream)
    steps.step(4)  # only skipped tiles so far: no rate yet
    assert "4 of 10" in stream.getvalue() and "time left unknown" in stream.getvalue()
    steps.next_s = 0.0
    steps.step(6)
    assert (
        "6 of 10" in stream.getvalue() and "left" in stream.getvalue().splitlines()[-1]
    )


def test_the_moon_is_checked_at_the_date_and_place(world, patch, tmp_path, capsys):
    f = _write(tmp_path / "img.tif", patch.astype(np.float32))
    place = ("--lat", "48.14", "--lon", "11.58")
    # full Moon 17 deg above Munich: the moonless estimator is not used
    assert (
        _map(f, tmp_path / "a", "--date", "2019-07-16T22:00", *place, model=world[4])
        == 2
    )
    err = capsys.readouterr().err
    assert "--date 2019-07-16T22:00" in err and "Moon is up" in err
    assert _map(f, tmp_path / "b", "--date", "2019-07-16T22:00", model=world[4]) == 2
    assert "go together" in capsys.readouterr().err
    # the same night at noon UTC the Moon is below the horizon: mapped, recorded
    assert (
        _map(f, tmp_path / "c", "--date", "2019-07-16T12:00", *place, model=world[4])
        == 0
    )
    moon = json.loads((tmp_path / "c" / "map.json").read_text())["moon"]
    assert moon["above_horizon"] is False and moon["date_utc"].startswith("2019-07-16")


@pytest.mark.slow
def test_a_killed_run_keeps_its_finished_tiles(world, patch, tmp_path):
    """A child process killed (SIGKILL) after some tiles: --resume skips them
    and the maps equal those of a run never interrupted."""
    img = np.tile(patch, (1, 8, 8)).astype(np.float32)  # 64 x 64: 16 tiles
    f = _write(tmp_path / "img.tif", img)
    out, full = tmp_path / "m", tmp_path / "full"
    args = ["--tile", "16", "--dark-below", f"{DARK:g}", "--model", str(world[4])]
    code = (
        "from bandopt.cli import main\n"
        f"main(['map', {str(f)!r}, '--bands', 'sdgsat-1', *{SMALL_CLI!r}, "
        f"'--out', {str(out)!r}, *{args!r}])\n"
    )
    child = subprocess.Popen([sys.executable, "-c", code], cwd=ROOT)
    ledger = out / "tiles.jsonl"
    t0 = time.monotonic()
    while time.monotonic() - t0 < 600 and child.poll() is None:
        if ledger.exists() and len(ledger.read_text().splitlines()) >= 3:
            break
        time.sleep(0.05)
    child.kill()
    child.wait()
    done = len(ledger.read_text().splitlines()) - 1
    assert 2 <= done < 16, done
    assert _map(f, out, *args, "--resume") == 0
    assert _map(f, full, *args) == 0
    summary = json.loads((out / "map.json").read_text())
    assert summary["tiles_skipped_on_resume"] >= done
    for stem in ("LER", "level1", "mask", "unexplained"):
        with (
            rasterio.open(out / f"{stem}.tif") as a,
            rasterio.open(full / f"{stem}.tif") as b,
        ):
            assert np.array_equal(a.read(), b.read(), equal_nan=True), stem


def test_dark_follows_the_band_sets_detection_limits(
    world, tiny_context, tmp_path, capsys
):
    toa = world[1]
    assert main(["bands", "sdgsat-1", "--json"]) == 0
    bands = json.loads(capsys.readouterr().out)
    names = [b["name"] for b in bands["bands"]]
    f = tmp_path / "bands.json"
    limits = {"PAN": DARK, "blue": DARK, "green": DARK, "red": 1e-3}  # as radiometry
    f.write_text(json.dumps({**bands, "detection_limit_w_m2_sr_nm": limits}))
    # the file's bands differ from sdgsat-1's in the last digits: fitted anew
    argv = ["map", str(toa), "--bands", str(f), *SMALL_CLI]
    assert main([*argv, "--out", str(tmp_path / "m")]) == 0
    with rasterio.open(toa) as src:
        rad = src.read()
    want = (rad < np.array([limits[n] for n in names])[:, None, None]).all(0)
    assert np.array_equal(_read(tmp_path / "m" / "mask.tif") == 3, want)
    dark = json.loads((tmp_path / "m" / "map.json").read_text())["dark"]
    assert dark["from"] == f"detection limit of --bands {f}"
    del limits["red"]
    f.write_text(json.dumps({**bands, "detection_limit_w_m2_sr_nm": limits}))
    assert main([*argv, "--out", str(tmp_path / "n")]) == 2
    err = capsys.readouterr().err
    assert str(f) in err and "no limit for band red" in err


def test_a_tile_with_every_pixel_masked_is_written_as_nodata(world, patch, tmp_path):
    img = np.tile(patch, (1, 2, 2)).astype(np.float32)  # 16 x 16: one tile
    img[:, :, 8:] = 0.0  # no signal: dark (no band above 0)
    out = tmp_path / "m"
    assert (
        _map(_write(tmp_path / "one.tif", img), out, "--tile", "16", model=world[4])
        == 0
    )
    wide = np.concatenate([img, np.zeros_like(img)], axis=2)  # a 2nd tile, all dark
    w = tmp_path / "w"
    assert (
        _map(_write(tmp_path / "wide.tif", wide), w, "--tile", "16", model=world[4])
        == 0
    )
    mask, ler = _read(w / "mask.tif"), _read(w / "LER.tif")
    assert (mask[:, 8:] == 3).all() and (ler[:, 8:] == -9999.0).all()
    assert np.array_equal(ler[:, :16], _read(out / "LER.tif"), equal_nan=True)
    assert json.loads((w / "map.json").read_text())["counts"]["dark"] == 16 * 24
