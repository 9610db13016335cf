"""The experiments the report reads and the state of one build (`Ctx`):
which experiments ran, which are MISSING and which were made with older data.

Every section module builds on these; kept apart from the sections so that
"has experiment X run?" has one answer, and the list of MISSING experiments
at the top of the report (`missing_summary`) is the one the sections filled.
"""

import dataclasses
import functools
import html

from ._html import esc, table
from ._source import Sources, fmt_number, missing_box


@dataclasses.dataclass(frozen=True)
class Experiment:
    """One experiment whose output the report reads."""

    key: str
    title: str
    marker: str  # a file (or folder, ending in "/") whose presence means "run"
    command: str


EXPERIMENTS = (
    Experiment("search", "Spectral band search (stability study)",
               "search/compare.json", "make run"),
    Experiment("classify", "Lamp-type classification", "classify/summary.json",
               "make classify"),
    Experiment("radiometry", "Radiometric sampling", "radiometry/summary.json",
               "make radiometry"),
    Experiment("spatial", "Spatial sampling (GSD)", "spatial/summary.json",
               "make spatial"),
    Experiment("overlap", "Overlapping lamp types", "spatial/overlap.json",
               "make spatial"),
    Experiment("robustness", "Intervals and robustness of the shipped estimator",
               "robustness/summary.json", "make robustness"),
    Experiment("library", "Lamp library and NIR-extension validation",
               "library/nir_validation.json", "python -m experiments.lamp_library"),
    Experiment("noise_aware", "Noise-aware bands", "noise_aware/noise_aware.json",
               "make noise-aware"),
    Experiment("bench", "Benchmarks", "bench/search.json", "make bench"),
)
BY_KEY = {e.key: e for e in EXPERIMENTS}
METRICS = ("LER", "G", "CCT")
UNITS = {"LER": "lm/W", "G": "", "CCT": "K"}


class Ctx:
    """Sources plus the list of experiments found missing while building."""

    def __init__(self, src: Sources):
        self.src = src
        self.missing: list[str] = []
        self.stale: dict[str, list[str]] = {}

    def ran(self, key: str) -> bool:
        e = BY_KEY[key]
        if e.marker.endswith("/"):
            folder = self.src.path(e.marker)
            return folder.is_dir() and any(folder.glob("*.json"))
        return self.src.exists(e.marker)

    def need(self, key: str) -> str | None:
        """None when experiment `key` ran, else its MISSING box (recorded)."""
        if self.ran(key):
            return None
        e = BY_KEY[key]
        if key not in self.missing:
            self.missing.append(key)
        return missing_box(
            f"{esc(e.title)} (no <code>results/{esc(e.marker)}</code>)",
            f"not run yet; produce it with <code>{esc(e.command)}</code>",
        )


def needs(key: str):
    """Decorator of a section builder that reads experiment `key`'s files:
    the section is `key`'s MISSING box (`Ctx.need`) while `key` has not run,
    else the builder's HTML."""

    def wrap(build):
        @functools.wraps(build)
        def section(ctx: Ctx) -> str:
            return ctx.need(key) or build(ctx)

        return section

    return wrap


def experiments_status(ctx: Ctx) -> str:
    src = ctx.src
    rows = []
    for e in EXPERIMENTS:
        ran = ctx.ran(e.key)
        if not ran and e.key not in ctx.missing:
            ctx.missing.append(e.key)
        folder = e.marker.split("/")[0] + "/"
        man = folder + "manifest.json"
        when = src.text(man, "/created_utc") if src.exists(man) else "no manifest"
        commit = (
            src.text(man, "/git_commit") if src.exists(man) else ""
        )
        rows.append([
            esc(e.title),
            '<span class="ok">run</span>' if ran else "<strong>MISSING</strong>",
            src.link(e.marker) if ran and not e.marker.endswith("/")
            else f"<code>results/{esc(e.marker)}</code>",
            f"<code>{esc(e.command)}</code>",
            when,
            commit,
        ])
    return table(
        ["experiment", "status", "result", "command", "run at (UTC)", "git commit"],
        rows,
    )


def missing_summary(ctx: Ctx) -> str:
    out = ""
    if not ctx.missing:
        out += '<p class="ok">Every experiment the report reads has been run.</p>'
    else:
        out += missing_box(
            "experiments not run: " + ", ".join(
                esc(BY_KEY[k].title if k in BY_KEY else k) for k in ctx.missing),
            "each section below says what produces it",
        )
    if ctx.stale:
        out += (
            '<p class="note"><strong>Made with older data:</strong> '
            + "; ".join(f"{esc(f)} ({esc(', '.join(d))})"
                        for f, d in sorted(ctx.stale.items()))
            + ' differ from the data of the newest result (see '
            '<a href="#provenance">Provenance</a>).</p>'
        )
    return out


def fmt(v) -> str:
    return html.escape(fmt_number(v))
