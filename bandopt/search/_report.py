"""Summaries and figures of search results (test MAE with lamp-bootstrap CIs,
relative reductions, bands drawn over lamp spectra)."""

import numpy as np

from ..datasets.lamps import library
from ..estimate import METRICS, UNITS
from ..folds import lamp_bootstrap_ci


def mae_ci(
    lamp_errors, lamp_index, classes, *, seed: int = 0, n_boot: int = 1000
) -> dict:
    """Class-balanced test MAE per metric with a 95 % lamp-bootstrap interval.
    `lamp_errors` (k, 3) for lamps `lamp_index` (each lamp once)."""
    e = np.asarray(lamp_errors, float)
    cls = np.asarray(classes, dtype=object)[np.asarray(lamp_index, int)]
    out = {}
    for m, name in enumerate(METRICS):
        ok = np.isfinite(e[:, m])
        est, lo, hi = lamp_bootstrap_ci(e[ok, m], cls[ok], n_boot=n_boot, seed=seed)
        out[name] = {"mae": est, "ci95": [lo, hi], "unit": UNITS[name]}
    return out


def paired_reduction(
    ours,
    theirs,
    lamp_index_ours,
    lamp_index_theirs,
    classes,
    *,
    n_boot: int = 1000,
    seed: int = 0,
) -> dict:
    """Relative MAE reduction `1 - MAE_ours / MAE_theirs` per metric with a 95 %
    paired lamp bootstrap (same lamps resampled within class for both)."""
    a = _by_lamp(ours, lamp_index_ours)
    b = _by_lamp(theirs, lamp_index_theirs)
    lamps = sorted(set(a) & set(b))
    cls = np.asarray(classes, dtype=object)[lamps]
    A = np.stack([a[i] for i in lamps])
    B = np.stack([b[i] for i in lamps])
    groups = [np.flatnonzero(cls == c) for c in sorted(set(cls.tolist()))]
    rng = np.random.default_rng(seed)
    out = {}
    for m, name in enumerate(METRICS):

        def stat(ix, m=m):
            ma = np.mean([np.nanmean(A[g, m]) for g in ix])
            mb = np.mean([np.nanmean(B[g, m]) for g in ix])
            return 1.0 - ma / mb

        est = stat(groups)
        boots = [stat([rng.choice(g, g.size) for g in groups]) for _ in range(n_boot)]
        out[name] = {
            "reduction": float(est),
            "ci95": [
                float(np.nanquantile(boots, 0.025)),
                float(np.nanquantile(boots, 0.975)),
            ],
        }
    return out


def _by_lamp(errors, index):
    return {int(i): np.asarray(e, float) for i, e in zip(index, errors, strict=True)}


def plot_bands_over_lamps(bands, path, *, title: str = "") -> None:
    """The band responses over the mean spectrum of each scored lamp class."""
    import matplotlib  # plotting only: start-up time

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt  # after matplotlib.use("Agg")

    lib = library().select(scored_only=True)
    wl = lib.wavelength_nm
    cls = np.asarray([r.level2 for r in lib.records], dtype=object)
    fig, ax = plt.subplots(figsize=(9, 4.5))
    for c in sorted(set(cls.tolist())):
        s = lib.values[cls == c].mean(axis=0)
        ax.plot(wl, s / s.max(), lw=0.9, alpha=0.7, label=c)
    r = np.asarray(bands.response(wl))
    ax2 = ax.twinx()
    for i, n in enumerate(bands.names):
        ax2.fill_between(wl, r[i], alpha=0.18)
        ax2.plot(wl, r[i], lw=1.6, color="k" if n == "PAN" else None)
        j = int(np.argmax(r[i]))
        ax2.text(wl[j], 1.02, n, ha="center", fontsize=8)
    ax.set_xlabel("wavelength [nm]")
    ax.set_ylabel("mean class spectrum (peak 1)")
    ax2.set_ylabel("relative response")
    ax2.set_ylim(0, 1.1)
    ax.legend(fontsize=7, ncol=2, loc="upper left")
    ax.set_title(title or bands.name)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)
