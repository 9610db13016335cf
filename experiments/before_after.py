"""Before/after numbers of the issue-11 re-runs: a fixed set of headline numbers
of every downstream experiment at a git revision ("before") and in the working
tree ("after"), side by side.

    python -m experiments.before_after --before 0e7885f [--after REV]
                                       [--results DIR] [--no-write]
    make before-after                  (BEFORE=0e7885f unless given)

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
import csv
import datetime
import io
import json
import math
import re
import subprocess
import sys
from pathlib import Path


NOT_RUN = "not run"
"""Value of every quantity of a side whose result file is absent."""
ABSENT = "absent"
"""Value of a quantity the other side has but this side's file does not
(e.g. a band that only one design has)."""
NOT_RECORDED_PRE11 = "not recorded (pre-issue-11: uniform / Lambertian)"
SECTION = "before-after"


# ---------------------------------------------------------------------------
# sources: where one side's files come from


class GitSource:
    """Result files at a git revision, read with `git show` (no checkout)."""

    def __init__(self, rev: str, results: str | Path = "results"):
        results = Path(results).resolve()
        self.repo = Path(_git(results, "rev-parse", "--show-toplevel"))
        self.prefix = results.relative_to(self.repo).as_posix()
        try:
            self.commit = _git(self.repo, "rev-parse", "--verify", f"{rev}^{{commit}}")
        except RuntimeError:
            raise ValueError(
                f"--before/--after {rev!r}: not a git revision of {self.repo}."
            ) from None
        short = self.commit[:7]
        self.label = f"git {rev}" + ("" if short.startswith(rev) else f" ({short})")
        listing = _git(
            self.repo, "ls-tree", "-r", "--name-only", self.commit, "--",
            self.prefix + "/",
        )
        self._files = set(listing.splitlines())

    def read(self, rel: str) -> bytes | None:
        """Bytes of `results/<rel>` at the revision, None if it is not there."""
        path = f"{self.prefix}/{rel}"
        if path not in self._files:
            return None
        return subprocess.run(
            ["git", "show", f"{self.commit}:{path}"],
            cwd=self.repo, capture_output=True, check=True,
        ).stdout


class TreeSource:
    """Result files in the working tree."""

    def __init__(self, results: str | Path = "results"):
        self.root = Path(results)
        self.commit = None
        try:
            head = _git(self.root, "rev-parse", "--short", "HEAD")
        except (RuntimeError, OSError):
            head = None
        self.label = f"working tree ({self.root}" + (
            f", checkout at {head})" if head else ")"
        )

    def read(self, rel: str) -> bytes | None:
        path = self.root / rel
        return path.read_bytes() if path.is_file() else None


def _git(cwd: Path, *args: str) -> str:
    out = subprocess.run(
        ["git", *args], cwd=cwd, capture_output=True, text=True, check=False
    )
    if out.returncode != 0:
        raise RuntimeError(f"git {' '.join(args)}: {out.stderr.strip()}")
    return out.stdout.strip()


# ---------------------------------------------------------------------------
# strict access to result files


class Files:
    """One side's files of one experiment; `get` fails naming file and key."""

    def __init__(self, source, experiment: str):
        self.source, self.experiment = source, experiment
        self._cache: dict[str, object] = {}

    def where(self, name: str) -> str:
        return f"{self.source.label}: results/{self.experiment}/{name}"

    def raw(self, name: str) -> bytes | None:
        return self.source.read(f"{self.experiment}/{name}")

    def load(self, name: str):
        if name not in self._cache:
            data = self.raw(name)
            if data is None:
                raise FileNotFoundError(self.where(name))
            text = data.decode()
            if name.endswith(".csv"):
                self._cache[name] = list(csv.DictReader(io.StringIO(text)))
            else:
                try:
                    self._cache[name] = json.loads(text)
                except ValueError as err:
                    raise ValueError(
                        f"{self.where(name)}: not valid JSON ({err})"
                    ) from err
        return self._cache[name]

    def get(self, name: str, path: str, obj=None):
        """`path` ("a/b/0/c") inside file `name` (or inside `obj`, a part of it)."""
        node = self.load(name) if obj is None else obj
        for part in path.split("/"):
            try:
                node = node[int(part)] if isinstance(node, list) else node[part]
            except (KeyError, IndexError, TypeError, ValueError):
                raise ValueError(
                    f"{self.where(name)}: missing key {path!r} (at {part!r}); "
                    "the headline extractor of experiments.before_after needs it."
                ) from None
        return node

    def row(self, name: str, rows, **match):
        """The one row of `rows` (a list of dicts in file `name`) matching `match`."""
        found = [r for r in rows if all(r.get(k) == v for k, v in match.items())]
        if len(found) != 1:
            raise ValueError(
                f"{self.where(name)}: expected one row with {match}, found "
                f"{len(found)}."
            )
        return found[0]


# ---------------------------------------------------------------------------
# headline extractors: (key, quantity label, value) per experiment and file

Headline = tuple[str, str, object]
MAE_UNITS = {"LER": "lm/W", "G": "1", "CCT": "K"}


def _search_compare(f: Files) -> list[Headline]:
    n = "compare.json"
    rec = f.get(n, "pareto/recommended")
    design = f.get(n, f"designs/{rec}")
    out = [
        ("chosen_n", "chosen number of free bands (+ pan)",
         f.get(n, "band_count/chosen_n")),
        ("best_n", "band count with the lowest normalised MAE",
         f.get(n, "band_count/best_n")),
        ("recommended", "recommended design", rec),
        ("norm_mae", "recommended: normalised MAE [1]",
         f.get(n, "norm_mae_mean", design)),
    ]
    out += [
        (f"mae_{m}", f"recommended: {m} MAE [{u}]", f.get(n, f"mae_mean/{m}", design))
        for m, u in MAE_UNITS.items()
    ]
    out.append(("f1", "recommended: level-2 macro F1 [1]",
                f.get(n, "f1_mean", design)))
    for ref in ("sdgsat-1", "nightsat"):
        out += [
            (f"reduction_{ref}_{m}", f"{m} MAE reduction vs {ref} [1]",
             f.get(n, f"reductions/{ref}/recommended/{m}/reduction"))
            for m in MAE_UNITS
        ]
    return out


def _search_bands(f: Files) -> list[Headline]:
    n = "recommended_bands.json"
    bands = f.get(n, "bands")
    return [
        ("band_names", "recommended bands",
         [f.get(n, "name", b) for b in bands]),
        ("centre_nm", "band centres [nm]", [f.get(n, "centre_nm", b) for b in bands]),
        ("fwhm_nm", "band FWHM [nm]", [f.get(n, "fwhm_nm", b) for b in bands]),
    ]


def _classify_summary(f: Files) -> list[Headline]:
    n = "summary.json"
    chosen = f.get(n, "chosen_n_bands")
    out = [
        ("chosen_n", "chosen number of bands", chosen),
        ("nested_l2", "chosen n: nested level-2 macro F1 [1]",
         f.get(n, "recommended/bands/level2_macro_f1_nested")),
    ]
    for noise in ("noisy", "noise_free"):
        out += [
            (f"rec_{noise}_{lvl}",
             f"recommended set, {noise.replace('_', '-')}: {lvl} macro F1 [1]",
             f.get(n, f"recommended/{noise}/{lvl}/macro_f1"))
            for lvl in ("level1", "level2")
        ]
    for r in f.get(n, "band_count"):
        if f.get(n, "method", r) == "nlopt":
            k = f.get(n, "n_bands", r)
            out += [
                (f"nested_{k}_{lvl}", f"{k} bands (nested, nlopt): {lvl} macro F1 [1]",
                 f.get(n, f"{lvl}_macro_f1", r))
                for lvl in ("level1", "level2")
            ]
    refs = f.get(n, "reference_sensors")
    names = ["sdgsat-1", "nightsat", "viirs-dnb"]
    names += [
        r["sensor"] for r in refs
        if str(r.get("sensor", "")).startswith("spectral") and r.get("noise")
    ]
    for s in names:
        r = f.row(n, refs, sensor=s, noise=True)
        out += [
            (f"ref_{s}_{lvl}", f"{s} (photon noise): {lvl} macro F1 [1]",
             f.get(n, f"{lvl}_macro_f1", r))
            for lvl in ("level1", "level2")
        ]
    goal = f.get(n, f"goal/{chosen}")
    out += [
        ("goal_margin", "chosen n: level-2 F1 margin over best reference [1]",
         f.get(n, "margin", goal)),
        ("goal_met", "goal (>= 10 points above best reference) met",
         f.get(n, "met", goal)),
    ]
    return out


RADIOMETRY_SETS = ("sdgsat-1", "nightsat", "viirs-dnb")
RADIANCE = "W m-2 sr-1 nm-1"


def _radiometry_summary(f: Files) -> list[Headline]:
    n = "summary.json"
    return [
        ("linear_bits", "recommended linear bit depth",
         f.get(n, "bit_depth/recommended_linear_bits")),
        ("companded_bits", "recommended companded bit depth",
         f.get(n, "bit_depth/recommended_companded_bits")),
        ("ner_bits", "linear bits for a step <= NER at the limit",
         f.get(n, "bits_linear_step_le_ner_at_limit")),
    ] + [
        (f"clip_{m}", f"noise, clipped, unquantised: {m} MAE [{u}]",
         _num(f.get(n, f"{m}_mae", f.row(n, f.get(n, "bit_depth_table"),
                                           scheme="clip"))))
        for m, u in MAE_UNITS.items()
    ] + [
        ("clip_f1", "noise, clipped, unquantised: level-2 macro F1 [1]",
         f.get(n, "macro_f1", f.row(n, f.get(n, "bit_depth_table"), scheme="clip"))),
    ]


def _radiometry_limits(f: Files) -> list[Headline]:
    n = "limits.csv"
    rows = f.load(n)
    out = []
    for r in (r for r in rows if r.get("band_set") == "ours"):
        b = f.get(n, "band", r)
        out += [
            (f"ours_{b}_limit", f"ours {b}: detection limit [{RADIANCE}]",
             _num(f.get(n, "detection_limit_w_m2_sr_nm", r))),
            (f"ours_{b}_saturation", f"ours {b}: saturation [{RADIANCE}]",
             _num(f.get(n, "saturation_w_m2_sr_nm", r))),
            (f"ours_{b}_bits", f"ours {b}: linear bits for a step <= NER",
             int(_num(f.get(n, "bits_linear_step_le_ner_at_limit", r)))),
        ]
    if not out:
        raise ValueError(f"{f.where(n)}: no rows of band set 'ours'.")
    for s in RADIOMETRY_SETS:
        sel = [r for r in rows if r.get("band_set") == s]
        if not sel:
            raise ValueError(f"{f.where(n)}: no rows of band set {s!r}.")
        lim = [_num(f.get(n, "detection_limit_w_m2_sr_nm", r)) for r in sel]
        sat = [_num(f.get(n, "saturation_w_m2_sr_nm", r)) for r in sel]
        bits = [int(_num(f.get(n, "bits_linear_step_le_ner_at_limit", r)))
                for r in sel]
        out += [
            (f"{s}_limit", f"{s}: detection limit, min-max over bands [{RADIANCE}]",
             [min(lim), max(lim)]),
            (f"{s}_saturation", f"{s}: saturation, min-max over bands [{RADIANCE}]",
             [min(sat), max(sat)]),
            (f"{s}_bits", f"{s}: linear bits for a step <= NER, max over bands",
             max(bits)),
        ]
    return out


def _spatial_summary(f: Files) -> list[Headline]:
    from bandopt.report import spatial_median

    n = "summary.json"
    per = f.get(n, "gsd_needed_m")
    scenes = {k: f.get(n, "coarsest_gsd_m", v) for k, v in per.items()}
    out = [
        ("median_gsd", "median coarsest working GSD, rows and arrangements [m]",
         _or_none(spatial_median(f.load(n)))),
        ("single_gsd", "single lamp: coarsest working GSD [m]",
         _or_none(f.get(n, "gsd_needed_m/single/coarsest_gsd_m"))),
    ]
    out += [
        (f"arrangement_{a}", f"{a}: coarsest working GSD [m]",
         _or_none(f.get(n, f"gsd_needed_m/{a}/coarsest_gsd_m")))
        for a in f.get(n, "config/arrangements")
    ]
    out += [
        ("scenes", "scenes", len(scenes)),
        ("never", "scenes detected at no GSD",
         sum(v is None for v in scenes.values())),
    ]
    return out


def _spatial_overlap(f: Files) -> list[Headline]:
    n = "overlap.json"
    rows = f.get(n, "rows")
    return [
        ("overlap_gsd", "overlapping lamp types: GSDs [m]",
         [f.get(n, "gsd_m", r) for r in rows]),
    ] + [
        (f"overlap_{k}", f"overlapping lamp types: {label} by GSD [1]",
         [f.get(n, k, r) for r in rows])
        for k, label in (("macro_f1", "macro F1"), ("f1_pure", "F1 one-type pixels"),
                         ("f1_mixed", "F1 mixed pixels"))
    ]


def _estimate_summary(f: Files) -> list[Headline]:
    n = "summary.json"
    out = []
    for r in f.load(n):
        key = "/".join(
            str(f.get(n, k, r)) for k in ("band_set", "estimator", "surface")
        )
        out.append((
            f"mae_{key}",
            f"{key.replace('/', ', ')}: class-balanced MAE LER [lm/W], G [1], CCT [K]",
            [f.get(n, m, r) for m in MAE_UNITS],
        ))
    if not out:
        raise ValueError(f"{f.where(n)}: no rows.")
    return out


def _estimate_coverage(f: Files) -> list[Headline]:
    n = "coverage.json"
    out = []
    for part, label in (("held_out_lamps", "held-out lamps"),
                        ("unseen_types", "unseen types")):
        for key, cov in f.get(n, part).items():
            out.append((
                f"coverage_{part}_{key}",
                f"90 % interval coverage, {label}, {key}: LER, G, CCT [1]",
                [f.get(n, f"{m}_coverage", cov) for m in MAE_UNITS],
            ))
    return out


def _noise_aware(f: Files) -> list[Headline]:
    n = "noise_aware.json"
    out = []
    for r in f.get(n, "rows"):
        lvl = f.get(n, "level", r)
        bands = f.get(n, "bands", r)
        out += [
            (f"{lvl}_cv_loss", f"{lvl}: CV loss [1]", f.get(n, "cv_loss", r)),
            (f"{lvl}_centre_nm", f"{lvl}: band centres [nm]", [b[0] for b in bands]),
            (f"{lvl}_fwhm_nm", f"{lvl}: band FWHM [nm]", [b[1] for b in bands]),
        ]
    return out


# ---------------------------------------------------------------------------
# lamps used (experiment-specific: what the run's files record)


def _lamps_search(f):
    return f.get("compare.json", "context/n_lamps")


def _lamps_classify(f):
    return len(f.load("lamp_accuracy.csv"))


def _lamps_radiometry(f):
    return f.get("summary.json", "scenario_shape/0")


def _lamps_spatial(f):
    return f"1 ({f.get('summary.json', 'config/lamp')})"


def _lamps_estimate(f):
    return max(f.get("summary.json", "lamps_per_partition", r)
               for r in f.load("summary.json"))


EXPERIMENTS: dict[str, dict] = {
    "search": {
        "files": ("compare.json", "recommended_bands.json"),
        "headlines": (("compare.json", _search_compare),
                      ("recommended_bands.json", _search_bands)),
        "lamps_used": ("compare.json", _lamps_search,
                       "scored lamps, compare.json context/n_lamps"),
    },
    "classify": {
        "files": ("summary.json", "lamp_accuracy.csv"),
        "headlines": (("summary.json", _classify_summary),),
        "lamps_used": ("lamp_accuracy.csv", _lamps_classify,
                       "scored lamps, rows of lamp_accuracy.csv"),
    },
    "radiometry": {
        "files": ("summary.json", "limits.csv"),
        "headlines": (("summary.json", _radiometry_summary),
                      ("limits.csv", _radiometry_limits)),
        "lamps_used": ("summary.json", _lamps_radiometry,
                       "lamps, summary.json scenario_shape/0"),
    },
    "spatial": {
        "files": ("summary.json", "overlap.json"),
        "headlines": (("summary.json", _spatial_summary),
                      ("overlap.json", _spatial_overlap)),
        "lamps_used": ("summary.json", _lamps_spatial, "summary.json config/lamp"),
    },
    "estimate": {
        "files": ("summary.json", "coverage.json"),
        "headlines": (("summary.json", _estimate_summary),
                      ("coverage.json", _estimate_coverage)),
        "lamps_used": ("summary.json", _lamps_estimate,
                       "scored lamps per partition, summary.json"),
    },
    "noise_aware": {
        "files": ("noise_aware.json",),
        "headlines": (("noise_aware.json", _noise_aware),),
        "lamps_used": None,
    },
}
"""Per experiment folder: its key result files (besides manifest.json), the
headline extractor of each file, and where the number of lamps used is read."""

HEADLINES = {
    exp: [name for name, _ in spec["headlines"]] for exp, spec in EXPERIMENTS.items()
}


# ---------------------------------------------------------------------------
# values


def _num(v) -> float:
    """A CSV cell (or JSON number) as a float."""
    return float(v)


def _or_none(v):
    """A GSD that is None means "no GSD works"."""
    return "none works" if v is None else v


def _clean(v):
    """Strict-JSON form of a value: NaN/inf become the string "undefined (nan)"."""
    if isinstance(v, float) and not math.isfinite(v):
        return f"undefined ({v})"
    if isinstance(v, list):
        return [_clean(x) for x in v]
    return v


def _is_num(v) -> bool:
    return (
        isinstance(v, int | float) and not isinstance(v, bool)
        and math.isfinite(float(v))
    )


def change(before, after) -> dict:
    """`change`: after - before for numbers (element-wise for lists of equal
    length), "same" / "changed" otherwise; `relative`: change / |before| where
    both are numbers and before is not 0; None where it does not apply."""
    if before in (NOT_RUN, ABSENT) or after in (NOT_RUN, ABSENT):
        return {"change": None, "relative": None}
    if _is_num(before) and _is_num(after):
        d = after - before
        return {"change": d, "relative": d / abs(before) if before else None}
    if isinstance(before, list) and isinstance(after, list) and any(
        _is_num(x) for x in before + after
    ):
        if len(before) != len(after):
            return {"change": f"changed ({len(before)} -> {len(after)} values)",
                    "relative": None}
        return {
            "change": [a - b if _is_num(a) and _is_num(b) else None
                       for b, a in zip(before, after, strict=True)],
            "relative": None,
        }
    return {"change": "same" if before == after else "changed", "relative": None}


# ---------------------------------------------------------------------------
# manifests: commit, time, lamps, scene physics


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
    result made before that commit existed is pre-issue-11, and the text says
    how that was decided; otherwise the physics is not known."""
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
        if "uplight_ratio" in out else ""
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
        if "physics_version" in out else ""
    )
    out["summary"] = text + version + ratio
    return out


def _scene_source(repo: Path, commit: str) -> str | None:
    """The scene model's source at `commit`: `bandopt/scene.py`, or the modules
    of the package `bandopt/scene/` that replaced it, joined; None when the
    commit is not in the repository or has neither."""
    try:
        return _git(repo, "show", f"{commit}:bandopt/scene.py")
    except RuntimeError:
        pass
    try:
        names = _git(repo, "ls-tree", "--name-only", commit, "bandopt/scene/")
        files = [n for n in names.splitlines() if n.endswith(".py")]
        return "\n".join(_git(repo, "show", f"{commit}:{n}") for n in files) or None
    except RuntimeError:
        return None


def _utc(stamp: str) -> datetime.datetime:
    t = datetime.datetime.fromisoformat(stamp.replace("Z", "+00:00"))
    return t if t.tzinfo else t.replace(tzinfo=datetime.UTC)


def _first_physics_commit(repo: Path | None) -> tuple[str, str] | None:
    """(hash, committer date) of the first commit whose bandopt/scene.py has
    `DEFAULT_NEIGHBOURHOOD` (issue 11's scene physics); None if none has."""
    if repo is None:
        return None
    try:
        out = _git(
            repo, "log", "-S", "DEFAULT_NEIGHBOURHOOD", "--reverse",
            "--format=%H %cI", "--", "bandopt/scene.py",
        )
    except RuntimeError:
        return None
    lines = out.split()
    return (lines[0], lines[1]) if len(lines) >= 2 else None


def _lamp_library(man: dict) -> dict:
    lib = man.get("lamp_library")
    lamp_data = sorted(k for k in man.get("data_versions", {}) if k.startswith("lamps"))
    if not isinstance(lib, dict):
        return {"summary": f"not recorded (lamp data: {', '.join(lamp_data) or '?'})",
                "lamp_data": lamp_data}
    sets = lib.get("source_sets")
    out = {"spectra": lib.get("spectra"), "source_sets": sets, "lamp_data": lamp_data}
    if isinstance(sets, dict):
        measured = sum(v for k, v in sets.items() if k != "planck")
        out["lamps"] = measured
        out["summary"] = (
            f"{measured} lamps (+{sets.get('planck', 0)} Planck spectra)"
        )
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
            "not run" if a is None and b is None
            else "only after" if b is None
            else "only before" if a is None
            else "identical" if a == b
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
            repo = Path(_git(Path.cwd(), "rev-parse", "--show-toplevel"))
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
            rows.append({"key": k, "quantity": label, "file": name,
                         "before": vb, "after": va, **change(vb, va)})
        files = _file_state(before, after, exp)
        present = [s for s in files.values() if s != "not run"]
        out[exp] = {
            "files": files,
            "re_run": None if not present or hb is None or ha is None
            else any(s != "identical" for s in present),
            "before": {"run": hb is not None,
                       **(side_info(Files(before, exp), repo) or {})},
            "after": {"run": ha is not None,
                      **(side_info(Files(after, exp), repo) or {})},
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
        return ", ".join(
            "n/a" if x is None else f"{x:+.3g}" if x else "0" for x in c
        )
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
        "## Before / after issue 11 (`results/before_after.json`, "
        "`make before-after`)",
        "",
        f"Headline numbers of every downstream experiment before ({b['source']}) "
        f"and after ({a['source']}) the issue-11 physics. Change = after - before "
        "(relative change in brackets; element-wise for lists). \"not run\": the "
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
        + (f" --after {a['commit'][:7]}" if a["commit"] else "") + "`.",
    ]
    return "\n".join(lines)


def write(record: dict, results: str | Path = "results", *, config=None) -> Path:
    """`before_after.json`, its manifest and the README section in `results`."""
    from bandopt.provenance import write_manifest
    from bandopt.results import update_readme_section

    root = Path(results)
    path = root / "before_after.json"
    path.write_text(json.dumps(record, indent=2, allow_nan=False) + "\n")
    write_manifest(root / "before_after_manifest", config=config or {})
    update_readme_section(SECTION, readme_text(record), results_dir=root)
    return path


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--before", required=True, help="git revision of the 'before' "
                   "results (e.g. 0e7885f)")
    p.add_argument("--after", default=None, help="git revision of the 'after' "
                   "results (default: the working tree)")
    p.add_argument("--results", default="results", help="results folder")
    p.add_argument("--experiments", nargs="+", default=list(EXPERIMENTS),
                   choices=list(EXPERIMENTS))
    p.add_argument("--no-write", action="store_true",
                   help="print the README section only; write nothing")
    args = p.parse_args(argv)
    before = GitSource(args.before, args.results)
    after = (TreeSource(args.results) if args.after is None
             else GitSource(args.after, args.results))
    record = compare(before, after, args.experiments)
    if args.no_write:
        print(readme_text(record))
        return 0
    path = write(record, args.results, config={
        "before": args.before, "before_commit": before.commit,
        "after": args.after or "working tree", "after_commit": after.commit,
        "experiments": args.experiments,
    })
    print(f"wrote {path}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
