"""A small static HTML gallery: sections with a paragraph, figures and tables.

Used by ``vergence demo`` (``DIR/index.html``). Every string is escaped; figure paths are relative
to the report so the folder can be moved or served as is.
"""

from __future__ import annotations

import html
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

__all__ = ["Figure", "Section", "render_report", "write_report"]


@dataclass(frozen=True, slots=True)
class Figure:
    """An image in the report: ``path`` relative to the report's folder, and a caption."""

    path: str
    caption: str


@dataclass(frozen=True, slots=True)
class Section:
    """One section: a title, one paragraph, optional figures and an optional table (first row = header)."""

    title: str
    text: str
    figures: tuple[Figure, ...] = ()
    table: tuple[tuple[str, ...], ...] = field(default=())


_STYLE = """
body { font-family: system-ui, sans-serif; max-width: 1100px; margin: 2em auto; padding: 0 1em;
       color: #222; line-height: 1.45; }
h1 { margin-bottom: 0.2em; } h2 { border-bottom: 1px solid #ccc; padding-bottom: 0.2em; margin-top: 2em; }
figure { display: inline-block; margin: 0.5em 1em 0.5em 0; vertical-align: top; max-width: 100%; }
figure img { max-width: 100%; border: 1px solid #ddd; }
figcaption { font-size: 0.9em; color: #555; max-width: 520px; }
table { border-collapse: collapse; margin: 0.8em 0; font-size: 0.92em; }
th, td { border: 1px solid #ccc; padding: 0.25em 0.6em; text-align: right; }
th { background: #f3f3f3; } td:first-child, th:first-child { text-align: left; }
"""


def render_report(*, title: str, intro: str, sections: Sequence[Section]) -> str:
    """The HTML text of a report (UTF-8, self-contained apart from the figure files)."""
    e = html.escape
    parts = [
        "<!DOCTYPE html>",
        '<html lang="en"><head><meta charset="utf-8">',
        f"<title>{e(title)}</title><style>{_STYLE}</style></head><body>",
        f"<h1>{e(title)}</h1>",
        f"<p>{e(intro)}</p>",
    ]
    for sec in sections:
        parts.append(f"<h2>{e(sec.title)}</h2>")
        parts.append(f"<p>{e(sec.text)}</p>")
        if sec.table:
            header, *rows = sec.table
            parts.append("<table><thead><tr>" + "".join(f"<th>{e(c)}</th>" for c in header) + "</tr></thead><tbody>")
            for row in rows:
                parts.append("<tr>" + "".join(f"<td>{e(c)}</td>" for c in row) + "</tr>")
            parts.append("</tbody></table>")
        for fig in sec.figures:
            parts.append(
                f'<figure><a href="{e(fig.path)}"><img src="{e(fig.path)}" alt="{e(fig.caption)}"></a>'
                f"<figcaption>{e(fig.caption)}</figcaption></figure>"
            )
    parts.append("</body></html>")
    return "\n".join(parts) + "\n"


def write_report(path: str | Path, *, title: str, intro: str, sections: Sequence[Section]) -> Path:
    """Write the report atomically to ``path`` and return it. Figures must already exist beside it."""
    from vergence.io import atomic_write

    path = Path(path)
    for sec in sections:
        for fig in sec.figures:
            if not (path.parent / fig.path).is_file():
                raise ValueError(f"report figure {fig.path} does not exist in {path.parent}")
    text = render_report(title=title, intro=intro, sections=sections)
    with atomic_write(path) as tmp:
        Path(tmp).write_text(text, encoding="utf-8")
    return path
