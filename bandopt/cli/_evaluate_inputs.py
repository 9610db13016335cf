"""The inputs of `bandopt evaluate` a user gives: lamp spectra (read, checked
and extended beyond their measured end as `--nir` says, one row per
candidate extension, merged back per lamp), a surface reflectance file, and
the `--prior-lamps CLASS=FILE` entries with their names and class check."""


def read_reflectance(path, grid):
    """Reflectance file -> values on `grid` (380-900 nm) [1], read by the one
    reader of every spectral file (`datasets.loaders.read_spectrum`: header
    line, `,`/`;`/tab/space separators, comments, LI-1800 and TM-27 files);
    errors name the file and the problem."""
    import numpy as np

    from ..datasets.loaders import read_spectrum

    sp = read_spectrum(path, require_range_nm=(float(grid[0]), float(grid[-1])))
    w, r = np.asarray(sp.wavelength_nm, float), np.asarray(sp.values, float)
    if r.max() > 1:
        i = int(np.argmax(r))
        raise ValueError(
            f"{path}: reflectance {r[i]:g} at {w[i]:g} nm is above 1; give "
            "reflectance as a fraction 0-1."
        )
    return np.interp(grid, w, r)


def check_nir(value: str) -> None:
    """Refuse a `--nir` value that is neither a choice nor a file (before
    anything trains); the error names the option."""
    from pathlib import Path

    from ..datasets.technology import NIR_CHOICES

    if value not in NIR_CHOICES and not Path(value).is_file():
        raise ValueError(
            f"--nir {value!r}: neither a file nor one of {', '.join(NIR_CHOICES)}."
        )


def load_user_lamp(path, nir="auto"):
    """Read, check, extend (policy above) and resample a user spectrum to the
    library grid. Returns (values on GRID_1NM, one row per NIR candidate,
    most likely first; note or None)."""
    import numpy as np

    from ..datasets.loaders import read_spectrum
    from ..datasets.technology import extend_user_spectrum

    sp = read_spectrum(path)
    w, s = np.asarray(sp.wavelength_nm, float), np.asarray(sp.values, float)
    s = s / s.max()  # peak 1: the scene scales every lamp to its lux anyway
    if w[0] > 380.0 or w[-1] < 780.0:
        raise ValueError(
            f"{path}: spectrum covers {w[0]:g}-{w[-1]:g} nm; need 380-780 nm."
        )
    try:
        ext = extend_user_spectrum(w, s, nir)
    except (OSError, ValueError) as exc:
        raise ValueError(f"--nir {nir!s} for {path}: {exc}") from None
    note = None if ext.note is None else {"file": str(path), **ext.note}
    if ext.ambiguous:
        note["candidates"] = list(ext.technologies)
        note["estimate_policy"] = (
            "the estimator ran on every candidate extension: the estimate is the "
            "most likely candidate's, every 90 % interval the union over the "
            "candidates, the level-1 probabilities the candidates' average"
        )
    return ext.spectra, note


def merge_candidates(rows: list[dict]) -> dict:
    """One lamp's result from its candidate extensions' rows (most likely
    first): that row, every 90 % interval widened to the union over the
    candidates, the level-1 probabilities averaged (the type from the
    average). `unexplained` only when every candidate is (some extension
    explains the pixel otherwise; the types are then that candidate's), and
    then no type is given."""
    out = dict(rows[0])
    if len(rows) == 1:
        return out
    ps = [r.get("known_type_p_value") for r in rows]
    if None not in ps:  # unexplained only if every candidate is: the largest p
        out["known_type_p_value"] = max(ps)
    flags = [r.get("unexplained") for r in rows]
    if None not in flags:
        out["unexplained"] = all(flags)
        if not out["unexplained"] and flags[0]:
            first = rows[flags.index(False)]
            for k in ("predicted_level1", "predicted_level2", "null_reasons"):
                out[k] = first[k]
    out["interval90"] = {}
    for m, iv in (rows[0]["interval90"] or {}).items():
        ivs = [(r["interval90"] or {}).get(m) for r in rows]
        ivs = [x for x in ivs if x is not None]
        out["interval90"][m] = (
            [min(x[0] for x in ivs), max(x[1] for x in ivs)] if iv else iv
        )
    probs = [r.get("level1_probabilities") for r in rows]
    if all(probs):
        from ..inversion import top_two  # start-up time

        avg = {k: sum(p[k] for p in probs) / len(probs) for k in probs[0]}
        out["level1_probabilities"] = avg
        out["predicted_level1"] = max(avg, key=avg.get)
        out["level1_top2"] = top_two(avg)
    if out.get("unexplained"):  # flagged, not guessed
        out["predicted_level1"] = out["predicted_level2"] = None
    return out


def parse_prior_lamps(entries) -> list[tuple[str, str]]:
    """`--prior-lamps` entries `CLASS=FILE` -> (class, file) pairs; errors
    name the entry and the problem (no file is read here)."""
    from ..datasets.lamps import LEVEL2

    out = []
    for e in entries:
        cls, sep, path = str(e).partition("=")
        if not sep or not cls or not path:
            raise ValueError(
                f"--prior-lamps {e!r}: expected CLASS=FILE (e.g. led_warm=my_led.csv)."
            )
        if cls not in LEVEL2:
            raise ValueError(
                f"--prior-lamps {e!r}: class {cls!r} is not a level-2 class; choose "
                f"from {', '.join(LEVEL2)}."
            )
        out.append((cls, path))
    paths = [p for _, p in out]
    twice = sorted({p for p in paths if paths.count(p) > 1})
    if twice:
        raise ValueError(f"--prior-lamps: {twice[0]} is given twice.")
    return out


def visible_centroid_nm(spectra, grid):
    """Power-weighted mean wavelength over 380-780 nm of each spectrum (l, w)
    on `grid`; NaN for a spectrum without visible power. [nm]"""
    import numpy as np

    vis = (grid >= 380.0) & (grid <= 780.0)
    s = np.asarray(spectra, float)[:, vis]
    power = np.trapezoid(s, grid[vis], axis=1)
    moment = np.trapezoid(s * grid[vis], grid[vis], axis=1)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(power > 0, moment / power, np.nan)


def prior_class_warning(cls: str, path, spectrum, grid) -> str | None:
    """A warning when a `--prior-lamps CLASS=FILE` spectrum's visible centroid
    lies outside the range of the library's measured lamps of CLASS (a 450 nm
    line given as led_amber, whose lamps lie near 600 nm): the class is
    probably wrong. A warning, not an error: a new lamp of the class may lie
    a little outside the library's."""
    import numpy as np

    from ..datasets.lamps import library

    lib = library(wavelength_nm=grid).select(lamps_only=True)
    members = [i for i, r in enumerate(lib.records) if r.level2 == cls]
    ok = [i for i in members if np.all(np.isfinite(lib.values[i]))]
    if not ok:
        return None
    ref = visible_centroid_nm(lib.values[ok], grid)
    (c,) = visible_centroid_nm(np.asarray(spectrum, float)[None], grid)
    lo, hi = float(np.nanmin(ref)), float(np.nanmax(ref))
    if np.isfinite(c) and lo <= c <= hi:
        return None
    return (
        f"--prior-lamps {cls}={path}: its visible centroid "
        f"{c:.0f} nm lies outside the {lo:.0f}-{hi:.0f} nm of the library's "
        f"{len(ok)} {cls} lamps; is it a {cls} lamp?"
    )


def prior_lamp_names(paths) -> list[str]:
    """Each `--prior-lamps` file's name in the prior (ids `own:<name>`): its
    file name, or its path where two files share a name."""
    from pathlib import Path

    names = [Path(p).name for p in paths]
    return [
        str(p) if names.count(n) > 1 else n for p, n in zip(paths, names, strict=True)
    ]
