"""The mission report: one self-contained HTML file built only from `results/`.

`build_report(results_dir, out_dir)` reads the experiments' result files,
refuses to build when two files disagree about the same number
(`ReportDriftError`, see `check_consistency`), names every experiment that has
not been run as MISSING, and writes `out_dir/index.html` with every figure
embedded (base64 PNG) and every number linked to the file (and JSON pointer or
CSV row/column) it came from. `bandopt report --out DIR` and `make report` call
it.

`write_readme_section(section, results_dir)` writes the README sections that
quote the classification, spatial and noise-aware results (`_readme`).
`bandopt.report.before_after` sets the headline numbers of two revisions'
results side by side (`make before-after`); `check_in_browser` opens the
built page in headless Chromium and checks what a reader sees (`make
check-report`).
"""

import dataclasses
import datetime as _dt
import html
from pathlib import Path

from . import _sections
from ._browser import check_in_browser
from ._checks import CHECKS, ReportDriftError, check_consistency, spatial_median
from ._html import page
from ._readme import (
    README_SECTIONS,
    classification_text,
    noise_aware_text,
    spatial_text,
    write_readme_section,
)
from ._sections import EXPERIMENTS, Ctx
from ._source import ReportInputError, Sources, resolve_pointer


__all__ = [
    "EXPERIMENTS",
    "MAX_BYTES",
    "README_SECTIONS",
    "SECTIONS",
    "ReportDriftError",
    "ReportInputError",
    "ReportResult",
    "build_report",
    "check_consistency",
    "check_in_browser",
    "classification_text",
    "consistency_messages",
    "noise_aware_text",
    "resolve_pointer",
    "spatial_median",
    "spatial_text",
    "write_readme_section",
]

MAX_BYTES = 5_000_000
"""The report must stay below this size [bytes] (it is committed)."""

SECTIONS = (
    ("verdict", "Verdict: every target, pass or fail", "verdict"),
    ("recommended-sensor", "Recommended sensor", "recommended_sensor"),
    ("experiments", "Experiments and their status", "experiments_status"),
    ("comparison", "Comparison with reference sensors", "comparison"),
    ("band-count", "Error vs band count", "band_count"),
    ("search", "Stability and Pareto front of the band search", "search_figures"),
    (
        "classification",
        "Lamp-type classification: confusion matrices",
        "classification",
    ),
    ("radiometry", "Radiometry: radiance histograms, limits, bit depth", "radiometry"),
    ("spatial", "Spatial sampling: rendered scenes and detection vs GSD", "spatial"),
    ("overlap", "Overlapping lamp types", "overlap"),
    (
        "inversion",
        "Intervals of the shipped estimator: coverage and width",
        "inversion",
    ),
    ("provenance", "Provenance", "provenance"),
    ("consistency", "Consistency checks", None),
)
"""(HTML id, title, builder in `_sections`) of every section, in page order."""


@dataclasses.dataclass(frozen=True)
class ReportResult:
    path: Path
    bytes: int
    missing: tuple[str, ...]
    numbers: int
    disagreements: tuple[str, ...]
    sources: tuple[str, ...]


def consistency_messages(results_dir="results") -> list[str]:
    """Disagreements between the files of `results_dir` (empty: consistent)."""
    return check_consistency(Sources(results_dir, results_dir))


def folders_not_in_report(src: Sources) -> list[str]:
    """Folders of the results directory none of whose files the report read
    (the report's own folder aside)."""
    used = {Path(rel).parts[0] for rel in src.used}
    return sorted(
        p.name
        for p in src.root.iterdir()
        if p.is_dir() and p.name != "report" and p.name not in used
    )


def _not_in_report(src: Sources) -> str:
    """The results folders this page does not show, each linked to its folder
    (its README or its page in `results/README.md` says what it holds)."""
    names = folders_not_in_report(src)
    if not names:
        return ""
    links = ", ".join(
        f'<a href="{html.escape(src.href(n))}"><code>{html.escape(n)}/</code></a>'
        for n in names
    )
    return (
        f'<p class="note">Results not part of this report ({len(names)} folders; '
        "its README or its page in <code>results/README.md</code> says what it "
        f"holds): {links}.</p>"
    )


def build_report(
    results_dir="results", out_dir=None, *, strict: bool = True
) -> ReportResult:
    """Write `out_dir/index.html` (default `results_dir/report`) from the files
    of `results_dir`. With `strict=False` (tests of the page structure only) a
    disagreement is listed in the consistency section instead of raising; the
    command line is always strict.

    Raises:
        ReportDriftError: two results files disagree (lists every disagreement).
        ReportInputError: a results file is malformed (names file and field).
        FileNotFoundError: `results_dir` does not exist.
    """
    results_dir = Path(results_dir)
    if not results_dir.is_dir():
        raise FileNotFoundError(f"{results_dir}: no such results folder.")
    out_dir = Path(out_dir) if out_dir is not None else results_dir / "report"
    src = Sources(results_dir, out_dir)
    messages = check_consistency(src)
    if messages and strict:
        raise ReportDriftError(messages)
    ctx = Ctx(src)
    built = []
    for sid, title, builder in SECTIONS:
        if builder is None:
            body = _sections.consistency(ctx, messages, CHECKS)
        else:
            body = getattr(_sections, builder)(ctx)
        built.append((sid, title, body))
    now = _dt.datetime.now(_dt.UTC).isoformat(timespec="seconds")
    header = (
        f'<p class="note">Built {html.escape(now)} by <code>bandopt report</code> '
        f"from <code>{html.escape(str(results_dir))}/</code> only. Every number "
        "links to the results file it was read from (hover for the field).</p>"
        + _sections.missing_summary(ctx)
        + _not_in_report(src)
    )
    text = page("bandopt: night-time multispectral sensor report", built, header=header)
    out_dir.mkdir(parents=True, exist_ok=True)
    path = out_dir / "index.html"
    data = text.encode("utf-8")
    if len(data) > MAX_BYTES:
        raise ValueError(
            f"{path}: the report would be {len(data) / 1e6:.1f} MB, above the "
            f"{MAX_BYTES / 1e6:.0f} MB limit (figures too large?)."
        )
    path.write_bytes(data)
    return ReportResult(
        path=path,
        bytes=len(data),
        missing=tuple(ctx.missing),
        numbers=src.numbers,
        disagreements=tuple(messages),
        sources=tuple(sorted(src.used)),
    )
