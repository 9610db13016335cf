"""`bandopt evaluate`'s default estimator, the physics-based inversion, as a
configuration object.

`InversionConfig` holds the options of the inversion that `bandopt evaluate`
ships (`bandopt.inversion.fit_inversion`), with the defaults users get;
`fit_on_context` fits it on a `search.Context`'s scenes for any band set and
any lamp-grouped training split, so a study scores exactly the estimator
users run; `InversionConfig.fit` is its registry contract
(`bandopt.estimators`): a `FittedInversion` that describes itself and
predicts `Estimates`.
"""

import dataclasses
from collections.abc import Sequence
from typing import ClassVar

import numpy as np

from .. import inversion as inv_mod
from ..forward import band_weights_on
from ..spectra import GRID_1NM
from ._contract import Estimates, Surface


@dataclasses.dataclass(frozen=True)
class InversionConfig(inv_mod.InversionOptions):
    """The shipped inversion under the estimator contract: its options
    (`inversion.InversionOptions`, with `bandopt evaluate`'s defaults), how
    it is fitted on a context and what it predicts."""

    name: ClassVar[str] = "inversion"
    own_lamps: ClassVar[bool] = True
    needs_surface: ClassVar[bool] = False

    def check(self, bands) -> None:
        """Every band set will do: the inversion models any band."""

    def fit(self, ctx, bands, *, surface_mode: str, own=None) -> "FittedInversion":
        """Trained on every scored lamp of `ctx` (inner folds: its outer
        splits), with the user's lamps `own` ((names, values on GRID_1NM,
        level-2 classes), or None) in the prior too."""
        grid = ctx.wavelength_nm
        inv = fit_on_context(
            ctx,
            bands,
            self,
            surface_mode=surface_mode,
            always=_with_own_lamps(None, own, grid),
        )
        return FittedInversion(
            inv, self, inv_mod.surface_basis(grid), describe(inv, self, surface_mode)
        )


def fit_on_context(
    ctx,
    bands,
    config: InversionConfig = InversionConfig(),
    *,
    surface_mode: str = "unknown",
    train_lamps: Sequence[int] | None = None,
    inner: Sequence[tuple[np.ndarray, np.ndarray]] | None = None,
    always=None,
):
    """Fit `config`'s inversion on a `search.Context` for `bands`.

    `train_lamps` (indices of the context's scored lamps; default all) with
    `inner` lamp-grouped (train, validation) splits of them (default: the
    context's outer splits, as `bandopt evaluate` uses when it trains on every
    library lamp). `always`: extra lamps always in the prior (e.g. a user's
    own), added to the library's unscored lamps. Surface knowledge
    `surface_mode` as in `inversion.SURFACE_MODES` ('measured': Sentinel-2
    draws of each row's surface)."""
    lamps, lib_always, cond, row_types = inv_mod.context_setup(ctx)
    grid = ctx.wavelength_nm
    if train_lamps is None:
        train_lamps = np.arange(ctx.table.n_lamps)
        if inner is None:
            inner = ctx.folds.outer()
    elif inner is None:
        raise ValueError("inner: give the lamp-grouped splits of train_lamps.")
    basis = inv_mod.surface_basis(grid)
    row_surface = {
        "unknown": None,
        "class": row_types,
        "measured": inv_mod.measured_surfaces(row_types, basis),
    }[surface_mode]
    prior_always = lib_always
    if config.planck:
        prior_always = inv_mod.with_planck_lamps(prior_always, grid)
    if config.tm30:
        prior_always = inv_mod.with_tm30_lamps(prior_always, grid)
    if always is not None:
        prior_always = always if prior_always is None else prior_always + always
    return inv_mod.fit_inversion(
        ctx.radiance(bands),
        ctx.table.lamp_of,
        lamps,
        np.asarray(train_lamps, int),
        list(inner),
        np.asarray(band_weights_on(bands, np.asarray(grid, float))),
        cond,
        basis=basis,
        surface_mode=surface_mode,
        row_surface=row_surface,
        always=prior_always,
        row_moon=inv_mod.context_moon(ctx) if config.moon_told else None,
        **config.fit_kwargs(),
    )


@dataclasses.dataclass(frozen=True)
class FittedInversion:
    """A fitted inversion (`inversion.Inversion`) with its surface basis and
    its description, under the estimator contract."""

    model: object  # an inversion.Inversion
    config: InversionConfig
    basis: object
    description: str

    def predict(self, radiance, surface: Surface) -> Estimates:
        """Pixels of `bandopt evaluate`'s moonless scene, which the inversion
        is told is moonless; the surface as `surface` says."""
        n = len(radiance)
        res = self.model.predict(
            radiance, self.surface_input(surface, n), moon=np.zeros(n)
        )
        return Estimates.from_rows([res.row(i) for i in range(n)])

    def surface_input(self, surface: Surface, n: int):
        """What the inversion is told of `n` pixels' surface (`Inversion.
        posterior`'s `surface`): None (unknown), the type per pixel, or the
        measured reflectance's basis coefficients per pixel."""
        if surface.mode == "class":
            return [surface.name] * n
        if surface.mode == "measured":
            return np.repeat(self.basis.coords(surface.reflectance[None]), n, axis=0)
        return None

    def predict_chunks(self, radiance, surface: Surface, chunk_pixels=None):
        """`predict` for many pixels in bounded memory: yields (first pixel's
        index, `inversion.InversionResult` of a chunk) as
        `Inversion.predict_chunks` does, for the same moonless scene."""
        n = len(radiance)
        yield from self.model.predict_chunks(
            radiance,
            self.surface_input(surface, n),
            moon=np.zeros(n),
            chunk_pixels=chunk_pixels,
        )

    def report(self) -> dict:
        """The prior's and the intervals' fields of the evaluate JSON."""
        m, c = self.model, self.config
        return {
            "intervals": {"lamps": "known-types", "classes": "any-type"}.get(
                c.calibration, "by-flag"
            ),
            "interval_unit": _unit_json(m),
            "mixtures_per_class": c.mixtures,
            "cross_mixtures_per_class_pair": c.cross_mixtures,
            "modelled_in_prior": [i for i in m.prior.ids if i.startswith("planck_")],
            "peak_shifts_nm": m.diagnostics.get("peak_shifts", {}).get("shifts_nm", []),
            "tm30_lamps_in_prior": sum(i.startswith("ies_tm30_") for i in m.prior.ids),
            "sigma_rel": _sigma_json(m),
        }


def describe(inv, config: InversionConfig, surface_mode: str) -> str:
    """What the fitted inversion `inv` is, in words, for evaluate's JSON: its
    prior (how many lamps of which kind), the surface and Moon knowledge,
    the band-error model, the intervals, the probabilities and the flag."""
    added = inv.diagnostics["modelled_lamps"]["added"]
    n_model = sum(added.values())
    n_mix = inv.diagnostics["mixtures"]["n"]
    n_xmix = inv.diagnostics.get("cross_mixtures", {}).get("n", 0)
    shifted = inv.diagnostics["peak_shifts"]
    n_planck = sum(i.startswith("planck_") for i in inv.prior.ids)
    n_tm30 = sum(i.startswith("ies_tm30_") for i in inv.prior.ids)
    own = [i for i in inv.prior.ids if i.startswith("own:")]
    n_nir = inv.diagnostics["nir_error"]["n"]
    n_measured = (
        len(inv.prior.ids)
        - n_nir
        - n_model
        - n_mix
        - n_xmix
        - shifted["n"]
        - n_planck
        - n_tm30
        - len(own)
    )
    prior = f"{n_measured} measured library lamps"
    if n_tm30:
        prior += (
            f", {n_tm30} measured lamps of the IES TM-30-15 set (they train, "
            "never score)"
        )
    if n_planck:
        prior += (
            f", {n_planck} modelled incandescent spectra (Planck's law; they "
            "train, never score)"
        )
    if n_model:
        prior += (
            f" and {n_model} modelled lamps ({config.modelled_per_class} per class "
            f"of {', '.join(added)}; bandopt.lampmodels calibrated on the "
            "training lamps of each fit only)"
        )
    if n_mix:
        prior += (
            f", with {n_mix} pairwise blends of two measured lamps of one "
            f"class (up to {config.mixtures} pairs per class)"
        )
    if n_xmix:
        prior += (
            f", {n_xmix} blends of two lamps of different types (10, 25 or 40 "
            "% of the light from the second; named by the first; "
            f"{config.cross_mixtures} pairs per pair of types)"
        )
    if shifted["n"]:
        prior += (
            f", and {shifted['n']} copies of its direct-emission LEDs shifted "
            f"by {', '.join(f'{x:+g}' for x in shifted['shifts_nm'])} nm"
        )
    if n_nir:
        prior += (
            f", and {n_nir} copies of its lamps with modelled near-infrared "
            "(780-900 nm) at the low and high end of that model's measured "
            "error (bandopt.datasets.nir.extension_error)"
        )
    if own:
        prior += (
            f", and {len(own)} measured lamp{'s' if len(own) > 1 else ''} of "
            f"yours ({', '.join(own)}; they train, never score)"
        )
    return (
        f"physics-based inversion (bandopt.inversion), prior over {prior}, "
        f"surface {surface_mode}; Moon brightness told (training scenes: their "
        f"own; your scene: moonless), not fitted; sigma_rel {_sigma_text(inv)}, "
        "90 % "
        + (
            {
                "lamps": "intervals split-conformal on lamp-grouped folds "
                "(calibrated for new lamps of the library's types)",
                "classes": "intervals split-conformal on library classes held "
                "out in turn (calibrated for lamp types the library lacks too)",
            }.get(
                config.calibration,
                "intervals split-conformal on lamp-grouped folds for pixels "
                "the library explains (calibrated for new lamps of its types) "
                "and on library classes held out in turn for pixels flagged "
                "unexplained (calibrated for lamp types it lacks)",
            )
        )
        + f", in units of {_unit_text(inv)}"
        + _probability_text(inv)
        + _flag_text(inv)
    )


def _flag_text(inv) -> str:
    """How `unexplained` is decided, for the description."""
    if not getattr(inv, "flag_folds", ()):
        return "; unexplained: misfit above the inner folds' threshold"
    return (
        f"; unexplained: p < {inv.flag_level:g} (known_type_p_value, a "
        "cross-conformal test: the pixel's misfit under each inner fold's prior "
        "ranked among that fold's held-out lamps of the type it is called)"
    )


def _probability_text(inv) -> str:
    """How the type probabilities were calibrated, for the description."""
    d = inv.diagnostics.get("probabilities", {})
    if not d.get("calibrated"):
        return "; type probabilities: the posterior's, uncalibrated"
    g = d["groups"]
    known, novel = g["known_types"], g.get("left_out_types")
    text = (
        "; type probabilities calibrated by a temperature that grows with the "
        f"pixel's misfit ({inv.level1_temperature:.3g} x misfit^"
        f"{inv.temperature_slope[0]:.2f}), fitted on held-out lamps of known "
        f"types (level-1 ECE there {known['ece_level1_after']:.2f}, "
        f"unexplained {known['unexplained_rate']:.2f})"
    )
    if novel is not None:
        text += (
            "; on library types held out in turn: ECE "
            f"{novel['ece_level1_after']:.2f}, unexplained "
            f"{novel['unexplained_rate']:.2f}"
        )
    return text


def _with_own_lamps(always, own, grid):
    """`always` plus the user's lamps `own` ((names, values on GRID_1NM,
    classes), or None: none) on `grid` (`inversion.own_lamps`)."""
    if not own or not own[0]:
        return always
    names, values, classes = own
    lamps = inv_mod.own_lamps(names, values, GRID_1NM, grid, classes)
    return lamps if always is None else always + lamps


def _unit_text(inv) -> str:
    """The intervals' unit as the description says it: the posterior's
    half-width, plus each metric's offset when one was chosen."""
    chosen = inv.diagnostics.get("interval_offset") or {}
    if not any(chosen.values()):
        return "the posterior's half-width"
    parts = ", ".join(f"{m} {f:g}" for m, f in chosen.items())
    return (
        "the posterior's half-width plus the narrowest calibrated offset (x the "
        f"metric's spread over the library lamps: {parts})"
    )


def _sigma_text(inv) -> str:
    """The inversion's band-error model(s) for the description."""
    joint = (inv.sigma_rel, inv.sigma_floor)

    def one(x) -> str:
        return f"{x[0]:g} (floor {x[1]:g})"

    if set(inv.metric_noise) == {joint}:
        return one(joint)
    ler, g, cct = inv.metric_noise
    return (
        f"LER {one(ler)}, G {one(g)}, CCT {one(cct)} (each metric's own, "
        f"chosen on lamp-grouped folds; types and flag {one(joint)})"
    )


def _unit_json(model) -> dict:
    """`"interval_unit"` of the JSON: per metric the offset added to the
    posterior's half-width, as a fraction of the metric's spread (0: the
    half-width alone)."""
    chosen = model.diagnostics.get("interval_offset")
    return dict(chosen) if chosen else {m: 0.0 for m in ("LER", "G", "CCT")}


def _sigma_json(model) -> dict:
    """`"sigma_rel"` of the JSON: (σ_rel, floor) per metric and for the
    types and flag."""
    names = ("LER", "G", "CCT")
    out = {m: list(x) for m, x in zip(names, model.metric_noise, strict=True)}
    out["types_and_flag"] = [model.sigma_rel, model.sigma_floor]
    return out
