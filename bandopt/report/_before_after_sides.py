"""What one side of a before/after comparison was made with, from its
manifest and result files: git commit, time, lamp library, lamps used and
scene physics (neighbourhood, uplight model). A result whose scene physics is
not recorded is dated against the scene model at its commit."""

import datetime
import json
import re
from pathlib import Path

from ._before_after_files import NOT_RUN, Files, git
from ._before_after_headlines import EXPERIMENTS


NOT_RECORDED_PRE11 = "not recorded (pre-issue-11: uniform / Lambertian)"
"""Scene physics of a result made before the scene model had a neighbourhood
or uplight option."""


def _find_keys(obj, keys, found):
    if isinstance(obj, dict):
        for k, v in obj.items():
            if k in keys:
                found.setdefault(k, []).append(v)
            _find_keys(v, keys, found)
    elif isinstance(obj, list):
        for v in obj:
            _find_keys(v, keys, found)
    return found


PHYSICS_KEYS = ("neighbourhood", "uplight_model", "physics_version", "uplight_ratio")


def _physics(
    recorded: dict, commit: str | None, repo: Path | None, created: str | None = None
) -> dict:
    """Scene physics recorded in a side's manifest and result files (every
    value of `PHYSICS_KEYS` found at any depth). When neither a neighbourhood
    nor an uplight model is recorded: what the scene model at the manifest's
    commit defaults to (`_scene_source`), or `NOT_RECORDED_PRE11` when it has
    no such option.
    When the manifest's commit is not in the repository (a rebased or lost
    branch), the manifest's creation time `created` (ISO 8601) is compared
    with the commit that first gave scene.py its neighbourhood option: a
    result made before that commit existed is `NOT_RECORDED_PRE11`, and the
    text says how that was decided; otherwise the physics is not known."""
    out = {}
    for k in PHYSICS_KEYS:
        vals = []
        for v in recorded.get(k, []):
            if isinstance(v, dict):
                v = v.get("name", json.dumps(v, sort_keys=True))
            if v not in vals:
                vals.append(v)
        if vals:
            out[k] = vals
    ratio = (
        f"; uplight ratio {', '.join(map(str, out['uplight_ratio']))}"
        if "uplight_ratio" in out
        else ""
    )
    if "neighbourhood" in out or "uplight_model" in out:
        out["summary"] = "; ".join(
            f"{k.replace('_', ' ')} {', '.join(map(str, v))}" for k, v in out.items()
        )
        return out
    scene = None
    if commit and repo is not None:
        scene = _scene_source(repo, commit)
    if scene is None:
        text = "not recorded (manifest commit not in this repository)"
        first = _first_physics_commit(repo)
        if created and first and _utc(created) < _utc(first[1]):
            text = (
                f"{NOT_RECORDED_PRE11}, by date: manifest commit {str(commit)[:7]} "
                f"not in this repository, made {created}, before {first[0][:7]} "
                f"({first[1]}) added the neighbourhood option"
            )
    else:
        hood = re.search(r'^DEFAULT_NEIGHBOURHOOD\s*=\s*"([^"]+)"', scene, re.M)
        up = re.search(r'uplight_model:\s*str\s*=\s*"([^"]+)"', scene)
        if hood is None and up is None:
            text = NOT_RECORDED_PRE11
        else:
            text = (
                f"not recorded; scene.py default at {commit[:7]}: neighbourhood "
                f"{hood.group(1) if hood else 'uniform'}, uplight model "
                f"{up.group(1) if up else 'lambertian'}"
            )
    version = (
        f"; physics version {', '.join(map(str, out['physics_version']))}"
        if "physics_version" in out
        else ""
    )
    out["summary"] = text + version + ratio
    return out


def _scene_source(repo: Path, commit: str) -> str | None:
    """The scene model's source at `commit`: `bandopt/scene.py`, or the modules
    of the package `bandopt/scene/` that replaced it, joined; None when the
    commit is not in the repository or has neither."""
    try:
        return git(repo, "show", f"{commit}:bandopt/scene.py")
    except RuntimeError:
        pass
    try:
        names = git(repo, "ls-tree", "--name-only", commit, "bandopt/scene/")
        files = [n for n in names.splitlines() if n.endswith(".py")]
        return "\n".join(git(repo, "show", f"{commit}:{n}") for n in files) or None
    except RuntimeError:
        return None


def _utc(stamp: str) -> datetime.datetime:
    t = datetime.datetime.fromisoformat(stamp.replace("Z", "+00:00"))
    return t if t.tzinfo else t.replace(tzinfo=datetime.UTC)


def _first_physics_commit(repo: Path | None) -> tuple[str, str] | None:
    """(hash, committer date) of the first commit whose bandopt/scene.py has
    `DEFAULT_NEIGHBOURHOOD` (the scene physics options); None if none has."""
    if repo is None:
        return None
    try:
        out = git(
            repo,
            "log",
            "-S",
            "DEFAULT_NEIGHBOURHOOD",
            "--reverse",
            "--format=%H %cI",
            "--",
            "bandopt/scene.py",
        )
    except RuntimeError:
        return None
    lines = out.split()
    return (lines[0], lines[1]) if len(lines) >= 2 else None


def _lamp_library(man: dict) -> dict:
    lib = man.get("lamp_library")
    lamp_data = sorted(k for k in man.get("data_versions", {}) if k.startswith("lamps"))
    if not isinstance(lib, dict):
        return {
            "summary": f"not recorded (lamp data: {', '.join(lamp_data) or '?'})",
            "lamp_data": lamp_data,
        }
    sets = lib.get("source_sets")
    out = {"spectra": lib.get("spectra"), "source_sets": sets, "lamp_data": lamp_data}
    if isinstance(sets, dict):
        measured = sum(v for k, v in sets.items() if k != "planck")
        out["lamps"] = measured
        out["summary"] = f"{measured} lamps (+{sets.get('planck', 0)} Planck spectra)"
    else:
        out["summary"] = f"{lib.get('spectra')} spectra (sets not recorded)"
    return out


def side_info(f: Files, repo: Path | None) -> dict | None:
    """Manifest facts of one side of one experiment; None without a manifest."""
    raw = f.raw("manifest.json")
    if raw is None:
        return None
    man = f.load("manifest.json")
    recorded = _find_keys(man, PHYSICS_KEYS, {})
    for name in EXPERIMENTS[f.experiment]["files"]:
        if name.endswith(".json") and f.raw(name) is not None:
            _find_keys(f.load(name), PHYSICS_KEYS, recorded)
    commit = man.get("git_commit")
    physics = _physics(recorded, commit, repo, man.get("created_utc"))
    if f.experiment == "spatial" and f.raw("summary.json") is not None:
        # the renderer states its transmittance and adjacency model in prose
        summary = f.load("summary.json")
        notes = [summary.get("atmosphere")] + [
            a for a in summary.get("assumptions", []) if "adjacency" in str(a)
        ]
        notes = [str(n) for n in notes if n]
        if notes:
            physics["renderer"] = notes
            physics["summary"] += f"; spatial renderer: {'; '.join(notes)}"
    info = {
        "git_commit": commit,
        "git_dirty": man.get("git_dirty"),
        "created_utc": man.get("created_utc"),
        "lamp_library": _lamp_library(man),
        "physics": physics,
    }
    spec = EXPERIMENTS[f.experiment]["lamps_used"]
    if spec is None:
        info["lamps_used"] = "not recorded"
    else:
        name, fn, what = spec
        info["lamps_used"] = fn(f) if f.raw(name) is not None else NOT_RUN
        info["lamps_used_from"] = what
    return info
