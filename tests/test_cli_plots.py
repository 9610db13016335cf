"""Issue 15 item 8: figures a person can read. Axis labels with units, a
colour bar with units and the band shown, band colours that match their
names, legends beside the data, lamp spectra over the whole band range, and
the new `metrics --plot` and `classify --plot` (confusion matrix)."""

import matplotlib
import numpy as np
import pytest
from matplotlib.colors import to_rgb
from matplotlib.figure import Figure

from bandopt.cli import main


@pytest.fixture
def figures(monkeypatch):
    """Every figure saved by a command (the real savefig still runs)."""
    saved = []
    original = Figure.savefig

    def spy(self, *args, **kwargs):
        saved.append(self)
        return original(self, *args, **kwargs)

    monkeypatch.setattr(Figure, "savefig", spy)
    return saved


def _labelled(ax) -> bool:
    return "[" in ax.get_xlabel() and "[" in ax.get_ylabel()


def _legend_outside(ax) -> bool:
    leg = ax.get_legend()
    if leg is None:
        return True
    fig = ax.figure
    fig.canvas.draw()
    box = leg.get_window_extent()
    axes_box = ax.get_window_extent()
    return box.x0 >= axes_box.x1 - 1 or box.y1 <= axes_box.y0 + 1


def test_metrics_plot(tmp_path, figures):
    w = np.arange(380.0, 901.0)
    f = tmp_path / "lamp.csv"
    s = np.exp(-(((w - 600) / 40) ** 2))
    f.write_text("\n".join(f"{a:g},{b:.8g}" for a, b in zip(w, s, strict=True)))
    png = tmp_path / "m.png"
    assert main(["metrics", str(f), "--plot", str(png)]) == 0
    assert png.is_file() and png.stat().st_size < 300_000
    (fig,) = figures
    (ax,) = fig.axes
    assert _labelled(ax) and _legend_outside(ax)
    labels = [t.get_text() for t in ax.get_legend().get_texts()]
    assert any("LER" in t and "lamp" in t for t in labels)
    assert any("V(λ)" in t for t in labels)


def test_bands_plot_colours_match_names(tmp_path, figures):
    png = tmp_path / "b.png"
    assert main(["bands", "nightsat", "--plot", str(png)]) == 0
    (fig,) = figures
    (ax,) = fig.axes
    assert _labelled(ax) and _legend_outside(ax)
    colour = {
        ln.get_label().split(" ")[0]: to_rgb(ln.get_color()) for ln in ax.get_lines()
    }
    r, g, b = colour["TM3-red"]
    assert r > 0.6 and g < 0.2 and b < 0.2
    r, g, b = colour["TM1-blue"]
    assert b > 0.6 and r < 0.2
    r, g, b = colour["TM2-green"]
    assert g > 0.4 and r < 0.2 and b < 0.2
    # lamp spectra cover the whole band range (to 900 nm), not only to 780 nm
    for poly in ax.collections:
        xs = np.concatenate([p.vertices[:, 0] for p in poly.get_paths()])
        assert xs.max() >= 899.0


def test_band_colour_by_wavelength():
    from bandopt.cli._plots import band_colour

    assert band_colour(450.0, 30.0, "b1")[2] > 0.5  # blue
    r, g, _ = band_colour(530.0, 30.0, "b2")
    assert g > r  # green
    assert band_colour(650.0, 30.0, "b3")[0] > 0.5  # red
    assert band_colour(600.0, 400.0, "wide") == (0.0, 0.0, 0.0)  # panchromatic


def test_library_plot_has_a_y_label(tmp_path, figures):
    assert main(["library", "--plot", str(tmp_path / "l.png")]) == 0
    (fig,) = figures
    visible = [ax for ax in fig.axes if ax.get_visible() and ax.axison]
    first_col = [ax for ax in visible if ax.get_subplotspec().is_first_col()]
    last_row = [ax for ax in visible if ax.get_subplotspec().is_last_row()]
    assert first_col and all("[1]" in ax.get_ylabel() for ax in first_col)
    assert last_row and all("[nm]" in ax.get_xlabel() for ax in last_row)


def test_render_png_has_a_colour_bar_with_units(tmp_path, figures):
    out = tmp_path / "r"
    assert main(["render", "--layout", "single", "--gsd", "10", "--out", str(out),
                 "--bands", "viirs-dnb"]) == 0  # fmt: skip
    (fig,) = figures
    assert len(fig.axes) == 2  # the image and its colour bar
    image_ax, bar = fig.axes
    assert "[m]" in image_ax.get_xlabel() and "[m]" in image_ax.get_ylabel()
    label = bar.get_ylabel()
    assert "W m" in label and "DNB" in label
    assert _legend_outside(image_ax)


def test_classify_plot_confusion_matrix(tmp_path, figures):
    png = tmp_path / "c.png"
    args = ["--bands", "aerocube", "--scenarios", "quick", "--no-noise",
            "--atmospheres", "none", "--plot", str(png)]  # fmt: skip
    assert main(["classify", *args]) == 0
    assert png.is_file() and png.stat().st_size < 300_000
    (fig,) = figures
    mats = [ax for ax in fig.axes if ax.images]
    assert len(mats) == 2  # level 1 and level 2
    for ax in mats:
        assert ax.get_xlabel() == "predicted class" and ax.get_ylabel() == "true class"
        data = ax.images[0].get_array()
        rows = np.asarray(data).sum(axis=1)
        assert np.all((np.abs(rows - 1) < 1e-9) | (rows == 0))  # fractions per row
    assert any("fraction" in ax.get_ylabel() for ax in fig.axes if not ax.images)


matplotlib.use("Agg")


def test_evaluate_plot_truth_vs_estimate(tmp_path, figures):
    """`evaluate --plot`: per metric the estimates with their 90 % intervals
    against the truth, axes with units, one legend below the panels. The
    figure code runs on rows of the `evaluate --json` form (training the
    estimators for a real run takes ~40 s: tests/test_cli_answers.py)."""
    from matplotlib.container import ErrorbarContainer

    from bandopt.cli._cmd_evaluate import _plot

    def row(t, e, iv):
        return {"true": t, "estimate": e, "interval90": iv}

    rows = [
        row({"LER": 300.0, "G": 0.5, "CCT": 2000.0},
            {"LER": 290.0, "G": 0.6, "CCT": 2100.0},
            {"LER": [270.0, 310.0], "G": [0.4, 0.8], "CCT": [1900.0, 2400.0]}),
        row({"LER": 320.0, "G": 2.0, "CCT": None},  # CCT not meaningful: skipped
            {"LER": 330.0, "G": 1.8, "CCT": 5000.0},
            None),  # ridge without intervals
    ]  # fmt: skip
    png = tmp_path / "e.png"
    _plot(rows, "viirs-dnb", "inversion", png)
    assert png.is_file() and png.stat().st_size < 300_000
    (fig,) = figures
    axes = fig.axes
    assert len(axes) == 3
    for ax, metric, n in zip(axes, ("LER", "G", "CCT"), (2, 2, 1), strict=True):
        assert _labelled(ax) and metric in ax.get_xlabel()
        (bars,) = [c for c in ax.containers if isinstance(c, ErrorbarContainer)]
        assert len(bars.lines[0].get_xdata()) == n
        assert ax.get_legend() is None
    (legend,) = fig.legends
    fig.canvas.draw()
    top = legend.get_window_extent().y1
    assert all(top <= ax.get_window_extent().y0 for ax in axes)  # below the data
