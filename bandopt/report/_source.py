"""Reading `results/`: every value the report shows comes through `Sources`,
which remembers the file and the location inside it so the HTML can link each
number to where it came from."""

import base64
import csv
import html
import json
import math
import os
from pathlib import Path


class ReportInputError(ValueError):
    """A results file the report needs is malformed (names file, field, problem)."""


class ReportUnreadableError(ReportInputError):
    """A results file cannot be read at all (not JSON, not UTF-8): the report
    stops naming it, never counting it as a disagreement between files."""


def escape_pointer(token) -> str:
    """One RFC 6901 JSON-pointer token."""
    return str(token).replace("~", "~0").replace("/", "~1")


def pointer(*tokens) -> str:
    """A JSON pointer from path tokens: `pointer("a", 0, "b") == "/a/0/b"`."""
    return "".join("/" + escape_pointer(t) for t in tokens)


def resolve_pointer(data, ptr: str, *, where: str = "?"):
    """The value at JSON pointer `ptr` in `data` (dicts and lists). CSV tables
    are lists of row dicts, so `/3/column` is row 3 (from 0), column `column`."""
    if ptr in ("", "/"):
        return data
    if not ptr.startswith("/"):
        raise ReportInputError(f"{where}: pointer {ptr!r} must start with '/'.")
    cur = data
    for raw in ptr[1:].split("/"):
        tok = raw.replace("~1", "/").replace("~0", "~")
        if isinstance(cur, list):
            try:
                cur = cur[int(tok)]
            except (ValueError, IndexError) as err:
                raise ReportInputError(
                    f"{where}: no list item {tok!r} at {ptr!r}."
                ) from err
        elif isinstance(cur, dict):
            if tok not in cur:
                raise ReportInputError(f"{where}: no field {tok!r} at {ptr!r}.")
            cur = cur[tok]
        else:
            raise ReportInputError(f"{where}: {ptr!r} goes into a scalar.")
    return cur


def fmt_number(value, digits: int = 3) -> str:
    """`digits` significant digits; integers as integers; None/NaN as 'n/a'."""
    if value is None:
        return "n/a"
    if isinstance(value, bool):
        return str(value)
    if isinstance(value, int):
        return str(value)
    v = float(value)
    if math.isnan(v):
        return "n/a"
    if v == 0:
        return "0"
    if abs(v) >= 1e5 or abs(v) < 1e-3:
        return f"{v:.{digits - 1}e}"
    if abs(v) >= 10 ** (digits - 1):
        return f"{v:.0f}"
    return f"{v:.{digits}g}"


class Sources:
    """Reader of one results folder, rendering values as linked HTML.

    Args:
        results_dir: the `results/` folder read [path].
        out_dir: where the HTML is written; links are relative to it [path].
    """

    def __init__(self, results_dir, out_dir):
        self.root = Path(results_dir)
        self.out_dir = Path(out_dir)
        self._cache: dict[str, object] = {}
        self.used: set[str] = set()
        self.numbers = 0

    # -- files -----------------------------------------------------------------
    def path(self, rel: str) -> Path:
        return self.root / rel

    def exists(self, rel: str) -> bool:
        return self.path(rel).is_file()

    def href(self, rel: str) -> str:
        target = self.path(rel).resolve()
        try:
            return Path(os.path.relpath(target, self.out_dir.resolve())).as_posix()
        except ValueError:  # another drive (Windows)
            return target.as_uri()

    def load(self, rel: str):
        """A JSON file as Python objects, a CSV file as a list of row dicts."""
        if rel in self._cache:
            return self._cache[rel]
        path = self.path(rel)
        if not path.is_file():
            raise FileNotFoundError(f"{path}: results file not found.")
        try:
            text = path.read_text()
        except UnicodeDecodeError as err:
            raise ReportUnreadableError(
                f"{path}: not a UTF-8 text file ({err})."
            ) from None
        if rel.endswith(".json"):
            try:
                data = json.loads(text)
            except json.JSONDecodeError as err:
                raise ReportUnreadableError(
                    f"{path}: not valid JSON ({err})."
                ) from None
        elif rel.endswith(".csv"):
            data = list(csv.DictReader(text.splitlines()))
        else:
            raise ReportInputError(f"{path}: only .json and .csv are read.")
        self._cache[rel] = data
        self.used.add(rel)
        return data

    def get(self, rel: str, ptr: str):
        return resolve_pointer(self.load(rel), ptr, where=str(self.path(rel)))

    def csv_row(self, rel: str, **match) -> int:
        """Index of the first CSV row whose columns equal `match`."""
        for i, row in enumerate(self.load(rel)):
            if all(row.get(k) == str(v) for k, v in match.items()):
                return i
        raise ReportInputError(f"{self.path(rel)}: no row with {match}.")

    # -- HTML ------------------------------------------------------------------
    def num(self, rel: str, ptr: str, *, digits: int = 3, scale: float = 1.0,
            suffix: str = "") -> str:
        """The value at (`rel`, `ptr`) as a link to its file; `scale` multiplies
        the shown value (e.g. 100 for a percentage), `data-value` keeps the raw
        one so tests can compare the page with the file."""
        value = self.get(rel, ptr)
        raw = _as_number(value, where=f"{self.path(rel)} {ptr}")
        self.numbers += 1
        shown = "n/a" if raw is None else fmt_number(
            raw * scale if scale != 1.0 else raw, digits
        )
        return (
            f'<a class="num" href="{html.escape(self.href(rel))}" '
            f'data-src="{html.escape(rel)}" data-ptr="{html.escape(ptr)}" '
            f'data-value="{html.escape(repr(raw))}" data-scale="{scale!r}" '
            f'title="{html.escape(rel + " " + ptr)}">{html.escape(shown)}{suffix}</a>'
        )

    def interval(self, rel: str, ptr: str, *, digits: int = 3,
                 scale: float = 1.0) -> str:
        """`[lo, hi]` of a two-item list, each end linked."""
        return (
            f"[{self.num(rel, ptr + '/0', digits=digits, scale=scale)}, "
            f"{self.num(rel, ptr + '/1', digits=digits, scale=scale)}]"
        )

    def text(self, rel: str, ptr: str, *, shown=None) -> str:
        """A string field, escaped, linked to its file; `shown(value)`: the
        HTML to show for it instead (e.g. a plain name)."""
        value = self.get(rel, ptr)
        label = html.escape(str(value)) if shown is None else shown(value)
        return (
            f'<a class="txt" href="{html.escape(self.href(rel))}" '
            f'title="{html.escape(rel + " " + ptr)}">{label}</a>'
        )

    def link(self, rel: str, label: str | None = None) -> str:
        return (
            f'<a href="{html.escape(self.href(rel))}">'
            f"<code>{html.escape(label or rel)}</code></a>"
        )

    def image(self, rel: str, caption: str, *, width: str = "100%") -> str:
        """A PNG embedded as base64 with its caption, or a MISSING box."""
        path = self.path(rel)
        if not path.is_file():
            return missing_box(f"figure <code>{html.escape(rel)}</code>", "")
        data = base64.b64encode(path.read_bytes()).decode("ascii")
        self.used.add(rel)
        return (
            '<figure><img alt="' + html.escape(caption) + '" style="max-width:'
            + width + '" src="data:image/png;base64,' + data + '"><figcaption>'
            + html.escape(caption) + " (" + self.link(rel) + ")</figcaption></figure>"
        )


def _as_number(value, *, where: str):
    if value is None or value == "":
        return None
    if isinstance(value, bool):
        raise ReportInputError(f"{where}: expected a number, got {value!r}.")
    if isinstance(value, int | float):
        return value
    try:
        return int(value) if str(value).lstrip("-").isdigit() else float(value)
    except (TypeError, ValueError) as err:
        raise ReportInputError(f"{where}: expected a number, got {value!r}.") from err


def missing_box(what: str, how: str) -> str:
    """The visible marker of an experiment or file that is not in results/."""
    return (
        f'<div class="missing"><strong>MISSING</strong>: {what}'
        + (f" &mdash; {how}" if how else "")
        + "</div>"
    )
