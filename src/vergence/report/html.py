"""A small static HTML gallery: sections with a paragraph, figures, grids of figures and tables.

Used by ``vergence demo`` (``DIR/index.html``). Every string is escaped; text between backticks
(```vergence demo```) becomes ``<code>``; figure paths are relative to the report so the folder can be
moved or served as is. A :class:`Grid` shows figures side by side (a view beside its truth), each with
its caption under it.
"""

from __future__ import annotations

import html
import re
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

__all__ = ["Figure", "Grid", "Section", "render_report", "write_report"]

# Columns a grid may have: one is a plain column, past four the figures are too small to compare on a
# laptop screen (1100 px of page / 4 = 275 px each).
_MAX_COLUMNS = 4


@dataclass(frozen=True, slots=True)
class Figure:
    """An image in the report: ``path`` relative to the report's folder, and a caption."""

    path: str
    caption: str


@dataclass(frozen=True, slots=True)
class Grid:
    """Figures side by side, ``columns`` to a row, each caption under its figure (for comparisons)."""

    figures: tuple[Figure, ...]
    columns: int = 2

    def __post_init__(self) -> None:
        object.__setattr__(self, "figures", tuple(self.figures))
        if not self.figures or not all(isinstance(f, Figure) for f in self.figures):
            raise ValueError("figures must be a non-empty sequence of Figure")
        if isinstance(self.columns, bool) or not isinstance(self.columns, int) or not 1 <= self.columns <= _MAX_COLUMNS:
            raise ValueError(f"columns must be an integer in [1, {_MAX_COLUMNS}]; got {self.columns!r}")


@dataclass(frozen=True, slots=True)
class Section:
    """One section: a title, one paragraph, optional figures or grids of figures, and an optional table
    (first row = header). The table comes right after the paragraph, the figures after it."""

    title: str
    text: str
    figures: tuple[Figure | Grid, ...] = ()
    table: tuple[tuple[str, ...], ...] = field(default=())

    def all_figures(self) -> tuple[Figure, ...]:
        """Every figure of the section, grids unrolled, in page order."""
        out: list[Figure] = []
        for item in self.figures:
            out.extend(item.figures if isinstance(item, Grid) else (item,))
        return tuple(out)


_STYLE = """
body { font-family: system-ui, sans-serif; max-width: 1100px; margin: 2em auto; padding: 0 1em;
       color: #222; line-height: 1.45; }
h1 { margin-bottom: 0.2em; } h2 { border-bottom: 1px solid #ccc; padding-bottom: 0.2em; margin-top: 2em; }
figure { display: inline-block; margin: 0.5em 1em 0.5em 0; vertical-align: top; max-width: 100%; }
figure img { max-width: 100%; border: 1px solid #ddd; }
figcaption { font-size: 0.9em; color: #555; max-width: 520px; }
.grid { display: grid; gap: 0.8em 1em; margin: 0.8em 0; align-items: start; }
.grid figure { margin: 0; display: block; }
.grid figure img { width: 100%; height: auto; }
.grid figcaption { max-width: none; }
code { font-family: ui-monospace, monospace; background: #f3f3f3; padding: 0 0.2em; border-radius: 3px; }
table { border-collapse: collapse; margin: 0.8em 0; font-size: 0.92em; }
th, td { border: 1px solid #ccc; padding: 0.25em 0.6em; text-align: right; }
th { background: #f3f3f3; } td:first-child, th:first-child { text-align: left; }
"""


def _text(text: str) -> str:
    """Escaped text with ```code``` spans as ``<code>`` (no literal backtick reaches the page)."""
    parts = re.split(r"`([^`]*)`", text)  # odd items were between backticks
    return "".join(f"<code>{html.escape(p)}</code>" if k % 2 else html.escape(p).replace("`", "")
                   for k, p in enumerate(parts))


def _figure(fig: Figure) -> str:
    e = html.escape
    alt = e(fig.caption.replace("`", ""))
    return (f'<figure><a href="{e(fig.path)}"><img src="{e(fig.path)}" alt="{alt}"></a>'
            f"<figcaption>{_text(fig.caption)}</figcaption></figure>")


def render_report(*, title: str, intro: str, sections: Sequence[Section]) -> str:
    """The HTML text of a report (UTF-8, self-contained apart from the figure files)."""
    e = html.escape
    parts = [
        "<!DOCTYPE html>",
        '<html lang="en"><head><meta charset="utf-8">',
        f"<title>{e(title.replace('`', ''))}</title><style>{_STYLE}</style></head><body>",
        f"<h1>{_text(title)}</h1>",
        f"<p>{_text(intro)}</p>",
    ]
    for sec in sections:
        parts.append(f"<h2>{_text(sec.title)}</h2>")
        parts.append(f"<p>{_text(sec.text)}</p>")
        if sec.table:
            header, *rows = sec.table
            parts.append("<table><thead><tr>" + "".join(f"<th>{_text(c)}</th>" for c in header) + "</tr></thead><tbody>")
            for row in rows:
                parts.append("<tr>" + "".join(f"<td>{_text(c)}</td>" for c in row) + "</tr>")
            parts.append("</tbody></table>")
        for item in sec.figures:
            if isinstance(item, Grid):
                parts.append(f'<div class="grid" style="grid-template-columns: repeat({item.columns}, minmax(0, 1fr))">')
                parts.extend(_figure(fig) for fig in item.figures)
                parts.append("</div>")
            else:
                parts.append(_figure(item))
    parts.append("</body></html>")
    return "\n".join(parts) + "\n"


def write_report(path: str | Path, *, title: str, intro: str, sections: Sequence[Section]) -> Path:
    """Write the report atomically to ``path`` and return it. Figures must already exist beside it."""
    from vergence.io import atomic_write

    path = Path(path)
    for sec in sections:
        for fig in sec.all_figures():
            if not (path.parent / fig.path).is_file():
                raise ValueError(f"report figure {fig.path} does not exist in {path.parent}")
    text = render_report(title=title, intro=intro, sections=sections)
    with atomic_write(path) as tmp:
        Path(tmp).write_text(text, encoding="utf-8")
    return path
