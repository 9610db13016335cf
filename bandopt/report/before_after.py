"""Before/after numbers: a fixed set of headline numbers of every downstream
experiment at a git revision ("before") and in the working tree ("after"),
side by side, so that a change of the physics shows what it moved and which
results were not re-run.

`run(argv)` is the command line (`python -m experiments.before_after
--before REV [--after REV] [--results DIR] [--experiments ...]
[--no-write]`, `make before-after`).

"before" files are read with `git show REV:results/...` (no checkout);
"after" files from the working tree (or `--after REV`). For each experiment
folder of `EXPERIMENTS` the headline numbers come from named keys of its
result files (`HEADLINES` says which): a key missing from a file that exists
is an error naming the file and the key; a file missing on one side shows
"not run". An experiment whose files are byte-identical on both sides is
marked "NOT re-run". Per side and experiment the manifest gives the git
commit, time, lamp library and scene physics (neighbourhood, uplight model)
where recorded.

Writes `results/before_after.json` (strict JSON), its provenance manifest
`results/before_after_manifest/manifest.json`, and the section between
`<!-- before-after:start -->` and `<!-- before-after:end -->` of
`results/README.md`.
"""

import argparse
import math
from pathlib import Path

from ..provenance import check_clean_tree, write_manifest
from ..results import update_readme_section
from ..strict_json import strict_dumps
from ._before_after_files import (
    ABSENT as ABSENT,
    NOT_RUN as NOT_RUN,
    Files,
    GitSource as GitSource,
    TreeSource as TreeSource,
    git,
)
from ._before_after_headlines import EXPERIMENTS as EXPERIMENTS, HEADLINES
from ._before_after_sides import NOT_RECORDED_PRE11 as NOT_RECORDED_PRE11, side_info


SECTION = "before-after"
"""Name of the section of `results/README.md`."""


# ---------------------------------------------------------------------------
# values


def _clean(v):
    """Strict-JSON form of a value: NaN/inf become the string "undefined (nan)"."""
    if isinstance(v, float) and not math.isfinite(v):
        return f"undefined ({v})"
    if isinstance(v, list):
        return [_clean(x) for x in v]
    return v


def _is_num(v) -> bool:
    return (
        isinstance(v, int | float)
        and not isinstance(v, bool)
        and math.isfinite(float(v))
    )


def change(before, after) -> dict:
    """`change`: after - before for numbers (element-wise for lists of equal
    length), "same" / "changed" otherwise; `relative`: change / `abs(before)` where
    both are numbers and before is not 0; None where it does not apply."""
    if before in (NOT_RUN, ABSENT) or after in (NOT_RUN, ABSENT):
        return {"change": None, "relative": None}
    if _is_num(before) and _is_num(after):
        d = after - before
        return {"change": d, "relative": d / abs(before) if before else None}
    if (
        isinstance(before, list)
        and isinstance(after, list)
        and any(_is_num(x) for x in before + after)
    ):
        if len(before) != len(after):
            return {
                "change": f"changed ({len(before)} -> {len(after)} values)",
                "relative": None,
            }
        return {
            "change": [
                a - b if _is_num(a) and _is_num(b) else None
                for b, a in zip(before, after, strict=True)
            ],
            "relative": None,
        }
    return {"change": "same" if before == after else "changed", "relative": None}


# ---------------------------------------------------------------------------
# the comparison


def extract(source, experiment: str) -> dict[str, tuple[str, object, str]] | None:
    """Headlines {key: (quantity, value, file)} of one side; None when none of
    the experiment's headline files exists (the experiment was not run)."""
    f = Files(source, experiment)
    out: dict[str, tuple[str, object, str]] = {}
    present = False
    for name, fn in EXPERIMENTS[experiment]["headlines"]:
        if f.raw(name) is None:
            continue
        present = True
        for key, label, value in fn(f):
            if key in out:
                raise ValueError(f"{f.where(name)}: headline {key!r} twice.")
            out[key] = (label, _clean(value), name)
    return out if present else None


def _file_state(before, after, experiment) -> dict:
    names = ("manifest.json", *EXPERIMENTS[experiment]["files"])
    state = {}
    for name in names:
        b = before.read(f"{experiment}/{name}")
        a = after.read(f"{experiment}/{name}")
        state[name] = (
            "not run"
            if a is None and b is None
            else "only after"
            if b is None
            else "only before"
            if a is None
            else "identical"
            if a == b
            else "differs"
        )
    return state


def _value(headlines, source, experiment, key, name):
    """One side's value of `key` (from file `name`): "not run" when the file
    is absent on this side, "absent" when the file lacks this quantity."""
    if headlines is not None and key in headlines:
        return headlines[key][1]
    if headlines is None or source.read(f"{experiment}/{name}") is None:
        return NOT_RUN
    return ABSENT


def compare(before, after, experiments=None) -> dict:
    """The before/after record of every experiment (strict-JSON-ready)."""
    repo = getattr(before, "repo", None) or getattr(after, "repo", None)
    if repo is None:
        try:
            repo = Path(git(Path.cwd(), "rev-parse", "--show-toplevel"))
        except RuntimeError:
            repo = None
    out = {}
    for exp in experiments or EXPERIMENTS:
        if exp not in EXPERIMENTS:
            raise ValueError(
                f"unknown experiment {exp!r}; expected one of {list(EXPERIMENTS)}"
            )
        hb, ha = extract(before, exp), extract(after, exp)
        keys = list(hb or {}) + [k for k in (ha or {}) if k not in (hb or {})]
        rows = []
        for k in keys:
            label, _, name = (hb or {}).get(k) or ha[k]
            vb = _value(hb, before, exp, k, name)
            va = _value(ha, after, exp, k, name)
            rows.append(
                {
                    "key": k,
                    "quantity": label,
                    "file": name,
                    "before": vb,
                    "after": va,
                    **change(vb, va),
                }
            )
        files = _file_state(before, after, exp)
        present = [s for s in files.values() if s != "not run"]
        out[exp] = {
            "files": files,
            "re_run": None
            if not present or hb is None or ha is None
            else any(s != "identical" for s in present),
            "before": {
                "run": hb is not None,
                **(side_info(Files(before, exp), repo) or {}),
            },
            "after": {
                "run": ha is not None,
                **(side_info(Files(after, exp), repo) or {}),
            },
            "headlines": rows,
        }
    return {
        "before": {"source": before.label, "commit": before.commit},
        "after": {"source": after.label, "commit": after.commit},
        "rules": {
            "change": "after - before (element-wise for lists); relative = change / "
            "|before|",
            "not_run": f"{NOT_RUN!r}: the result file is absent on that side",
            "absent": f"{ABSENT!r}: the other side's file has this quantity, this "
            "side's does not",
            "re_run": "false (NOT re-run) when every result file and the manifest "
            "are byte-identical on both sides",
            "headline_files": HEADLINES,
        },
        "experiments": out,
    }


# ---------------------------------------------------------------------------
# README section


def _fmt(v) -> str:
    if isinstance(v, bool):
        return "yes" if v else "no"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        return f"{v:.4g}"
    if isinstance(v, list):
        return ", ".join(_fmt(x) for x in v)
    return str(v)


def _fmt_change(row) -> str:
    c, rel = row["change"], row["relative"]
    if c is None:
        return "n/a"
    if isinstance(c, str):
        return c
    if isinstance(c, list):
        return ", ".join("n/a" if x is None else f"{x:+.3g}" if x else "0" for x in c)
    if c == 0:
        return "0"
    text = f"{c:+d}" if isinstance(c, int) else f"{c:+.3g}"
    return text + (f" ({100 * rel:+.1f} %)" if rel is not None else "")


def _side_line(name: str, side: dict) -> str:
    if "git_commit" not in side:
        return f"{name}: {'no manifest' if side['run'] else NOT_RUN}"
    commit = (side["git_commit"] or "?")[:7] + (
        " (dirty tree)" if side.get("git_dirty") else ""
    )
    return (
        f"{name}: commit {commit}, {side['created_utc']}; library "
        f"{side['lamp_library']['summary']}; lamps used {side['lamps_used']}"
        + (f" ({side['lamps_used_from']})" if "lamps_used_from" in side else "")
        + "; "
        f"physics: {side['physics']['summary']}"
    )


def _cell(text: str) -> str:
    return text.replace("|", "\\|")


def _mark(e: dict) -> str:
    """The heading mark of one experiment: not run on a side, or NOT re-run."""
    b, a = e["before"]["run"], e["after"]["run"]
    if not (b or a):
        return " - **not run**"
    if not (b and a):
        return f" - **not run {'before' if a else 'after'}**"
    return " - **NOT re-run**" if e["re_run"] is False else ""


def readme_text(record: dict) -> str:
    """The results/README.md section, every number read from `record`."""
    b, a = record["before"], record["after"]
    lines = [
        "## Before / after issue 11 (`results/before_after.json`, `make before-after`)",
        "",
        f"Headline numbers of every downstream experiment before ({b['source']}) "
        f"and after ({a['source']}) the issue-11 physics. Change = after - before "
        '(relative change in brackets; element-wise for lists). "not run": the '
        "result file is absent on that side. **NOT re-run**: the after files are "
        "byte-identical to the before files.",
    ]
    stale = [x for x, e in record["experiments"].items() if e["re_run"] is False]
    if stale:
        lines += ["", f"**NOT re-run (after = before): {', '.join(stale)}.**"]
    for exp, e in record["experiments"].items():
        mark = _mark(e)
        lines += [
            "",
            f"### {exp} (`results/{exp}/`){mark}",
            "",
            _side_line("Before", e["before"]) + "  ",
            _side_line("After", e["after"]),
            "",
            "| quantity | before | after | change |",
            "|---|---|---|---|",
        ]
        lines += [
            f"| {_cell(r['quantity'])} | {_cell(_fmt(r['before']))} | "
            f"{_cell(_fmt(r['after']))} | {_cell(_fmt_change(r))} |"
            for r in e["headlines"]
        ] or ["| (no result files on either side) | not run | not run | n/a |"]
    lines += [
        "",
        "Generated from the result files by `python -m experiments.before_after "
        f"--before {b['commit'][:7] if b['commit'] else '?'}"
        + (f" --after {a['commit'][:7]}" if a["commit"] else "")
        + "`.",
    ]
    return "\n".join(lines)


def write(record: dict, results: str | Path = "results", *, config=None) -> Path:
    """`before_after.json`, its manifest and the README section in `results`
    (nothing written when the manifest would be refused: `check_clean_tree`)."""
    root = Path(results)
    check_clean_tree(root / "before_after_manifest")
    path = root / "before_after.json"
    path.write_text(strict_dumps(record, indent=2) + "\n")
    write_manifest(root / "before_after_manifest", config=config or {})
    update_readme_section(SECTION, readme_text(record), results_dir=root)
    return path


def run(argv=None) -> int:
    """The command line `argv`: compare, then write the outputs (or, with
    `--no-write`, print the README section); returns the exit status."""
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument(
        "--before",
        required=True,
        help="git revision of the 'before' results (e.g. 0e7885f)",
    )
    p.add_argument(
        "--after",
        default=None,
        help="git revision of the 'after' results (default: the working tree)",
    )
    p.add_argument("--results", default="results", help="results folder")
    p.add_argument(
        "--experiments", nargs="+", default=list(EXPERIMENTS), choices=list(EXPERIMENTS)
    )
    p.add_argument(
        "--no-write",
        action="store_true",
        help="print the README section only; write nothing",
    )
    args = p.parse_args(argv)
    before = GitSource(args.before, args.results)
    after = (
        TreeSource(args.results)
        if args.after is None
        else GitSource(args.after, args.results)
    )
    record = compare(before, after, args.experiments)
    if args.no_write:
        print(readme_text(record))
        return 0
    path = write(
        record,
        args.results,
        config={
            "before": args.before,
            "before_commit": before.commit,
            "after": args.after or "working tree",
            "after_commit": after.commit,
            "experiments": args.experiments,
        },
    )
    print(f"wrote {path}")
    return 0
