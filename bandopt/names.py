"""Name registries: strings resolved at the boundary, ignoring case and
separators (house style rule 8), in the manner of colour-science's
`colour.utilities.CanonicalMapping` and `validate_method`.

One rule everywhere: a name's key is its lower-case letters and digits
(`"Super-Gaussian"`, `"super_gaussian"` and `"super gaussian"` all have the
key `"supergaussian"`). An unknown name raises `ValueError` listing the valid
choices.
"""

import re
from collections.abc import Iterable, Iterator, Mapping
from typing import TypeVar


V = TypeVar("V")

__all__ = ["CanonicalMapping", "canonical_key", "validate_method"]


def canonical_key(name) -> str:
    """Lower-case letters and digits of `str(name)`: the lookup key."""
    return re.sub(r"[^0-9a-z]", "", str(name).lower())


class CanonicalMapping(Mapping[str, V]):
    """A read-only mapping whose keys are matched by `canonical_key`.

    `mapping[name]` finds the entry whose key (or one of `aliases`, a mapping
    alias -> key) has the same canonical key as `name`; iteration yields the
    stored keys. `resolve(name)` returns the stored key and raises a
    `ValueError` naming `what` and the choices when there is none.
    """

    def __init__(
        self,
        data: Mapping[str, V] | Iterable[tuple[str, V]],
        *,
        aliases: Mapping[str, str] | None = None,
        what: str = "name",
    ):
        self._data: dict[str, V] = dict(data)
        self._what = what
        self._lookup: dict[str, str] = {}
        for k in self._data:
            self._add(canonical_key(k), k)
        for alias, k in (aliases or {}).items():
            if k not in self._data:
                raise ValueError(f"Alias {alias!r} points to unknown {what} {k!r}.")
            self._add(canonical_key(alias), k)

    def _add(self, key: str, target: str) -> None:
        if self._lookup.get(key, target) != target:
            raise ValueError(
                f"{self._what} {target!r} and {self._lookup[key]!r} have the same "
                f"canonical key {key!r}."
            )
        self._lookup[key] = target

    def resolve(self, name) -> str:
        """The stored key matching `name` (case and separators ignored)."""
        target = self._lookup.get(canonical_key(name))
        if target is None:
            raise ValueError(
                f"Unknown {self._what} {name!r}; expected one of "
                f"{sorted(self._data)} (case and separators are ignored)."
            )
        return target

    def __getitem__(self, name) -> V:
        target = self._lookup.get(canonical_key(name))
        if target is None:
            raise KeyError(name)
        return self._data[target]

    def __contains__(self, name) -> bool:
        return canonical_key(name) in self._lookup

    def __iter__(self) -> Iterator[str]:
        return iter(self._data)

    def __len__(self) -> int:
        return len(self._data)

    def __repr__(self) -> str:
        return f"CanonicalMapping({self._data!r})"


def validate_method(
    name, choices: Iterable[str], what: str = "method", *, aliases=None
) -> str:
    """The entry of `choices` matching `name` (case and separators ignored);
    `ValueError` listing the choices otherwise."""
    choices = tuple(choices)
    return CanonicalMapping(
        {c: c for c in choices}, aliases=aliases, what=what
    ).resolve(name)
