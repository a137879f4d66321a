"""Small HTML pieces for the report: one self-contained page, inline CSS, no scripts, every
other file referenced by a relative path (so the folder opens offline in any browser)."""

from __future__ import annotations

import html
import math
from collections.abc import Iterable, Sequence

CSS = """
body { font: 15px/1.45 system-ui, -apple-system, "Segoe UI", sans-serif; color: #222;
       max-width: 1250px; margin: 0 auto; padding: 0 1.2em 3em; }
h1 { font-size: 1.6em; margin: 1em 0 .2em; } h2 { margin-top: 2em; border-bottom: 2px solid #ccc; }
h3 { margin-top: 1.5em; } .muted { color: #666; } nav a { margin-right: 1em; }
table { border-collapse: collapse; margin: .6em 0 1em; font-variant-numeric: tabular-nums; }
th, td { padding: .18em .6em; border-bottom: 1px solid #e3e3e3; text-align: right; }
th:first-child, td:first-child { text-align: left; } thead th { border-bottom: 2px solid #aaa; }
tr.theory td { color: #1f4e79; } tr.sub td { color: #777; font-size: .9em; }
td.undefined { color: #b00020; cursor: help; text-decoration: underline dotted; }
figure { margin: 1em 0 1.6em; } figure img { max-width: 100%; border: 1px solid #ddd; }
figcaption { color: #555; font-size: .92em; } pre { background: #f6f6f6; padding: .8em;
overflow-x: auto; font-size: .85em; } .note { background: #fff7e0; border-left: 4px solid #e6ab02;
padding: .4em .8em; margin: .6em 0; } dl { display: grid; grid-template-columns: 14em 1fr;
gap: .15em 1em; } dt { color: #555; } dd { margin: 0; } audio { display: block; margin: .3em 0; }
"""


def esc(text: object) -> str:
    return html.escape(str(text), quote=True)


def number(value: float | None, digits: int = 2) -> str:
    if value is None or (isinstance(value, float) and not math.isfinite(value)):
        return "–"
    return f"{value:.{digits}f}"


def page(title: str, body: str) -> str:
    return (f'<!DOCTYPE html>\n<html lang="en">\n<head>\n<meta charset="utf-8">\n'
            f'<meta name="viewport" content="width=device-width, initial-scale=1">\n'
            f"<title>{esc(title)}</title>\n<style>{CSS}</style>\n</head>\n<body>\n{body}\n"
            "</body>\n</html>\n")


def undefined(text: str, reason: str) -> tuple[str, str]:
    """A table cell for a value that is undefined: shows ``text``, the reason on hover."""
    return (text, reason)


def _cell(c) -> str:
    if isinstance(c, tuple):  # (text, reason): an undefined value, see ``undefined``
        return f'<td class="undefined" title="{esc(c[1])}">{esc(c[0])}</td>'
    return f"<td>{esc(c)}</td>"


def table(header: Sequence[str], rows: Iterable[tuple[str, Sequence[str]]] | Iterable[Sequence[str]],
          *, classes: Sequence[str] | None = None) -> str:
    """A table; each row is a sequence of already formatted cells (escaped here); a cell may
    be ``undefined(text, reason)``, shown with its reason on hover."""
    out = ["<table>", "<thead><tr>" + "".join(f"<th>{esc(h)}</th>" for h in header)
           + "</tr></thead>", "<tbody>"]
    for i, row in enumerate(rows):
        cls = f' class="{classes[i]}"' if classes and classes[i] else ""
        out.append(f"<tr{cls}>" + "".join(_cell(c) for c in row) + "</tr>")
    out.append("</tbody></table>")
    return "\n".join(out)


def figure(src: str, caption: str, alt: str | None = None) -> str:
    return (f'<figure><img src="{esc(src)}" alt="{esc(alt or caption)}" loading="lazy">'
            f"<figcaption>{esc(caption)}</figcaption></figure>")


def image_map(src: str, caption: str, name: str, areas: Sequence[dict]) -> str:
    """A figure whose boxes show a text on hover: areas = [{'box_px': (x0, y0, x1, y1),
    'title': text}] in the image's pixels from its top left (e.g. undefined map cells)."""
    if not areas:
        return figure(src, caption)
    spots = "".join(f'<area shape="rect" coords="{",".join(str(int(c)) for c in a["box_px"])}" '
                    f'title="{esc(a["title"])}" alt="{esc(a["title"])}">' for a in areas)
    return (f'<figure><img src="{esc(src)}" alt="{esc(caption)}" usemap="#{esc(name)}">'
            f'<map name="{esc(name)}">{spots}</map><figcaption>{esc(caption)}</figcaption></figure>')


def audio(src: str, caption: str) -> str:
    return (f'<div><span>{esc(caption)}</span> <a href="{esc(src)}">(file)</a>'
            f'<audio controls preload="none" src="{esc(src)}"></audio></div>')


def note(text: str) -> str:
    return f'<p class="note">{esc(text)}</p>'


def definitions(items: Iterable[tuple[str, str]]) -> str:
    return "<dl>" + "".join(f"<dt>{esc(k)}</dt><dd>{esc(v)}</dd>" for k, v in items) + "</dl>"
