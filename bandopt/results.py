"""Shared result files: `results/recommendation.json`, merged by every
experiment, and the results index `results/README.md` with one page per
experiment under `results/sections/`.

Each experiment owns one top-level key (`"spectral"`, `"classification"`,
`"radiometry"`, `"spatial"`) and replaces only that key, so experiments can run
in any order and a re-run overwrites only its own part. Every part records
what made it (`made_by`: mode, settings, command line, git commit, time), so a
quick or partial run can never pass for the full result.
"""

import datetime as _dt
import hashlib
import json
import os
import sys
import tempfile
from pathlib import Path

import numpy as np

from .provenance import data_versions, git_commit
from .strict_json import strict_dumps


RESULTS_DIR = Path(os.environ.get("BANDOPT_RESULTS", "results"))
RECOMMENDATION = "recommendation.json"


def _made_by(mode, settings) -> dict:
    return {
        "mode": mode,
        "settings": settings,
        "command_line": list(sys.argv),
        "git_commit": git_commit(),
        "created_utc": _dt.datetime.now(_dt.UTC).isoformat(timespec="seconds"),
    }


def update_recommendation(
    key: str,
    value,
    *,
    results_dir: str | Path | None = None,
    path: str | Path | None = None,
    mode: str | None = None,
    settings: dict | None = None,
) -> Path:
    """Replace `key` in `results/recommendation.json` (or the file `path`;
    created if missing), writing atomically so a crash never leaves a
    half-written file.

    A dict `value` gets a `made_by` entry: `mode` (e.g. "quick", "full"; else
    `value["mode"]` or None), `settings` (else `value["settings"]` or None),
    the command line, git commit and time of the run.
    """
    if path is not None:
        path = Path(path)
        root = path.parent if str(path.parent) else Path(".")
    else:
        root = Path(results_dir) if results_dir is not None else RESULTS_DIR
        path = root / RECOMMENDATION
    root.mkdir(parents=True, exist_ok=True)
    try:
        data = json.loads(path.read_text()) if path.is_file() else {}
    except ValueError as err:
        raise ValueError(f"{path}: not valid JSON ({err}).") from None
    if not isinstance(data, dict):
        raise ValueError(f"{path}: expected a JSON object at the top level.")
    if isinstance(value, dict):
        value = {
            **value,
            "made_by": _made_by(
                mode if mode is not None else value.get("mode"),
                settings if settings is not None else value.get("settings"),
            ),
        }
    data[key] = value
    fd, tmp = tempfile.mkstemp(dir=root, prefix=".recommendation-", suffix=".json")
    with os.fdopen(fd, "w") as fh:
        fh.write(strict_dumps(data, indent=2))
        fh.write("\n")
    os.chmod(tmp, 0o644)
    os.replace(tmp, path)
    return path


BAND_FIELDS = ("name", "centre_nm", "fwhm_nm", "shape_k", "edges_nm")
"""Fields of a band in a hand-written `bands` list that make the band; the
others (intervals, tolerances) are reporting."""


def recommended_band_set(
    key: str,
    *,
    results_dir: str | Path | None = None,
    path: str | Path | None = None,
):
    """The band set experiment `key` (`"spectral"`, `"classification"`)
    recommended, from `results/recommendation.json` (or the file `path`): the
    one reader of band sets in recommendation files (the radiometry command
    and the experiments call it; nothing else parses them).

    Two forms, in this order, no guessing between others:

    1. `entry["band_set"]`: the `BandSet.to_dict()` form every experiment
       writes;
    2. an entry without `band_set` whose `bands` is a non-empty list of bands
       (`name`, `centre_nm`, `fwhm_nm`, optional `shape_k` or `edges_nm`;
       other fields such as intervals are ignored) with optional `name` and
       `range_nm` beside it: the form of a hand-written file.

    None when the file or the key is absent; anything else is a `ValueError`
    naming the file and the key.
    """
    # sensor (JAX) only when a band set is read: the report reads results
    # without it
    from .sensor import BandSet

    if path is None:
        root = Path(results_dir) if results_dir is not None else RESULTS_DIR
        path = root / RECOMMENDATION
    path = Path(path)
    if not path.is_file():
        return None
    try:
        data = json.loads(path.read_text())
    except (ValueError, UnicodeDecodeError) as err:
        raise ValueError(f"{path}: not valid JSON ({err}).") from None
    entry = data.get(key) if isinstance(data, dict) else None
    if entry is None:
        return None
    where = f"{path}: key {key!r}"
    if isinstance(entry, dict) and isinstance(entry.get("band_set"), dict):
        return BandSet.from_dict(entry["band_set"], label=f"{path}:{key}.band_set")
    bands = entry.get("bands") if isinstance(entry, dict) else None
    if isinstance(entry, dict) and "band_set" not in entry and bands:
        if not isinstance(bands, list) or not all(isinstance(b, dict) for b in bands):
            raise ValueError(f"{where}: 'bands' must be a list of band objects.")
        form = {k: entry[k] for k in ("name", "range_nm") if k in entry}
        form["bands"] = [
            {k: v for k, v in b.items() if k in BAND_FIELDS} for b in bands
        ]
        return BandSet.from_dict(form, label=f"{path}:{key}.bands")
    raise ValueError(
        f"{where} has no 'band_set' object (BandSet.to_dict form) and no "
        f"non-empty 'bands' list; re-run the experiment that writes {key!r}."
    )


def bands_record(bands) -> list[dict]:
    """The bands a study ran with, as a results file records them (name,
    centre and FWHM [nm]; a tabulated sensor: names only), so the report can
    tell a study made with other bands than the recommendation's."""
    d = bands.to_dict() if hasattr(bands, "to_dict") else None
    if d is None:
        return [{"name": str(n)} for n in bands.names]
    return [
        {k: b[k] for k in ("name", "centre_nm", "fwhm_nm") if k in b}
        for b in d["bands"]
    ]


def band_digest(bands) -> str:
    """A short fingerprint of a band set's definition (its `to_dict()`
    form, or a tabulated sensor's names and response arrays): equal digests,
    equal responses."""
    h = hashlib.sha256()
    if hasattr(bands, "to_dict"):
        d = {k: v for k, v in bands.to_dict().items() if k != "name"}
        h.update(strict_dumps(d, indent=None).encode())
    else:  # a tabulated reference sensor: its names and response arrays
        import jax  # the tabulated sensors only: results are read without JAX

        h.update(repr(list(bands.names)).encode())
        for leaf in jax.tree_util.tree_leaves(bands):
            if hasattr(leaf, "shape"):
                h.update(np.ascontiguousarray(np.asarray(leaf, float)).tobytes())
    return h.hexdigest()[:16]


def digests_path(records_path: Path) -> Path:
    """The file beside `records_path` that records each band set's digest
    (`band_digest`) the records were computed with: `records.bands.json` for
    `records.jsonl.gz`."""
    records_path = Path(records_path)
    return records_path.with_name(records_path.name.split(".")[0] + ".bands.json")


def recorded_digests(records_path: Path) -> dict:
    """The band digests recorded beside `records_path` ({} when none)."""
    side = digests_path(records_path)
    try:
        return json.loads(side.read_text()) if side.is_file() else {}
    except ValueError as err:
        raise ValueError(f"{side}: not valid JSON ({err}).") from None


DATA_KEY = "lamps and data"
"""The entry of a digests file (`digests_path`) that holds `data_digest`:
what every record depends on besides its bands."""


def data_digest() -> str:
    """A short fingerprint of what every unit's records depend on besides
    its band set: the package data files (`provenance.data_versions`) and
    the lamp library as built (ids, classes, wavelengths and values, with
    its NIR extension). Stored beside records under `DATA_KEY`, so a resume
    after a change of the lamp data recomputes every unit instead of
    pairing new units with old ones."""
    # start-up time: the report and the results index read this module
    # without building the lamp library
    from .datasets.lamps import library

    lib = library()
    h = hashlib.sha256()
    h.update(strict_dumps(data_versions(), indent=None).encode())
    h.update(repr([(r.id, r.level2) for r in lib.records]).encode())
    for a in (lib.wavelength_nm, lib.values):
        h.update(np.ascontiguousarray(np.asarray(a, float)).tobytes())
    return h.hexdigest()[:16]


def changed_band_sets(records_path: Path, digests: dict | None) -> set:
    """Band sets of `digests` (name -> `band_digest`) recorded beside
    `records_path` with another digest: their records are stale. A name
    without a recorded digest is not counted as changed. When `digests`
    and the recorded ones both hold `DATA_KEY` (`data_digest`) and it
    differs, every band set, recorded or asked for, is stale."""
    old = recorded_digests(records_path)
    new = dict(digests or {})
    data = new.pop(DATA_KEY, None)
    if data is not None and old.get(DATA_KEY, data) != data:
        return (set(new) | set(old)) - {DATA_KEY}
    return {b for b, d in new.items() if b in old and old[b] != d}


def record_digests(records_path: Path, digests: dict) -> None:
    """Record `digests` beside `records_path`, keeping other names'."""
    merged = {**recorded_digests(records_path), **digests}
    digests_path(records_path).write_text(strict_dumps(merged, indent=1) + "\n")


README = "README.md"
"""The results index: one linked line per experiment's page."""
SECTIONS = "sections"
"""Folder of the experiments' pages under the results folder: `<name>.md`."""


def _markers(name: str) -> tuple[str, str]:
    return f"<!-- {name}:start -->", f"<!-- {name}:end -->"


def _page_title(text: str, name: str) -> str:
    for line in text.splitlines():
        if line.startswith("#"):
            return line.lstrip("#").strip()
    return name


def update_readme_section(
    name: str, text: str, *, heading: str | None = None,
    results_dir: str | Path | None = None,
) -> Path:
    """Write experiment `name`'s page `results/sections/<name>.md` (`text`)
    and its entry in the index `results/README.md`: a link under the page's
    first heading, between `<!-- name:start -->` and `<!-- name:end -->`.
    Without markers, a hand-written index section starting with the line
    `heading` (up to the next level-2 heading or marker) is replaced; else
    the entry is appended. Pages are written from the experiment's own result
    files, never typed by hand. Returns the page's path."""
    root = Path(results_dir) if results_dir is not None else RESULTS_DIR
    page = root / SECTIONS / f"{name}.md"
    page.parent.mkdir(parents=True, exist_ok=True)
    page.write_text(text.strip() + "\n")
    path = root / README
    old = path.read_text() if path.is_file() else "# Results\n"
    start, end = _markers(name)
    entry = f"- [{_page_title(text, name)}]({SECTIONS}/{name}.md)"
    block = f"{start}\n{entry}\n{end}"
    if start in old and end in old:
        new = old[: old.index(start)] + block + old[old.index(end) + len(end):]
    elif heading is not None and f"\n{heading}" in old:
        i = old.index(f"\n{heading}") + 1
        rest = old[i + len(heading):]
        stops = [j for j in (rest.find("\n## "), rest.find("\n<!--")) if j >= 0]
        j = i + len(heading) + (min(stops) + 1 if stops else len(rest))
        new = old[:i] + block + "\n\n" + old[j:].lstrip("\n")
    else:
        new = old.rstrip("\n") + "\n\n" + block + "\n"
    path.write_text(new)
    return page


def readme_section(name: str, results_dir: str | Path | None = None) -> str:
    """Experiment `name`'s page text (stripped). Raises `FileNotFoundError`
    naming the page when the experiment has not written it."""
    root = Path(results_dir) if results_dir is not None else RESULTS_DIR
    page = root / SECTIONS / f"{name}.md"
    if not page.is_file():
        raise FileNotFoundError(
            f"{page}: no page of experiment {name!r} (its run writes it)."
        )
    return page.read_text().strip()


def readme_text(results_dir: str | Path | None = None) -> str:
    """The index with every entry replaced by its page's text, in index order:
    all results as one text, for checks that read every quoted number. An
    entry whose page is missing keeps its link line."""
    root = Path(results_dir) if results_dir is not None else RESULTS_DIR
    path = root / README
    text = path.read_text() if path.is_file() else ""
    pages = sorted((root / SECTIONS).glob("*.md")) if (root / SECTIONS).is_dir() else []
    for page in pages:
        start, end = _markers(page.stem)
        if start in text and end in text:
            i, j = text.index(start), text.index(end) + len(end)
            body = page.read_text().strip()
            text = text[:i] + f"{start}\n{body}\n{end}" + text[j:]
    return text
