"""Noise-aware band design: how the optimum bands move with signal level.

Photon noise of the thesis Table 2.3 sensor (shot noise, 256 TDI stages) is
added to the band signal of every scene (one seeded normal draw per scene and
band, common random numbers so the loss stays smooth and deterministic);
narrow bands collect fewer electrons and pay for it in the ratio estimators.
For each signal level (None: noise-free, then EN 13201 classes from bright to
dim) the joint target is searched with `n_bands` free bands + the fixed pan
band on all scored lamps (outer-fold CV loss), each level a resumable task of
`run_sweep`. `run_noise_aware` writes noise_aware.json, bands_vs_signal.png,
manifest.json and tasks/ into its folder.
"""

from collections.abc import Callable, Sequence
from pathlib import Path

from ..provenance import write_manifest
from ..strict_json import strict_dumps
from ._sweep import print_progress, run_sweep
from ._task import make_task


def noise_aware_tasks(
    levels: Sequence[str | None],
    *,
    n_bands: int = 3,
    max_evals: int = 300,
    seed: int = 0,
) -> list[dict]:
    """One search task per signal level (`make_task`, target "all", fixed pan,
    final fold, the "search" preset)."""
    return [
        make_task(
            target="all",
            n_bands=n_bands,
            pan="fixed",
            fold="final",
            seed=seed,
            max_evals=max_evals,
            preset="search",
            noise=lv,
        )
        for lv in levels
    ]


def run_noise_aware(
    levels: Sequence[str | None],
    out: str | Path,
    *,
    n_bands: int = 3,
    max_evals: int = 300,
    seed: int = 0,
    workers: int = 1,
    progress: Callable = print_progress,
) -> list[dict]:
    """Search every level, then write the outputs into `out`. Returns one row
    per finished level: `level`, `cv_loss` and the free `bands` as sorted
    (centre, FWHM) pairs [nm]."""
    tasks = noise_aware_tasks(levels, n_bands=n_bands, max_evals=max_evals, seed=seed)
    res = run_sweep(tasks, out, workers=workers, progress=progress)
    rows = []
    for lv, r in zip(levels, res, strict=True):
        if r is None:
            continue
        free = [b for b in r["bands"]["bands"] if b["name"] != "PAN"]
        rows.append(
            {
                "level": lv or "noise-free",
                "cv_loss": r["loss"],
                "bands": sorted((b["centre_nm"], b["fwhm_nm"]) for b in free),
            }
        )
    out = Path(out)
    (out / "noise_aware.json").write_text(
        strict_dumps(
            {
                "rows": rows,
                "note": f"{n_bands} free bands + fixed pan, target all, all scored "
                "lamps; sensor: thesis Table 2.3 (shot noise only)",
            },
            indent=2,
        )
        + "\n"
    )
    _figure(rows, out / "bands_vs_signal.png")
    write_manifest(out, seed=seed, config={"tasks": tasks})
    return rows


def _figure(rows: list[dict], path: Path) -> None:
    """Bars centre ± FWHM/2 per level, brighter levels at the top."""
    import matplotlib  # plotting only: start-up time

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt  # after matplotlib.use("Agg")

    fig, ax = plt.subplots(figsize=(8, 0.8 + 0.7 * len(rows)))
    for i, r in enumerate(rows):
        for c, f in r["bands"]:
            ax.barh(i, f, left=c - f / 2, height=0.5, alpha=0.6, color="C0")
            ax.plot([c], [i], "k|")
        ax.text(905, i, f"loss {r['cv_loss']:.3f}", va="center", fontsize=8)
    ax.set_yticks(range(len(rows)), [r["level"] for r in rows])
    ax.set_xlim(380, 960)
    ax.set_xlabel("wavelength [nm] (bars: centre ± FWHM/2)")
    ax.set_title("Optimum bands against signal level (brighter at top)")
    ax.invert_yaxis()
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)
