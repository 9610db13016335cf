"""Monkeypatching the inversion package: a name of `bandopt.inversion` is
looked up in the package (by callers outside it) and in each of its modules
that imports it (`cross_validate` in `_crossval` calls `_crossval.context_setup`),
so a patch must reach all of them."""

import importlib
import pkgutil

import pytest

from bandopt import inversion as inv_mod


MODULES = tuple(
    importlib.import_module(f"{inv_mod.__name__}.{m.name}")
    for m in pkgutil.iter_modules(inv_mod.__path__)
)
"""The modules of `bandopt.inversion`."""


def patch_inversion(monkeypatch: pytest.MonkeyPatch, name: str, value) -> None:
    """Set `name` to `value` in `bandopt.inversion` and in every module of the
    package that binds the same object under that name (where it is defined
    and where it is imported), undone with `monkeypatch`."""
    real = getattr(inv_mod, name)
    monkeypatch.setattr(inv_mod, name, value)
    for mod in MODULES:
        if getattr(mod, name, None) is real:
            monkeypatch.setattr(mod, name, value)


def moonlit_scenarios(lamp_id: str):
    """A scenario set of lamp `lamp_id` on asphalt and grass under one urban
    midlatitude-summer atmosphere, moonless and under a full Moon: the
    conditions of the small inversions of the Moon and chunking tests."""
    from bandopt.scene import build_scenarios

    return build_scenarios(
        lamps=[lamp_id],
        surfaces=("asphalt", "grass"),
        atmospheres=(("midlatitude_summer", "urban", 23.0),),
        moons=(None, "full"),
        classes=("P6",),
    )
