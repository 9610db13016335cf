"""HTML primitives of the report: tables, sections, the page. No JavaScript,
no external resources: the page is one file that opens anywhere."""

import base64
import html
import io
import re


CSS = """
body{font-family:system-ui,-apple-system,'Segoe UI',sans-serif;max-width:1200px;
margin:0 auto;padding:1em 2em;color:#1b1b1b;line-height:1.45}
h1{border-bottom:3px solid #234;padding-bottom:.2em}
h2{border-bottom:1px solid #aab;margin-top:2em}
table{border-collapse:collapse;margin:.6em 0 1em;font-size:.92em}
th,td{border:1px solid #ccd;padding:.25em .55em;text-align:right;vertical-align:top}
th{background:#eef1f6}
td:first-child,th:first-child{text-align:left}
caption{caption-side:top;text-align:left;font-weight:600;padding:.3em 0}
a.num{color:#063;text-decoration:none;border-bottom:1px dotted #063}
a.txt{color:inherit;text-decoration:none;border-bottom:1px dotted #888}
figure{margin:1em 0}
img{max-width:100%}
section{overflow-x:auto}
figcaption{font-size:.9em;color:#444}
.missing{background:#fff1f0;border:2px solid #c00;padding:.5em .8em;margin:.6em 0}
.ok{color:#063}
.note{font-size:.9em;color:#444}
nav ol{columns:2}
code{font-size:.92em}
@media (max-width:700px){body{padding:.5em .8em}nav ol{columns:1}
table{font-size:.8em}th,td{padding:.2em .35em}}
"""


def esc(text) -> str:
    return html.escape(str(text))


_DESIGN = re.compile(r"^n(\d+)\+pan a=([0-9.]+)$")

ALPHA_NOTE = (
    "α is the search's weight on lamp-type classification against "
    "estimation of LER, G and CCT (0: estimation only, 1: classification only)"
)
"""The legend of `design_name`'s α, for a section that shows design names."""


def design_name(label: str) -> str:
    """A search design's label in plain words, escaped: "n3+pan a=0.5" is
    "3 bands + pan (α = 0.5)", "n6+pan a=0" "6 bands + pan (α = 0)"; any
    other label (a reference sensor) as it is. The label itself is kept as
    the hover title, for finding it in the result files."""
    m = _DESIGN.match(str(label))
    if m is None:
        return esc(label)
    n, a = int(m.group(1)), float(m.group(2))
    word = "band" if n == 1 else "bands"
    return (
        f'<span title="{esc(label)}">{n} {word} + pan (α = {a:g})</span>'
    )


def table(header: list[str], rows: list[list[str]], *, caption: str = "",
          cls: str = "") -> str:
    """An HTML table; cells are inserted as given (already HTML)."""
    out = [f'<table class="{cls}">' if cls else "<table>"]
    if caption:
        out.append(f"<caption>{caption}</caption>")
    out.append("<thead><tr>" + "".join(f"<th>{h}</th>" for h in header)
               + "</tr></thead><tbody>")
    for r in rows:
        out.append("<tr>" + "".join(f"<td>{c}</td>" for c in r) + "</tr>")
    out.append("</tbody></table>")
    return "".join(out)


def section(sid: str, title: str, body: str) -> str:
    return f'<section id="{sid}"><h2>{esc(title)}</h2>{body}</section>'


def figure_png(fig, caption: str) -> str:
    """A matplotlib figure drawn by the report, embedded as PNG."""
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=90, bbox_inches="tight")
    data = base64.b64encode(buf.getvalue()).decode("ascii")
    return (
        f'<figure><img alt="{esc(caption)}" src="data:image/png;base64,{data}">'
        f"<figcaption>{esc(caption)}</figcaption></figure>"
    )


def page(title: str, sections: list[tuple[str, str, str]], *, header: str) -> str:
    """The whole document: title, header block, table of contents, sections
    `(id, title, html)`."""
    toc = "".join(f'<li><a href="#{sid}">{esc(t)}</a></li>' for sid, t, _ in sections)
    body = "".join(section(sid, t, h) for sid, t, h in sections)
    return (
        "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">"
        '<meta name="viewport" content="width=device-width, initial-scale=1">'
        f"<title>{esc(title)}</title><style>{CSS}</style></head><body>"
        f"<h1>{esc(title)}</h1>{header}<nav><h2>Contents</h2><ol>{toc}</ol></nav>"
        f"{body}</body></html>\n"
    )
