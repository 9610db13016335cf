"""Surface prior: a low-rank reflectance basis of the road-scene surface types,
the candidate surfaces of each `SURFACE_MODES` (unknown, class, measured) and
the simulated daytime Sentinel-2 measurement (`ESA2017`, `Doxani2018`) that
the 'measured' mode inverts to basis coefficients."""

import dataclasses
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from ..datasets import surfaces as surf_mod


SURFACE_MODES = ("unknown", "class", "measured")
"""What the estimator is told about the surface under the lamp."""


PRIOR_SURFACES = (
    "asphalt",
    "road",
    "parking_lot",
    "sidewalk",
    "driveway",
    "composition_shingle",
    "wood_shingle",
    "tile_roof",
    "metal_roof",
    "concrete_roof_tile",
    "soil",
    "sand",
    "grass",
)
"""Surface types a street light may shine on (water and snow left out: one
spectrum each and not road scenes)."""


SURFACE_RANK = 12
"""Basis size of the surface prior: reproduces the mean reflectance of every
road-scene type within 0.4 % (rank 6: 4.5 % for asphalt) over 380-900 nm."""


S2_SIGMA = (0.05, 0.005)
"""Sentinel-2 L2A surface reflectance accuracy `σ = a ρ + b` (`Doxani2018`)."""


S2_MIN_INSIDE = 0.95
"""Least fraction of a Sentinel-2 band's response inside the grid to use it."""


S2_FILE = Path(__file__).parents[1] / "sensor" / "data" / "sentinel2a_msi_srf.csv"


@dataclasses.dataclass(frozen=True)
class SurfaceBasis:
    """Low-rank reflectance basis `ρ = mean + coords @ basis`.

    - `mean`: (w,) [1]; `basis`: (r, w) orthonormal rows; `scale`: prior SD of
      each coefficient (r,); `types`: surface types, `type_coords`: their mean
      reflectances' coefficients (t, r).
    """

    wavelength_nm: np.ndarray
    mean: np.ndarray
    basis: np.ndarray
    scale: np.ndarray
    types: tuple[str, ...]
    type_coords: np.ndarray

    def coords(self, reflectance) -> np.ndarray:
        """Least-squares coefficients of reflectances on the grid, (n, r)."""
        return (np.atleast_2d(reflectance) - self.mean) @ self.basis.T

    def reflectance(self, coords) -> np.ndarray:
        return self.mean + np.atleast_2d(coords) @ self.basis

    def class_coords(self, name: str, n: int = 11, seed: int = 0) -> np.ndarray:
        """Candidates when the class is known: its mean and `n` measured
        samples (drawn with `seed`), (n + 1, r)."""
        name = surf_mod.resolve_surface(name)
        grid = self.wavelength_nm
        _, mean = surf_mod.mean_reflectance([name], grid)
        s = surf_mod.sample_reflectance(name, n, seed, grid)
        return self.coords(np.vstack([mean, s]))


_SURFACE_BASES: dict = {}
"""`surface_basis` results by (grid bytes, grid shape, types, rank)."""


def surface_basis(
    wavelength_nm,
    types: Sequence[str] = PRIOR_SURFACES,
    rank: int = SURFACE_RANK,
) -> SurfaceBasis:
    """Type-balanced weighted PCA of every library reflectance of `types`.

    Computed once per grid, types and rank in a process: the SVD of every
    library reflectance takes seconds, and fits, estimators and contexts ask
    for the same basis many times. The library's surface sets are cached and
    read-only, so the basis cannot change within a process; every call
    returns its own copies of the arrays, so a caller that modifies one
    changes no other caller's."""
    grid = np.asarray(wavelength_nm, float)
    key = (grid.tobytes(), grid.shape, tuple(types), int(rank))
    if key not in _SURFACE_BASES:
        _SURFACE_BASES[key] = _computed_surface_basis(grid.copy(), types, rank)
    b = _SURFACE_BASES[key]
    return SurfaceBasis(
        b.wavelength_nm.copy(),
        b.mean.copy(),
        b.basis.copy(),
        b.scale.copy(),
        b.types,
        b.type_coords.copy(),
    )


def _computed_surface_basis(
    grid: np.ndarray, types: Sequence[str], rank: int
) -> SurfaceBasis:
    """`surface_basis` computed (not cached)."""
    rows, wts, means = [], [], []
    for t in types:
        s = surf_mod.surface(t).resample(grid)
        r = np.asarray(s.reflectance, float)
        rows.append(r)
        wts.append(np.full(r.shape[0], 1.0 / (len(types) * r.shape[0])))
        means.append(r.mean(axis=0))
    x, w = np.vstack(rows), np.concatenate(wts)
    mu = w @ x
    xc = (x - mu) * np.sqrt(w)[:, None]
    _, sv, vt = np.linalg.svd(xc, full_matrices=False)
    basis = vt[:rank]
    scale = sv[:rank]  # weights sum to 1: singular values are the coefficient SDs
    return SurfaceBasis(
        grid, mu, basis, scale, tuple(types), (np.stack(means) - mu) @ basis.T
    )


def sentinel2_response(wavelength_nm) -> tuple[tuple[str, ...], np.ndarray]:
    """Sentinel-2A MSI band responses on the grid (bands with at least
    `S2_MIN_INSIDE` of their response area on it, cut at its ends),
    `(names, (b, w))`, from the vendored Py6S tables (`ESA2017`)."""
    data = np.genfromtxt(S2_FILE, delimiter=",", names=True)
    grid = np.asarray(wavelength_nm, float)
    names, rows = [], []
    wl = data["wavelength_nm"]
    for name in data.dtype.names[1:]:
        r = np.asarray(data[name], float)
        inside = (wl >= grid[0]) & (wl <= grid[-1])
        if np.trapezoid(r * inside, wl) < S2_MIN_INSIDE * np.trapezoid(r, wl):
            continue
        names.append(name)
        rows.append(np.interp(grid, data["wavelength_nm"], r, left=0.0, right=0.0))
    return tuple(names), np.stack(rows)


def observe_sentinel2(reflectance, wavelength_nm, *, seed: int = 0) -> np.ndarray:
    """Daytime Sentinel-2 band reflectances of surfaces with the L2A error
    `σ = 0.05 ρ + 0.005` (Gaussian, `numpy.random.default_rng(seed)`), (n, b)."""
    _, resp = sentinel2_response(wavelength_nm)
    r = np.atleast_2d(reflectance)
    band = r @ resp.T / resp.sum(axis=1)
    sd = S2_SIGMA[0] * band + S2_SIGMA[1]
    return band + sd * np.random.default_rng(seed).standard_normal(band.shape)


def surface_from_sentinel2(observed, basis: SurfaceBasis) -> np.ndarray:
    """Basis coefficients from Sentinel-2 band reflectances: the Gaussian
    posterior mean under the basis prior and the L2A error model, (n, r)."""
    _, resp = sentinel2_response(basis.wavelength_nm)
    h = resp / resp.sum(axis=1, keepdims=True)
    a = h @ basis.basis.T  # (b, r)
    m0 = h @ basis.mean
    obs = np.atleast_2d(observed)
    out = np.empty((obs.shape[0], basis.basis.shape[0]))
    for i, o in enumerate(obs):
        sd = S2_SIGMA[0] * np.clip(o, 0, None) + S2_SIGMA[1]
        aw = a / sd[:, None]
        lhs = aw.T @ aw + np.diag(1.0 / basis.scale**2)
        out[i] = np.linalg.solve(lhs, aw.T @ ((o - m0) / sd))
    return out


def surface_candidates(basis: SurfaceBasis, mode: str, n: int, surface=None):
    if mode not in SURFACE_MODES:
        raise ValueError(f"surface mode {mode!r}: expected one of {SURFACE_MODES}.")
    r = basis.basis.shape[0]
    if mode == "unknown":
        c = np.broadcast_to(basis.type_coords, (n, *basis.type_coords.shape))
    elif mode == "class":
        if surface is None or len(surface) != n:
            raise ValueError("surface mode 'class' needs one surface type per pixel.")
        cache = {}
        for t in set(surface):
            cache[t] = basis.class_coords(t)
        c = np.stack([cache[t] for t in surface])
    else:
        coords = np.asarray(surface, float) if surface is not None else None
        if coords is None or coords.shape != (n, r):
            raise ValueError(
                "surface mode 'measured' needs basis coefficients (n, r) per pixel "
                "(see surface_from_sentinel2)."
            )
        c = coords[:, None, :]
    ones = np.ones((*c.shape[:2], 1))
    cand = np.concatenate([ones, c], axis=-1)
    return cand, np.full(cand.shape[:2], -np.log(cand.shape[1]))


def _surface_knowledge(row_types, basis: SurfaceBasis, seed: int) -> dict:
    """Per-row surface input of each mode (the Sentinel-2 draw only when asked)."""

    class _Lazy(dict):
        def __missing__(self, key):
            if key != "measured":
                raise KeyError(key)
            self[key] = measured_surfaces(row_types, basis, seed=seed)
            return self[key]

    return _Lazy(unknown=None, **{"class": row_types})


def measured_surfaces(row_types, basis: SurfaceBasis, *, seed: int = 0):
    """Per-row surface coefficients from a simulated daytime Sentinel-2
    measurement of each row's true (type-mean) surface, (N, r)."""
    types = sorted(set(row_types))
    _, refl = surf_mod.mean_reflectance(types, basis.wavelength_nm)
    idx = np.array([types.index(t) for t in row_types])
    obs = observe_sentinel2(refl[idx], basis.wavelength_nm, seed=seed)
    return surface_from_sentinel2(obs, basis)
