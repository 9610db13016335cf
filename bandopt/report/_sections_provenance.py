"""The report's closing sections: provenance (which code, packages and data
made each results folder; the modelled rather than measured inputs) and the
consistency checks run before the build.

`provenance` also records in `Ctx.stale` the folders made with older data
than the newest result, which `missing_summary` lists at the top.
"""

from ._experiments import EXPERIMENTS, Ctx
from ._html import esc, table
from ._source import missing_box, pointer


def provenance(ctx: Ctx) -> str:
    src = ctx.src
    rows, pk_rows, data_rows = [], {}, {}
    folders = sorted({e.marker.split("/")[0] for e in EXPERIMENTS})
    lib_info = None
    for folder in folders:
        man = f"{folder}/manifest.json"
        if not src.exists(man):
            rows.append([esc(folder), "<strong>no manifest</strong>", "", "", ""])
            continue
        m = src.load(man)
        rows.append([
            esc(folder), src.text(man, "/git_commit"),
            esc(m.get("git_dirty")), src.text(man, "/created_utc"),
            esc(m.get("python", "")),
        ])
        for k, v in (m.get("packages") or {}).items():
            pk_rows.setdefault(k, {})[folder] = v
        for k, v in (m.get("data_versions") or {}).items():
            data_rows.setdefault(k, {})[folder] = v
        if m.get("lamp_library") and (
            lib_info is None or m.get("created_utc", "") > lib_info[1].get(
                "created_utc", "")
        ):
            lib_info = (man, m)
    newest = max(
        (src.load(f"{f}/manifest.json") for f in folders
         if src.exists(f"{f}/manifest.json")),
        key=lambda m: m.get("created_utc", ""), default=None,
    )
    stale = {}
    if newest is not None:
        for f in folders:
            if not src.exists(f"{f}/manifest.json"):
                continue
            dv = src.load(f"{f}/manifest.json").get("data_versions") or {}
            diff = sorted(k for k, v in (newest.get("data_versions") or {}).items()
                          if dv.get(k) != v)
            if diff:
                stale[f] = diff
    ctx.stale = stale
    for r in rows:
        folder = r[0]
        r.append(esc(", ".join(stale.get(folder, []))) or "")
    out = [
        table(["results folder", "git commit", "dirty tree", "created (UTC)", "python",
               "data sets differing from the newest result"],
              rows, caption="Which code and data made each result (a result made "
              "with other data than the newest one is older than that data: "
              "re-run it to compare like with like)"),
        table(["package"] + [esc(f) for f in folders],
              [[esc(k)] + [esc(v.get(f, "")) for f in folders]
               for k, v in sorted(pk_rows.items())],
              caption="Package versions per results folder"),
        table(["data set (content hash)"] + [esc(f) for f in folders],
              [[esc(k)] + [esc(v.get(f, "")) for f in folders]
               for k, v in sorted(data_rows.items())],
              caption="Data versions per results folder (a blank: the data set "
              "did not exist when that result was made)"),
    ]
    out.append("<h3>Modelled rather than measured inputs</h3>")
    if lib_info is None:
        out.append(missing_box("a manifest with lamp-library provenance",
                               "re-run any experiment"))
    else:
        man, m = lib_info
        lib = m["lamp_library"]
        out.append(
            f"<p>Near-infrared extension ({src.link(man)}): "
            f"{src.text(man, '/lamp_library/nir_extension')}. "
            f"{src.num(man, '/lamp_library/extended_spectra')} of "
            f"{src.num(man, '/lamp_library/spectra')} library spectra are measured "
            "only to about 780 nm and extended to 900 nm by a model; "
            f"{len(lib.get('extended_unvalidated', []))} of them belong to a "
            "technology whose extension could not be validated (no second "
            "measured lamp):</p><p><code>"
            + esc(", ".join(lib.get("extended_unvalidated", []))) + "</code></p>"
        )
        if lib.get("extended"):
            out.append("<p>Every extended lamp: <code>"
                       + esc(", ".join(lib["extended"])) + "</code></p>")
        else:
            out.append(
                '<p class="note">This manifest predates the per-lamp list of '
                "extended spectra (<code>lamp_library/extended</code>); results "
                "re-run since then record it.</p>"
            )
    if ctx.ran("library"):
        N = "library/nir_validation.json"
        rows = []
        for cls, v in src.get(N, "/per_class").items():
            p = pointer("per_class", cls)
            err = v.get("bands", {}).get("780-900", {})
            key = next((k for k in err if "median" in k), None)
            rows.append([
                esc(cls), src.num(N, p + "/lamps_validated"),
                esc(v.get("extension_validated")),
                src.num(N, p + pointer("bands", "780-900", key), digits=2)
                if key else esc(v.get("note", "n/a")),
            ])
        out.append(table(
            ["class", "lamps validated (leave-one-out)", "extension validated",
             "median |relative error| of the 780-900 nm power"],
            rows, caption="NIR extension, leave-one-out validation",
        ))
        out.append(src.image("library/nir_validation.png", "NIR extension validation",
                             width="80%"))
    else:
        out.append(ctx.need("library"))
    return "".join(out)


def consistency(ctx: Ctx, messages: list[str], checks: tuple) -> str:
    items = "".join(f"<li><code>{esc(c.__name__)}</code>: {esc(c.__doc__ or '')}"
                    "</li>" for c in checks)
    verdict = (
        '<p class="ok">All agree (0 disagreements).</p>' if not messages
        else missing_box(
            f"{len(messages)} disagreements (built without the check, for tests "
            "only)", "<ul>" + "".join(f"<li>{esc(m)}</li>" for m in messages)
            + "</ul>")
    )
    return (
        "<p>Every number quoted in two results files was compared before this "
        "report was built; a disagreement stops the build. Checks run:</p>"
        f"<ul>{items}</ul>{verdict}"
    )
