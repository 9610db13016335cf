"""Figures of the band-search studies: the stability study's designs over
resamples (`plot_stability`) and its Pareto front (`plot_pareto`); the
single-split study's error against band count (`plot_error_vs_bands`) and
its band approximating V(λ) (`plot_v_band`, cf. thesis Fig. 4.2)."""

import numpy as np

from ..estimate import METRICS, UNITS
from ..sensor import slit_super_gaussian


def _pyplot():
    """`matplotlib.pyplot` on the file-only Agg backend."""
    import matplotlib  # plotting only: start-up time

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt  # after matplotlib.use("Agg")

    return plt


def plot_stability(designs, stab, path, title) -> None:
    """One row per resample's design (bar: centre +/- FWHM/2) above the
    recommended design, with the range of each band's centre shaded; right:
    the fraction of resamples with a band in each region."""
    plt = _pyplot()
    fig, (ax, ax2) = plt.subplots(
        1, 2, figsize=(12, 4.8), gridspec_kw={"width_ratios": [3, 1]}
    )
    for i, d in enumerate(designs):
        for j, (c, f) in enumerate(zip(d["centre_nm"], d["fwhm_nm"], strict=True)):
            ax.plot([c - f / 2, c + f / 2], [i, i], color=f"C{j}", lw=3, alpha=0.6)
            ax.plot([c], [i], "k|", ms=8)
    m = stab["medoid_resample"]
    for j, (c, f) in enumerate(zip(stab["centre_nm"], stab["fwhm_nm"], strict=True)):
        lo, hi = stab["centre_interval_nm"][j]
        ax.axvspan(lo, hi, color=f"C{j}", alpha=0.12)
        ax.plot([c - f / 2, c + f / 2], [len(designs) + 0.8] * 2, color=f"C{j}", lw=6)
    ax.axhline(m, color="k", ls=":", lw=0.8)
    ax.set_yticks([*range(len(designs)), len(designs) + 0.8])
    ax.set_yticklabels(
        [f"p{d['partition']} f{d['fold']}" for d in designs] + ["recommended"],
        fontsize=7,
    )
    ax.set_xlabel(
        "wavelength [nm] (bar: centre +/- FWHM/2; shade: range of the centre)"
    )
    ax.set_title(title, fontsize=9)
    freq = stab["region_frequency"]
    ax2.barh(list(freq), list(freq.values()), color="0.5")
    ax2.set_xlim(0, 1)
    ax2.set_xlabel("fraction of resamples with a band there")
    ax2.tick_params(labelsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)


def plot_pareto(cands, refs, rec_key, path, note, others=None) -> None:
    """Normalised MAE against 1 - F1 of the candidates at the chosen band
    count (colour: log10 SNR; ringed: Pareto), the recommended one starred,
    `others` (other band counts) in grey, reference sensors as crosses."""
    plt = _pyplot()
    fig, ax = plt.subplots(figsize=(8, 5.5))
    xs = np.array([c["norm_mae_mean"] for c in cands.values()])
    ys = np.array([1 - c["f1_mean"] for c in cands.values()])
    ss = np.array([c["snr_median"] for c in cands.values()])
    sc = ax.scatter(xs, ys, c=np.log10(ss), cmap="viridis", s=60, zorder=3)
    for (k, c), x, y in zip(cands.items(), xs, ys, strict=True):
        ax.annotate(k, (x, y), fontsize=7, xytext=(3, 3), textcoords="offset points")
        if c.get("pareto"):
            ax.scatter([x], [y], s=160, facecolors="none", edgecolors="r", zorder=4)
    r = cands[rec_key]
    ax.scatter(
        [r["norm_mae_mean"]],
        [1 - r["f1_mean"]],
        marker="*",
        s=300,
        c="r",
        zorder=5,
        label=f"recommended: {rec_key}",
    )
    for k, v in (others or {}).items():
        if k in cands:
            continue
        ax.scatter([v["norm_mae_mean"]], [1 - v["f1_mean"]], marker="o", color="0.7")
        ax.annotate(k, (v["norm_mae_mean"], 1 - v["f1_mean"]), fontsize=6, color="0.5")
    for k, v in refs.items():
        ax.scatter(
            [v["norm_mae_mean"]], [1 - v["f1_mean"]], marker="x", color="0.4", s=30
        )
        ax.annotate(k, (v["norm_mae_mean"], 1 - v["f1_mean"]), fontsize=6, color="0.4")
    fig.colorbar(sc, label="log10 SNR of the weakest band (median scene, class P4)")
    ax.set_xlabel("normalised MAE (LER, G, CCT), mean over partitions")
    ax.set_ylabel("1 - level-2 macro F1 (KNN), mean over partitions")
    ax.set_title(
        "Pareto front at the chosen n (red rings: non-dominated in MAE, 1-F1, "
        "-log SNR); grey: other n at alpha 0; x: reference sensors",
        fontsize=9,
    )
    ax.legend(fontsize=8)
    fig.text(0.01, 0.005, note, fontsize=6)
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)


def plot_error_vs_bands(ours, references, path) -> None:
    """Outer-fold test MAE (95 % lamp-bootstrap CI) of each searched target
    against its band count (pan included), with five reference sensors."""
    plt = _pyplot()
    fig, axes = plt.subplots(1, 3, figsize=(14, 4.2))
    for ax, m in zip(axes, METRICS, strict=True):
        for target, style in (
            ("ler", "C0o-"),
            ("g", "C1s-"),
            ("cct", "C2^-"),
            ("all", "k.-"),
        ):
            pts = sorted(
                (v["n_bands"] + 1, v[m]["mae"], *v[m]["ci95"])
                for v in ours.values()
                if v["target"] == target
            )
            if pts:
                x, y, lo, hi = map(np.asarray, zip(*pts, strict=True))
                ax.errorbar(
                    x,
                    y,
                    yerr=[y - lo, hi - y],
                    fmt=style,
                    capsize=2,
                    label=f"ours ({target})",
                )
        for i, key in enumerate(
            ("sdgsat-1", "jilin-1-03b", "iss-dslr", "nightsat", "viirs-dnb")
        ):
            if key in references:
                ax.scatter(
                    [references[key]["n_bands"]],
                    [references[key][m]["mae"]],
                    marker="x",
                    s=60,
                    color=f"C{i + 3}",
                    label=key,
                )
        ax.set_xlabel("bands (including pan)")
        ax.set_ylabel(f"test MAE {m} [{UNITS[m]}]")
        ax.set_ylim(bottom=0)
    axes[0].legend(fontsize=7)
    fig.suptitle("Outer-fold test MAE (class-balanced, 95 % lamp bootstrap)")
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def plot_v_band(vb, path) -> None:
    """The band of `v_band_experiment` over the CIE 1924 photopic V(λ)."""
    plt = _pyplot()
    from colour.colorimetry import SDS_LEFS_PHOTOPIC  # plotting only: start-up time

    sd = SDS_LEFS_PHOTOPIC["CIE 1924 Photopic Standard Observer"]
    wl = np.arange(380.0, 901.0)
    r = np.asarray(
        slit_super_gaussian(
            wl, np.array([vb["centre_nm"]]), np.array([vb["fwhm_nm"]]), np.array([6.0])
        )
    )[0]
    fig, ax = plt.subplots(figsize=(7, 4))
    ax.plot(sd.wavelengths, sd.values, "k", label="V(λ) (CIE 1924)")
    ax.plot(
        wl,
        r,
        "C1",
        label=f"optimised band {vb['centre_nm']:.0f} nm, FWHM {vb['fwhm_nm']:.0f} nm",
    )
    ax.set_xlim(380, 900)
    ax.set_xlabel("wavelength [nm]")
    ax.set_ylabel("relative response")
    ax.set_title(
        "Band approximating V(λ) for LER = a + b·L_B/L_PAN (cf. thesis Fig. 4.2)"
    )
    ax.legend()
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)
