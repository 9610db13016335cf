"""Every estimator of LER, G, CCT and lamp type behind one contract, looked
up by name.

`ESTIMATORS` maps a name (case and separators ignored) to a frozen
configuration class (`InversionConfig`, `RidgeConfig`, `KernelConfig`,
`DirectConfig`); an instance's `fit(ctx, bands, surface_mode=...)` trains on
a `search.Context`'s scored lamps and returns a fitted estimator whose
`predict(radiance, surface)` returns an `Estimates` record (values, 90 %
intervals, null reasons, `unexplained`, types, probabilities) and whose
`description` says what it is. `configure(name, **options)` builds a
configuration and refuses an option the estimator does not have, naming the
estimators that do. `bandopt evaluate` and the studies take their
estimators from here; `tests/test_estimators.py` checks every registered
one against the contract (as scikit-learn's `estimator_checks` does).

A fitted estimator is an artefact: `save_fitted` writes it with the
fingerprint of what it depends on (bands, configuration, data, code),
`load_fitted` refuses one whose fingerprint differs, and `fit_cached` fits
once per fingerprint and loads it afterwards (`bandopt fit`, `bandopt
evaluate --model`).

`variant(label)` is the inversion's configuration of a named variant (the
studies' estimators).

- `_contract`: `Estimates`, `Surface` and the protocols;
- `_inversion`: the shipped physics-based inversion (`InversionConfig`,
  `fit_on_context`);
- `_baselines`: the regression baselines and the direct estimate;
- `_artefact`: a fitted estimator as a fingerprinted file (`save_fitted`,
  `load_fitted`) and the user's cache of them (`fit_cached`); `_serial`
  turns a fitted estimator into JSON and arrays and back.
"""

import dataclasses

from ..inversion import options_of as inversion_options_of
from ..names import CanonicalMapping
from ._artefact import (
    EVALUATE_CONTEXT as EVALUATE_CONTEXT,
    CacheOutcome as CacheOutcome,
    FingerprintMismatchError as FingerprintMismatchError,
    ModelFileError as ModelFileError,
    cache_dir as cache_dir,
    fingerprint as fingerprint,
    fit_cached as fit_cached,
    load_fitted as load_fitted,
    read_fingerprint as read_fingerprint,
    save_fitted as save_fitted,
)
from ._baselines import (
    DirectConfig as DirectConfig,
    FittedDirect as FittedDirect,
    FittedRegression as FittedRegression,
    KernelConfig as KernelConfig,
    RidgeConfig as RidgeConfig,
    conformal_halfwidth as conformal_halfwidth,
)
from ._contract import (
    Estimates as Estimates,
    EstimatorConfig as EstimatorConfig,
    Fitted as Fitted,
    Surface as Surface,
)
from ._inversion import (
    FittedInversion as FittedInversion,
    InversionConfig as InversionConfig,
    describe as describe,
    fit_on_context as fit_on_context,
)


ESTIMATORS: CanonicalMapping[type] = CanonicalMapping(
    {c.name: c for c in (InversionConfig, RidgeConfig, KernelConfig, DirectConfig)},
    what="estimator",
)
"""Registered estimators: name -> configuration class."""


def options_of(name: str) -> tuple[str, ...]:
    """The configuration fields of estimator `name`."""
    return tuple(
        f.name for f in dataclasses.fields(ESTIMATORS[ESTIMATORS.resolve(name)])
    )


def owners_of(option: str) -> tuple[str, ...]:
    """The registered estimators that have configuration field `option`."""
    return tuple(n for n in ESTIMATORS if option in options_of(n))


def configure(name: str, **options) -> "EstimatorConfig":
    """The configuration of estimator `name` with `options` set; an option
    it does not have raises `ValueError` naming the estimators that have it."""
    key = ESTIMATORS.resolve(name)
    for opt in options:
        if opt not in options_of(key):
            owners = owners_of(opt)
            raise ValueError(
                f"option {opt!r} is not one of estimator {key}'s "
                f"({', '.join(options_of(key)) or 'it has none'}); "
                + (
                    f"it belongs to {', '.join(owners)}."
                    if owners
                    else "no registered estimator has it."
                )
            )
    return ESTIMATORS[key](**options)


def variant(label: str) -> InversionConfig:
    """The shipped inversion's configuration with the options of a named
    variant of it (`bandopt.inversion.LABELLED`, e.g.
    `inversion-moon-mix-metric`; `-loco`: intervals calibrated on classes
    held out in turn), the names the studies compare. An unknown name raises
    `ValueError` listing the variants."""
    opts = inversion_options_of(label)
    return InversionConfig(
        **{f.name: getattr(opts, f.name) for f in dataclasses.fields(opts)}
    )
