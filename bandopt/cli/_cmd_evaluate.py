"""`bandopt evaluate`: LER, G and CCT of user lamp spectra, true and estimated
from the band radiances of a band set."""

SCENE = {
    "surface": "asphalt",
    "atmosphere": "none",
    "moon": None,
    "lighting_class": "P4",
    "view_zenith_deg": 0.0,
}
NIR_POLICY = (
    "A spectrum must cover 380-780 nm. If it ends before 900 nm it is extended to "
    "900 nm "
    "with bandopt.datasets.nir.extend_spectrum, using the technology of its nearest "
    "library lamp (smallest RMS difference of the peak-normalised 380-780 nm spectra); "
    "the technology used is listed in notes. Resampling to the 1 nm library grid is "
    "linear."
)


def register(subparsers):
    p = subparsers.add_parser(
        "evaluate",
        help="true and estimated LER, G, CCT of lamp spectra for a band set",
        description=(
            "Train the brightness-free ridge estimators of LER, G index and CCT for a "
            "band set on the built-in lamp library (scored lamps, scenario preset "
            "'search'; ridge strength and feature degree by lamp-grouped CV), then, "
            "for each lamp spectrum file, report the truth (from the full spectrum) "
            "and the "
            "estimates from the band radiances of that lamp lighting the default scene "
            f"{SCENE}. " + NIR_POLICY
        ),
    )
    p.add_argument(
        "--bands",
        required=True,
        metavar="NAME|FILE",
        help="reference sensor name (e.g. sdgsat-1) or band-set JSON file",
    )
    p.add_argument(
        "--lamps",
        required=True,
        nargs="+",
        metavar="FILE",
        help="lamp spectra (.csv/.txt/.dat two columns, .prn, .xml/.spdx)",
    )
    p.add_argument("--json", action="store_true", help="print JSON (input order)")
    p.set_defaults(func=run)


def _nearest_technology(w, s):
    import numpy as np

    from ..datasets import nir
    from ..datasets.lamps import library

    lib = library(extend_nir=False)
    vis = (lib.wavelength_nm >= 380) & (lib.wavelength_nm <= 780)
    mine = np.interp(lib.wavelength_nm[vis], w, s)
    mine = mine / mine.max()
    best, tech = np.inf, None
    for rec, v in zip(lib.records, lib.values, strict=True):
        t = nir.technology_of(rec.level2, rec.level1)
        if t is None or rec.modelled:
            continue
        ref = v[vis] / np.nanmax(v[vis])
        d = float(np.sqrt(np.nanmean((ref - mine) ** 2)))
        if d < best:
            best, tech = d, (t, rec.id)
    return tech


def load_user_lamp(path):
    """Read, check, extend (policy above) and resample a user spectrum to the
    library grid. Returns (values on GRID_1NM, note or None)."""
    import numpy as np

    from ..datasets import nir
    from ..datasets.loaders import read_spectrum
    from ..spectra import GRID_1NM

    sp = read_spectrum(path)
    w, s = np.asarray(sp.wavelength_nm, float), np.asarray(sp.values, float)
    if w[0] > 380.0 or w[-1] < 780.0:
        raise ValueError(
            f"{path}: spectrum covers {w[0]:g}-{w[-1]:g} nm; need 380-780 nm."
        )
    grid = np.asarray(GRID_1NM, float)
    note = None
    if w[-1] < grid[-1]:
        tech, ref = _nearest_technology(w, s)
        new = grid[grid > max(w[-1], 780.0)]
        keep = w <= 780.0
        ext = nir.extend_spectrum(w[keep], s[keep], tech, new[new > 780.0])
        w = np.concatenate([w[w <= new[0] - 1e-9], new])
        s = np.concatenate([s[: w.size - new.size], ext])
        note = {
            "file": str(path),
            "nir_extension": tech,
            "nearest_library_lamp": ref,
            "measured_to_nm": float(sp.wavelength_nm[-1]),
        }
    return np.interp(grid, w, s), note


def run(args) -> int:
    import json
    import math
    import sys

    import jax.numpy as jnp
    import numpy as np

    from ..datasets import surfaces
    from ..estimate import METRICS, fit_estimator, lamp_truth
    from ..scene import class_illuminance_lx
    from ..search import get_context
    from ..spectra import GRID_1NM
    from ._cmd_bands import _load

    bands, entry = _load(args.bands)
    name = entry.key if entry is not None else bands.name
    lamps = [load_user_lamp(p) for p in args.lamps]  # errors before training
    ctx = get_context("search", None, 0, "none")
    all_lamps = np.arange(ctx.table.n_lamps)
    est = fit_estimator(
        ctx.radiance(bands),
        ctx.table,
        all_lamps,
        [(s.train, s.test) for s in ctx.splits],
    )
    grid = np.asarray(GRID_1NM, float)
    _, refl = surfaces.mean_reflectance([SCENE["surface"]], grid)
    e_lx = class_illuminance_lx(SCENE["lighting_class"])
    resp = np.asarray(bands.response(jnp.asarray(grid)))
    from ..scene import band_weights

    wts = np.asarray(band_weights(jnp.asarray(resp), jnp.asarray(grid)))
    vis = (grid >= 380) & (grid <= 780)
    from ..photometry import ler as ler_fn

    rows, notes, band_rad = [], [], []
    for path, (values, note) in zip(args.lamps, lamps, strict=True):
        truth, valid = lamp_truth(values[None], grid)
        # lumens ∝ K_m ∫ V S dλ = LER · ∫ S dλ (380-780 nm)
        lumens = float(ler_fn(values[None, vis], grid[vis])[0]) * float(
            np.trapezoid(values[vis], grid[vis])
        )
        per_lx = values / lumens  # spectral irradiance per lux [W m-2 nm-1 lx-1]
        toa = e_lx * refl[0] / math.pi * per_lx
        band_rad.append(wts @ toa)
        est_v = np.asarray(est.predict(jnp.asarray((wts @ toa)[None])))[0]
        t = {
            m: (float(truth[0, i]) if valid[0, i] else None)
            for i, m in enumerate(METRICS)
        }
        rows.append(
            {
                "file": str(path),
                "true": t,
                "estimate": {m: float(est_v[i]) for i, m in enumerate(METRICS)},
                "predicted_level1": None,
                "predicted_level2": None,
            }
        )
        if note:
            notes.append(note)
    from ..classify import predict_lamp_types

    level1, level2 = predict_lamp_types(np.asarray(band_rad), bands)
    for row, l1, l2 in zip(rows, level1, level2, strict=True):
        row["predicted_level1"], row["predicted_level2"] = l1, l2
    out = {
        "bands": name,
        "scene": {
            **SCENE,
            "illuminance_lx": e_lx,
            "estimator": "ridge on centred log band ratios, trained on "
            f"{ctx.table.n_lamps} scored library lamps x "
            f"{ctx.toa.shape[1]} scenes (preset 'search', no atmosphere)",
            "nir_policy": NIR_POLICY,
        },
        "lamps": rows,
        "notes": notes,
    }
    if args.json:
        json.dump(out, sys.stdout, indent=2)
        print()
        return 0
    print(f"bands: {name}; scene: {SCENE}")
    for r in rows:
        parts = []
        for m in METRICS:
            tv = r["true"][m]
            parts.append(
                f"{m} true {'n/a' if tv is None else f'{tv:.4g}'} "
                f"est {r['estimate'][m]:.4g}"
            )
        print(f"{r['file']}: " + "; ".join(parts))
    for n in notes:
        print(
            f"note: {n['file']} extended beyond {n['measured_to_nm']:g} nm as "
            f"{n['nir_extension']} (nearest library lamp {n['nearest_library_lamp']})"
        )
    return 0
