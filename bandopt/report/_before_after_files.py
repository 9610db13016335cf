"""Where one side of a before/after comparison reads its result files: a git
revision (`GitSource`, `git show`, no checkout) or the working tree
(`TreeSource`), and `Files`, one side's files of one experiment whose `get`
fails naming the file and the key."""

import csv
import io
import json
import subprocess
from pathlib import Path


NOT_RUN = "not run"
"""Value of every quantity of a side whose result file is absent."""
ABSENT = "absent"
"""Value of a quantity the other side has but this side's file does not
(e.g. a band that only one design has)."""


# ---------------------------------------------------------------------------
# sources: where one side's files come from


class GitSource:
    """Result files at a git revision, read with `git show` (no checkout)."""

    def __init__(self, rev: str, results: str | Path = "results"):
        results = Path(results).resolve()
        self.repo = Path(git(results, "rev-parse", "--show-toplevel"))
        self.prefix = results.relative_to(self.repo).as_posix()
        try:
            self.commit = git(self.repo, "rev-parse", "--verify", f"{rev}^{{commit}}")
        except RuntimeError:
            raise ValueError(
                f"--before/--after {rev!r}: not a git revision of {self.repo}."
            ) from None
        short = self.commit[:7]
        self.label = f"git {rev}" + ("" if short.startswith(rev) else f" ({short})")
        listing = git(
            self.repo,
            "ls-tree",
            "-r",
            "--name-only",
            self.commit,
            "--",
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
            cwd=self.repo,
            capture_output=True,
            check=True,
        ).stdout


class TreeSource:
    """Result files in the working tree."""

    def __init__(self, results: str | Path = "results"):
        self.root = Path(results)
        self.commit = None
        try:
            head = git(self.root, "rev-parse", "--short", "HEAD")
        except (RuntimeError, OSError):
            head = None
        self.label = f"working tree ({self.root}" + (
            f", checkout at {head})" if head else ")"
        )

    def read(self, rel: str) -> bytes | None:
        path = self.root / rel
        return path.read_bytes() if path.is_file() else None


def git(cwd: Path, *args: str) -> str:
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
                    "the before/after headline extractor needs it."
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
