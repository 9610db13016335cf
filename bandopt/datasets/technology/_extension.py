"""The near-infrared extension of a user's spectrum by its technology.

`extend_user_spectrum` puts a spectrum measured from 380 nm to 780 nm or
beyond on the library grid (to 900 nm) and continues it past its measured end
by the NIR model of its identified technology (one row per candidate when
ambiguous), of a named technology, by zeros or by the user's own NIR
(`NIR_CHOICES`). Apart from the identification it calls (`_identify`), since
it is the step `bandopt evaluate` and the robustness study use;
`bandopt.datasets.technology` re-exports every public name here.
"""

import dataclasses
from pathlib import Path

import numpy as np

from ...names import CanonicalMapping
from ...spectra import GRID_1NM
from .. import nir as nir_models
from ..loaders import read_spectrum
from ._identify import TechnologyEvidence, identify_technology


NIR_CHOICES = CanonicalMapping(
    {**{t: t for t in nir_models.TECHNOLOGIES}, "auto": "auto", "none": "none"},
    what="NIR option",
)
"""The named `nir=` options of `extend_user_spectrum`: a technology of
`bandopt.datasets.nir.TECHNOLOGIES`, "auto" or "none" (case and separators ignored)."""


@dataclasses.dataclass(frozen=True)
class UserExtension:
    """A user's spectrum on the library grid, one row per NIR candidate.

    - `wavelength_nm`: `bandopt.spectra.GRID_1NM` (380-900 nm, 1 nm). [nm]
    - `spectra`: (n_candidates, w): measured values up to `measured_to_nm`,
      each candidate's extension beyond it. [unit of the input]
    - `technologies`: the technology of each row's extension (None: zeros,
      the user's own NIR, or nothing to extend).
    - `identification`: the `TechnologyEvidence` of the visible spectrum.
    - `measured_to_nm`: the last measured wavelength. [nm]
    - `nir`: how the NIR was chosen: "measured" (nothing to extend), "auto",
      a technology name, "none" or "user" (the user's own values).
    - `note`: JSON-ready summary of the above (None when nothing was
      extended).
    """

    wavelength_nm: np.ndarray
    spectra: np.ndarray
    technologies: tuple[str | None, ...]
    identification: TechnologyEvidence
    measured_to_nm: float
    nir: str
    note: dict | None

    @property
    def ambiguous(self) -> bool:
        """More than one candidate extension."""
        return self.spectra.shape[0] > 1


def _user_nir(nir_option, end_nm: float):
    """(wavelength, values) of the user's own NIR: an array pair or a file;
    must cover from the measured end to 900 nm."""
    if isinstance(nir_option, str | Path):
        label = str(nir_option)
        try:  # the one reader of spectral files (CSV, .prn, TM-27 XML)
            sp = read_spectrum(nir_option, require_range_nm=None)
        except (OSError, ValueError) as exc:
            raise ValueError(f"nir {label}: cannot read a spectrum ({exc})") from None
        w, v = sp.wavelength_nm, sp.values
    else:
        try:
            w, v = nir_option
        except (TypeError, ValueError):
            raise ValueError(
                "nir must be 'auto', 'none', a technology, a (wavelength, values) "
                "pair or a file."
            ) from None
        label = "(wavelength, values) arrays"
    w, v = np.asarray(w, float), np.asarray(v, float)
    if w.ndim != 1 or w.shape != v.shape or w.size < 2 or np.any(np.diff(w) <= 0):
        raise ValueError(
            f"nir {label}: need 1-d wavelength and values of one length >= 2, "
            "wavelengths strictly increasing."
        )
    top = float(GRID_1NM[-1])
    if w[0] > end_nm or w[-1] < top:
        raise ValueError(
            f"nir {label}: covers {w[0]:g}-{w[-1]:g} nm; the NIR must cover "
            f"{end_nm:g}-{top:g} nm (the measured end to the grid's end)."
        )
    if not np.all(np.isfinite(v)):
        raise ValueError(f"nir {label}: values must be finite.")
    return w, v, label


def extend_user_spectrum(wavelength_nm, values, nir="auto") -> UserExtension:
    """A spectrum measured from <= 380 nm to any end >= 780 nm, on the library
    grid `GRID_1NM` (to 900 nm), extended beyond its measured end.

    Every measured value up to the measured end is kept (linear
    interpolation onto the grid); grid points beyond it come from `nir`:

    - "auto": the technology `identify_technology` finds; when it is
      ambiguous, one row per candidate (best first);
    - a technology of `bandopt.datasets.nir.TECHNOLOGIES`: that technology's model
      (`bandopt.datasets.nir.extend_spectrum`);
    - "none": zeros beyond the measured end (the note says so);
    - a (wavelength [nm], values) pair or a spectrum file: the user's own
      NIR, interpolated linearly (it must cover the measured end to 900 nm).

    A spectrum measured to 900 nm or beyond is only resampled (`nir` is not
    used). Pure NumPy, no library loaded (the NIR line models are calibrated
    once per process). (`wavelength_nm` [nm] increasing; `values` any
    spectral unit, returned in it.)
    """
    w = np.asarray(wavelength_nm, float)
    s = np.asarray(values, float)
    ident = identify_technology(w, s)  # validates shapes and the 380-780 range
    if not np.all(np.isfinite(s)) or np.any(np.diff(w) <= 0):
        raise ValueError("values must be finite and wavelength_nm strictly increasing.")
    grid = np.asarray(GRID_1NM, float)
    end = float(w[-1])
    inside = grid <= end
    base = np.where(inside, np.interp(grid, w, s), 0.0)
    beyond = grid[~inside]
    if beyond.size == 0:
        return UserExtension(grid, base[None], (None,), ident, end, "measured", None)
    named = None
    if isinstance(nir, str) and not Path(nir).is_file():
        named = NIR_CHOICES.resolve(nir)  # ValueError listing the choices
    note = {"measured_to_nm": end, "identification": ident.to_json()}
    if named == "none":
        rows, techs = [base], (None,)
        note["nir_extension"] = "none"
        note["policy"] = f"zeros beyond the measured end ({end:g} nm), as asked"
    elif named is not None:
        techs = ident.candidates if named == "auto" else (named,)
        rows = [
            np.concatenate([base[inside], nir_models.extend_spectrum(w, s, t, beyond)])
            for t in techs
        ]
        note["nir_extension"] = techs[0] if len(techs) == 1 else list(techs)
        note["policy"] = (
            f"extended by the {' / '.join(techs)} NIR model"
            + (
                " (one extension per candidate: the features are ambiguous)"
                if len(techs) > 1
                else ""
            )
            + (" from the spectral features" if named == "auto" else ", as asked")
        )
    else:
        nw, nv, label = _user_nir(nir, end)
        rows, techs = (
            [np.concatenate([base[inside], np.interp(beyond, nw, nv)])],
            (None,),
        )
        note["nir_extension"] = "user"
        note["policy"] = f"the user's own NIR beyond {end:g} nm: {label}"
    return UserExtension(
        wavelength_nm=grid,
        spectra=np.asarray(rows),
        technologies=techs,
        identification=ident,
        measured_to_nm=end,
        nir=named if named is not None else "user",
        note=note,
    )
