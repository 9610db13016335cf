"""Figures of the GSD study: image grids with detection overlays, the
single-lamp cross-sections with the DoG response (thesis Figs. 4.8-4.9) and
F1 against GSD; the GSD images are also written as float32 TIFF."""

from pathlib import Path

import numpy as np

from ..strict_json import strict_dumps
from ._evaluate import cross_section, true_targets


def figures(out: Path, study, keep: dict, table: list[dict]) -> None:
    """Write the figures of a `GsdStudy` into `out`: `keep` maps (scene, GSD)
    to (first-phase observation, fine scene), `table` holds the phase-mean
    rows."""
    import matplotlib  # plotting only: start-up time

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt  # after matplotlib.use("Agg")
    import tifffile  # image files only: start-up time

    gsds = study.gsds_m
    names = [
        n
        for n in ("single", *study.arrangements, "mixed-led-hps")
        if (n, gsds[0]) in keep
    ]
    fig, axes = plt.subplots(
        len(names),
        len(gsds),
        figsize=(2.6 * len(gsds), 1.9 * len(names)),
        squeeze=False,
    )
    for a, name in enumerate(names):
        for b, gsd in enumerate(gsds):
            obs, scene = keep[(name, gsd)]
            tifffile.imwrite(
                out / "images" / f"{name}_gsd{gsd:g}m.tif",
                np.asarray(obs.image, np.float32),
                compression="zlib",
                metadata={"unit": "W m-2 sr-1 nm-1", "gsd_m": gsd},
            )
            ax = axes[a, b]
            _show(ax, obs, scene, zoom=True)
            s = obs.score
            ax.set_title(
                f"{name} {gsd:g} m\nP{s.precision:.2f} R{s.recall:.2f}", fontsize=7
            )
    fig.tight_layout()
    fig.savefig(out / "arrangements_by_gsd.png", dpi=100)
    plt.close(fig)
    for name in names:
        for gsd in gsds:
            obs, scene = keep[(name, gsd)]
            f, ax = plt.subplots(figsize=(9, 3.2))
            _show(ax, obs, scene, zoom=False)
            s = obs.score
            ax.set_title(
                f"{name}, GSD {gsd:g} m: precision {s.precision:.2f}, "
                f"recall {s.recall:.2f}, F1 {s.f1:.2f}",
                fontsize=9,
            )
            f.tight_layout()
            f.savefig(out / "images" / f"{name}_gsd{gsd:g}m.png", dpi=90)
            plt.close(f)
    _cross_sections(out, gsds, keep)
    _f1_plot(out, study.f1_needed, table)


def _show(ax, obs, scene, zoom: bool) -> None:
    """The band-mean image with true lamps (circles) and detections (+)."""
    g = obs.grid
    ext = (g.x0_m, g.x0_m + g.nx * g.dx_m, g.y0_m, g.y0_m + g.ny * g.dx_m)
    pan = obs.image.mean(axis=0)
    ax.imshow(
        np.sqrt(np.maximum(pan, 0)),
        origin="lower",
        extent=ext,
        cmap="magma",
        aspect="auto" if zoom else "equal",
    )
    t = true_targets(scene)
    ax.plot(t[:, 0], t[:, 1], "o", mfc="none", mec="cyan", ms=4)
    d = obs.detections.xy_m
    if d.size:
        ax.plot(d[:, 0], d[:, 1], "+", color="lime", ms=6)
    if zoom:
        ax.set_xlim(t[:, 0].min() - 60, t[:, 0].max() + 60)
        ax.set_ylim(-50, 50)
        ax.set_xticks([])
        ax.set_yticks([])


def _cross_sections(out: Path, gsds, keep: dict) -> None:
    """Figures 4.8-4.9: single-lamp radiance and DoG response along and across
    the road at every GSD up to 50 m, and their data (cross_sections.json)."""
    import matplotlib.pyplot as plt  # plotting only: start-up time

    data = {}
    for axis, fname in (
        ("along", "cross_section_along.png"),
        ("across", "cross_section_across.png"),
    ):
        fig, axes = plt.subplots(2, 1, figsize=(8, 6), sharex=True)
        for gsd in gsds:
            if gsd > 50:
                continue
            obs, scene = keep[("single", gsd)]
            cs = cross_section(obs, scene, axis)
            sel = np.abs(cs["position_m"]) <= 80
            axes[0].step(
                cs["position_m"][sel],
                cs["radiance"][sel],
                where="mid",
                label=f"{gsd:g} m",
            )
            axes[1].step(cs["position_m"][sel], cs["dog"][sel], where="mid")
            data[f"{axis}_{gsd:g}m"] = {
                k: np.asarray(v).tolist() if np.ndim(v) else v for k, v in cs.items()
            }
        axes[0].set_ylabel("TOA radiance [W m-2 sr-1 nm-1]")
        axes[1].set_ylabel("DoG response")
        axes[1].set_xlabel(f"distance from the lamp {axis} the road [m]")
        axes[0].legend(fontsize=8, title="GSD")
        axes[0].set_title(f"Single lamp, cross-section {axis} the road")
        fig.tight_layout()
        fig.savefig(out / fname, dpi=100)
        plt.close(fig)
    (out / "cross_sections.json").write_text(strict_dumps(data, indent=None) + "\n")


def _f1_plot(out: Path, f1_needed: float, table: list[dict]) -> None:
    """Phase-mean F1 against GSD for the arrangements, rows and patterns."""
    import matplotlib.pyplot as plt  # plotting only: start-up time

    fig, axes = plt.subplots(1, 3, figsize=(14, 4), sharey=True)
    for ax, group, key in (
        (axes[0], "arrangements", "arrangement"),
        (axes[1], "rows", None),
        (axes[2], "patterns", "pattern"),
    ):
        for name in dict.fromkeys(r["scene"] for r in table if r["group"] == group):
            rs = sorted(
                (r for r in table if r["scene"] == name), key=lambda r: r["gsd_m"]
            )
            ax.plot(
                [r["gsd_m"] for r in rs],
                [r["f1"] for r in rs],
                "o-",
                ms=3,
                label=name if key is None else rs[0][key],
            )
        ax.set_xscale("log")
        ax.axhline(f1_needed, color="grey", lw=0.8, ls="--")
        ax.set_title(group)
        ax.set_xlabel("GSD [m]")
        ax.legend(fontsize=6)
    axes[0].set_ylabel("F1 (mean over grid phases)")
    fig.tight_layout()
    fig.savefig(out / "f1_by_gsd.png", dpi=100)
    plt.close(fig)
