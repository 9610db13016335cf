"""The conditions line at the top of a report section: the scenes (lamps,
surfaces, atmospheres, Moon, lighting classes), the noise and measurement
effects, and the estimator each number of the section comes from, read from
the result's own files so that two sections on different footings say so.
"""

from ._html import esc
from ._source import Sources


def _paragraph(items: list[str]) -> str:
    return (
        '<p class="conditions"><strong>Conditions.</strong> '
        + "; ".join(items)
        + ".</p>"
    )


def _moons(moons) -> str:
    states = [m for m in moons if m is not None]
    if not states:
        return "no Moon"
    return "Moon " + ", ".join(
        ["none"] * (len(states) < len(moons)) + [str(m) for m in states]
    )


def _atmospheres(atm) -> str:
    if isinstance(atm, str):
        return f"atmospheres: {atm}"
    return "atmospheres " + ", ".join(f"{p} / {a} / {v:g} km" for p, a, v in atm)


def search_context(
    src: Sources, rel: str, ptr: str = "/context", *, estimator: str = ""
) -> str:
    """Conditions of a result made on a band-search context (`compare.json`
    "context": preset, scenarios, noise, lamps and scenes per lamp)."""
    ctx = src.get(rel, ptr)
    sc = ctx["scenarios"]
    pert = ctx.get("perturbations")
    items = [
        src.num(rel, ptr + "/n_lamps")
        + " measured lamps, "
        + src.num(rel, ptr + "/scenes_per_lamp")
        + " scenes each (preset "
        + src.text(rel, ptr + "/preset")
        + ")",
        "surfaces " + esc(", ".join(sc["surfaces"])),
        esc(_atmospheres(sc["atmospheres"])),
        esc(_moons(sc["moons"])),
        "lighting class " + esc(", ".join(sc["classes"])),
        "noise " + src.text(rel, ptr + "/noise"),
        "measurement effects: " + (esc(str(pert)) if pert else "none (clean spectra)"),
    ]
    if estimator:
        items.append("estimator: " + estimator)
    return _paragraph(items)


def robustness(src: Sources, rel: str = "robustness/summary.json") -> str:
    """Conditions of the robustness suite (and of the verdict read from it):
    the band search's scenes, the Moon told, its rows of measurement effects,
    lamp partitions, the shipped estimator."""
    rows = src.load(rel)["perturbations"]
    items = [
        "the band search's scenes (preset search), held-out measured lamps over "
        + src.num(rel, "/partitions")
        + " lamp partitions",
        "rows: " + esc(", ".join(rows)),
        "estimator: <code>bandopt evaluate</code>'s inversion, surface unknown, "
        "Moon told, fitted per partition on the training lamps",
    ]
    return _paragraph(items)


def radiometry(src: Sources, rel: str = "radiometry/summary.json") -> str:
    """Conditions of the radiometry: the distribution set's lamps, surfaces,
    atmospheres, Moon states and lighting classes, the sensor."""
    cfg = src.get(rel, "/config")
    items = [
        src.num(rel, "/scenario_shape/0") + " lamps",
        "surfaces " + esc(", ".join(cfg["surfaces"])),
        "atmospheres " + src.text(rel, "/atmospheres"),
        esc(_moons(cfg["moons"])),
        "lighting classes " + esc(", ".join(cfg["classes"])),
        "fires at "
        + esc(", ".join(f"{t:g}" for t in cfg["fire_temperatures_k"]))
        + " K",
        "sensor: thesis Table 2.3 (the verdict lists its parameters), photon noise",
    ]
    return _paragraph(items)


def spatial(src: Sources, rel: str = "spatial/summary.json") -> str:
    """Conditions of the GSD study: lamp, lighting class, bands, atmosphere,
    Moon, sensor, phases."""
    cfg = src.get(rel, "/config")
    atm = cfg.get("atmosphere")
    items = [
        "lamp "
        + src.text(rel, "/config/lamp")
        + " lit to class "
        + src.text(rel, "/config/lighting_class"),
        "bands " + src.text(rel, "/config/bands"),
        esc(_atmospheres([atm]) if atm else "no atmosphere"),
        esc(_moons([cfg.get("moon")])),
        src.num(rel, "/config/n_phases") + " sub-pixel phases per GSD",
        "sensor and detector: " + esc("; ".join(src.get(rel, "/assumptions")[2:4])),
    ]
    return _paragraph(items)


def classification(src: Sources, rel: str = "classify/summary.json") -> str:
    """Conditions of the classification study: its evaluation scenes and
    its own band search."""
    sc = src.get(rel, "/scenarios/evaluation")
    items = [
        "surfaces " + esc(", ".join(sc["surfaces"])),
        esc(_atmospheres(sc["atmospheres"])),
        esc(_moons(sc["moons"])),
        "lighting classes " + esc(", ".join(sc["classes"])),
        "one-vs-all k-nearest neighbours on lamp-grouped nested folds, on the "
        "study's own band search (not the recommended bands)",
    ]
    return _paragraph(items)
