"""One renderer for every report: a list of blocks -> Markdown and standalone HTML.

A report is a sequence of frozen blocks (:class:`Heading`, :class:`Paragraph`,
:class:`Table`, :class:`Figure`, :class:`Note`, :class:`BulletList`,
:class:`Code`).  :func:`render_markdown` and :func:`render_html` turn the same
blocks into the two formats (one stylesheet, :data:`STYLESHEET`, for every
HTML report); :func:`write_report` writes both atomically through
:mod:`vfs.atomic`.

Text in paragraphs, list items, notes and table cells is plain text in which
`backticks` mark code; everything else is escaped for HTML.  Figures are
referenced by a path relative to the report (not embedded).

Example
-------
>>> blocks = [Heading("Result"), Paragraph("Speed in km/h."),
...           Table(("system", "avoided"), (("`ideal`", "40.0 % [31.2, 48.8]"),))]
>>> print(render_markdown(blocks))
# Result
<BLANKLINE>
Speed in km/h.
<BLANKLINE>
| system | avoided |
|---|---:|
| `ideal` | 40.0 % [31.2, 48.8] |
<BLANKLINE>
"""

from __future__ import annotations

import html
import math
import os
import re
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Literal
from urllib.parse import quote

import numpy as np

from vfs.atomic import write_text
from vfs.errors import ParameterError

if TYPE_CHECKING:  # pragma: no cover
    import pandas as pd

Align = Literal["left", "right", "center"]


@dataclass(frozen=True)
class Heading:
    """A section heading; ``level`` 1 (title) to 4."""

    text: str
    level: int = 1

    def __post_init__(self) -> None:
        if self.level not in (1, 2, 3, 4):
            raise ParameterError(f"heading level {self.level!r} must be 1, 2, 3 or 4")


@dataclass(frozen=True)
class Paragraph:
    """A paragraph of text (`backticks` mark code)."""

    text: str


@dataclass(frozen=True)
class Table:
    """A table of text cells.

    Attributes
    ----------
    columns : tuple of str
        Column headers.
    rows : tuple of tuple of str
        Cells, already formatted (units belong in the headers).
    align : tuple of {"left", "right", "center"}, optional
        Alignment per column; default: right for columns whose cells are all
        numbers, intervals or percentages (:func:`is_numeric_text`), else left.
    empty : str, optional
        Text shown instead of a table without rows; None shows nothing.
    cell_classes : tuple of tuple of str, optional
        A CSS class per cell (same shape as ``rows``; ``""`` for none), HTML
        only: :data:`STYLESHEET`'s ``band-green`` ... ``band-red`` colour a cell
        as a Euro NCAP result grid.

    Cells that hold a number, an interval (``1.2 [0.8, 1.6]``) or a short
    name without spaces (``three-stage``) never wrap in HTML.
    """

    columns: tuple[str, ...]
    rows: tuple[tuple[str, ...], ...]
    align: tuple[Align, ...] | None = None
    empty: str | None = None
    cell_classes: tuple[tuple[str, ...], ...] | None = None

    def __post_init__(self) -> None:
        width = len(self.columns)
        bad = [k for k, row in enumerate(self.rows) if len(row) != width]
        if bad:
            raise ParameterError(f"table rows {bad[:5]} do not have {width} cells")
        if self.cell_classes is not None and (
                len(self.cell_classes) != len(self.rows)
                or any(len(row) != width for row in self.cell_classes)):
            raise ParameterError("cell_classes must have the shape of the table's rows")
        if self.align is not None:
            if len(self.align) != width:
                raise ParameterError(f"align has {len(self.align)} entries for {width} columns")
            wrong = set(self.align) - {"left", "right", "center"}
            if wrong:
                raise ParameterError(f"unknown alignment {sorted(wrong)}; use left, right "
                                     "or center")

    @classmethod
    def from_frame(cls, df: pd.DataFrame, *, floatfmt: str | None = None,
                   align: Sequence[Align] | None = None, empty: str | None = None) -> Table:
        """A table from a DataFrame (its index is dropped: ``reset_index()`` first to keep it).

        Parameters
        ----------
        df : pandas.DataFrame
            Values; text cells are kept as they are.
        floatfmt : str, optional
            Format of float cells (e.g. ``"{:.3g}"``; non-finite floats become
            empty, booleans ``yes``/``no``); None: ``str(value)`` for every cell.
        align, empty
            As in :class:`Table`.
        """
        rows = tuple(tuple(format_cell(v, floatfmt) for v in row)
                     for row in df.itertuples(index=False))
        return cls(tuple(str(c) for c in df.columns), rows,
                   None if align is None else tuple(align), empty)

    def alignment(self) -> tuple[Align, ...]:
        """The alignment of each column (given, or guessed from the cells)."""
        if self.align is not None:
            return self.align
        out: list[Align] = []
        for k in range(len(self.columns)):
            cells = [row[k] for row in self.rows if row[k].strip() not in ("", "-")]
            out.append("right" if cells and all(is_numeric_text(c) for c in cells) else "left")
        return tuple(out)


@dataclass(frozen=True)
class Figure:
    """An image file (path relative to the report), its caption and alternative text."""

    path: str
    caption: str
    alt: str = ""

    @property
    def alt_text(self) -> str:
        """The alternative text (the caption unless given)."""
        return self.alt or self.caption


@dataclass(frozen=True)
class Note:
    """A highlighted remark; ``kind`` ``"note"`` or ``"warning"``."""

    text: str
    kind: Literal["note", "warning"] = "note"

    def __post_init__(self) -> None:
        if self.kind not in ("note", "warning"):
            raise ParameterError(f"note kind {self.kind!r} must be 'note' or 'warning'")


@dataclass(frozen=True)
class BulletList:
    """A list of text items (numbered when ``ordered``)."""

    items: tuple[str, ...]
    ordered: bool = False


@dataclass(frozen=True)
class Code:
    """A block of verbatim text (command lines, configuration)."""

    text: str
    language: str = ""


Block = Heading | Paragraph | Table | Figure | Note | BulletList | Code


@dataclass(frozen=True)
class Report:
    """A titled list of blocks (the title is the HTML page's ``<title>``)."""

    title: str
    blocks: tuple[Block, ...] = field(default_factory=tuple)


# ----------------------------------------------------------------------------
# Cells
# ----------------------------------------------------------------------------

_NUMERIC = re.compile(r"(?:[-+<>=~\s\d.,%\[\]()/:]|inf|nan|e(?=[-+]?\d)|\.\.)+")


def is_numeric_text(text: str) -> bool:
    """True for a number, percentage or interval written as text.

    Examples
    --------
    >>> [is_numeric_text(t) for t in ("12.5", "< 0.001", "40 % [31, 49]", "full")]
    [True, True, True, False]
    """
    t = text.strip()
    return bool(t) and any(ch.isdigit() for ch in t) and _NUMERIC.fullmatch(t) is not None


def format_cell(value: object, floatfmt: str | None = None) -> str:
    """One table cell as text (see :meth:`Table.from_frame`)."""
    if floatfmt is None:
        return str(value)
    if isinstance(value, bool | np.bool_):
        return "yes" if value else "no"
    if isinstance(value, float | np.floating):
        v = float(value)
        return "" if not math.isfinite(v) else floatfmt.format(v)
    return str(value)


# ----------------------------------------------------------------------------
# Markdown
# ----------------------------------------------------------------------------


def _md_cell(text: str) -> str:
    return str(text).replace("|", "\\|").replace("\n", " ")


def _md_link(path: str) -> str:
    return quote(path.replace(os.sep, "/"), safe="/:.-_~#?=&")


def _md_table(t: Table) -> str:
    rule = {"left": "---", "right": "---:", "center": ":---:"}
    lines = ["| " + " | ".join(_md_cell(c) for c in t.columns) + " |",
             "|" + "|".join(rule[a] for a in t.alignment()) + "|"]
    lines += ["| " + " | ".join(_md_cell(c) for c in row) + " |" for row in t.rows]
    return "\n".join(lines)


def render_markdown(blocks: Sequence[Block]) -> str:
    """The blocks as Markdown (GitHub flavour: pipe tables with alignment)."""
    out: list[str] = []
    for b in blocks:
        if isinstance(b, Heading):
            out.append("#" * b.level + " " + b.text)
        elif isinstance(b, Paragraph):
            out.append(b.text)
        elif isinstance(b, Table):
            if b.rows:
                out.append(_md_table(b))
            elif b.empty is not None:
                out.append(b.empty)
        elif isinstance(b, Figure):
            alt = b.alt_text.replace("[", "\\[").replace("]", "\\]")
            out.append(f"![{alt}]({_md_link(b.path)})\n\n*{b.caption}*")
        elif isinstance(b, Note):
            label = "Warning" if b.kind == "warning" else "Note"
            out.append("\n".join(f"> {line}" if line else ">" for line in
                                 f"**{label}:** {b.text}".splitlines()))
        elif isinstance(b, BulletList):
            out.append("\n".join((f"{k}. " if b.ordered else "- ") + item
                                 for k, item in enumerate(b.items, start=1)))
        elif isinstance(b, Code):
            fence = "````" if "```" in b.text else "```"
            out.append(f"{fence}{b.language}\n{b.text.rstrip()}\n{fence}")
        else:
            raise ParameterError(f"not a report block: {b!r}")
    return "\n\n".join(out) + "\n"


# ----------------------------------------------------------------------------
# HTML
# ----------------------------------------------------------------------------

#: The one stylesheet of every HTML report: readable line length, zebra
#: tables that scroll sideways rather than squeeze, figures at most the page
#: width, and a print layout without scrolling or page breaks inside figures.
STYLESHEET = """\
:root{--fg:#1d1d1f;--muted:#5b5b66;--rule:#d0d0d7;--head:#eef0f4;--zebra:#f7f8fa;
--accent:#1f4e9c;--warn:#b35900}
*{box-sizing:border-box}
body{font-family:system-ui,-apple-system,"Segoe UI",Roboto,"Helvetica Neue",Arial,sans-serif;
color:var(--fg);line-height:1.5;max-width:72rem;margin:2rem auto;padding:0 1.25rem;
font-size:15px}
h1{font-size:1.75rem;margin:0 0 1rem;border-bottom:2px solid var(--accent);
padding-bottom:.3rem}
h2{font-size:1.35rem;margin:2.2rem 0 .6rem;border-bottom:1px solid var(--rule);
padding-bottom:.2rem}
h3{font-size:1.1rem;margin:1.6rem 0 .5rem}
h4{font-size:1rem;margin:1.2rem 0 .4rem}
p,li{max-width:60rem}
code{font-family:ui-monospace,SFMono-Regular,Menlo,Consolas,monospace;font-size:.9em;
background:#f1f2f5;padding:.05em .3em;border-radius:3px}
pre{background:#f6f7f9;border:1px solid var(--rule);padding:.7rem 1rem;overflow-x:auto;
border-radius:4px}
pre code{background:none;padding:0}
.table-wrap{overflow-x:auto;margin:.8rem 0 1.2rem}
table{border-collapse:collapse;font-size:.85rem;font-variant-numeric:tabular-nums}
th,td{border:1px solid var(--rule);padding:.25rem .5rem;vertical-align:top}
th{background:var(--head);font-weight:600;text-align:left;vertical-align:bottom}
tbody tr:nth-child(even){background:var(--zebra)}
tbody tr:hover{background:#eaf0fb}
.r{text-align:right}.c{text-align:center}.l{text-align:left}
.nw{white-space:nowrap}
figure{margin:1.2rem 0 1.6rem}
figure img{max-width:100%;height:auto;display:block;border:1px solid #e4e4ea}
figcaption{color:var(--muted);font-size:.9rem;font-style:italic;margin-top:.35rem}
.note{border-left:4px solid var(--accent);background:#f0f4fb;padding:.5rem .9rem;
margin:1rem 0}
.note.warning{border-left-color:var(--warn);background:#fff5eb}
.empty{color:var(--muted);font-style:italic}
td.band-green{background:#009933;color:#fff}td.band-yellow{background:#ffdd33}
td.band-orange{background:#ff9933}td.band-brown{background:#964b00;color:#fff}
td.band-red{background:#ff3333;color:#fff}
@media print{
body{max-width:none;margin:0;font-size:10pt}
.table-wrap{overflow:visible}
table{font-size:8pt}
tbody tr:hover{background:inherit}
h1,h2,h3,h4{break-after:avoid}
figure,tr{break-inside:avoid}
a{color:inherit;text-decoration:none}
}
"""

_CI = re.compile(r"[\[(]\s*[-+\d.]+.*(?:,|\.\.)\s*[-+\d.]+.*[\])]")


_LINK = re.compile(r"\[([^\]\[]+)\]\(([^()\s]+)\)")


def inline_html(text: object) -> str:
    """Escape text for HTML, render `backtick` spans as ``<code>`` and ``[text](url)`` as links."""
    parts = html.escape(str(text)).split("`")
    if len(parts) % 2 == 0:  # an unpaired backtick stays a backtick
        parts[-2:] = [parts[-2] + "`" + parts[-1]]
    return "".join(f"<code>{p}</code>" if i % 2
                   else _LINK.sub(lambda m: f'<a href="{m.group(2)}">{m.group(1)}</a>', p)
                   for i, p in enumerate(parts))


def _html_table(t: Table) -> str:
    cls = {"left": "l", "right": "r", "center": "c"}
    align = t.alignment()
    head = "".join(f'<th class="{cls[a]}">{inline_html(c)}</th>'
                   for c, a in zip(t.columns, align, strict=True))
    body = []
    classes = t.cell_classes or tuple(("",) * len(t.columns) for _ in t.rows)
    for row, extra in zip(t.rows, classes, strict=True):
        cells = []
        for text, a, more in zip(row, align, extra, strict=True):
            c = cls[a] + (f" {more}" if more else "")
            if ((a == "right" and is_numeric_text(text)) or _CI.search(text)
                    or (len(text) <= 24 and " " not in text)):  # numbers, intervals, names
                c += " nw"
            cells.append(f'<td class="{c}">{inline_html(text)}</td>')
        body.append("<tr>" + "".join(cells) + "</tr>")
    return (f'<div class="table-wrap"><table>\n<thead><tr>{head}</tr></thead>\n<tbody>\n'
            + "\n".join(body) + "\n</tbody></table></div>")


def heading_anchor(text: str) -> str:
    """The anchor of a heading as GitHub makes it for Markdown (lower case, punctuation
    dropped, spaces to hyphens); the HTML renderer gives its headings the same ``id``.

    Examples
    --------
    >>> heading_anchor("Crashes avoided (per `system`)")
    'crashes-avoided-per-system'
    """
    text = re.sub(r"[`*]", "", text.strip().lower())
    return re.sub(r"[^\w\- ]", "", text).replace(" ", "-")


def _html_block(b: Block) -> str:
    if isinstance(b, Heading):
        return (f'<h{b.level} id="{heading_anchor(b.text)}">{inline_html(b.text)}'
                f"</h{b.level}>")
    if isinstance(b, Paragraph):
        return f"<p>{inline_html(b.text)}</p>"
    if isinstance(b, Table):
        if b.rows:
            return _html_table(b)
        return "" if b.empty is None else f'<p class="empty">{inline_html(b.empty)}</p>'
    if isinstance(b, Figure):
        src = html.escape(quote(b.path.replace(os.sep, "/"), safe="/:.-_~#?=&"), quote=True)
        return (f'<figure><img src="{src}" alt="{html.escape(b.alt_text, quote=True)}" '
                f'loading="lazy"><figcaption>{inline_html(b.caption)}</figcaption></figure>')
    if isinstance(b, Note):
        label = "Warning" if b.kind == "warning" else "Note"
        return (f'<div class="note {b.kind}"><strong>{label}:</strong> '
                f"{inline_html(b.text)}</div>")
    if isinstance(b, BulletList):
        tag = "ol" if b.ordered else "ul"
        return f"<{tag}>" + "".join(f"<li>{inline_html(i)}</li>" for i in b.items) + f"</{tag}>"
    if isinstance(b, Code):
        lang = f' class="language-{html.escape(b.language, quote=True)}"' if b.language else ""
        return f"<pre><code{lang}>{html.escape(b.text.rstrip())}</code></pre>"
    raise ParameterError(f"not a report block: {b!r}")


def render_html(blocks: Sequence[Block], title: str) -> str:
    """The blocks as one standalone HTML page with :data:`STYLESHEET` (figures linked)."""
    body = [s for s in (_html_block(b) for b in blocks) if s]
    return ("<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n"
            "<meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">\n"
            f"<title>{html.escape(title)}</title>\n<style>\n{STYLESHEET}</style>\n</head>\n"
            "<body>\n" + "\n".join(body) + "\n</body>\n</html>\n")


def write_report(folder: str | os.PathLike[str], report: Report, *, name: str = "report"
                 ) -> dict[str, Path]:
    """Write ``NAME.md`` and ``NAME.html`` into ``folder`` atomically.

    Returns
    -------
    dict of str to Path
        ``{"report_md": ..., "report_html": ...}``.
    """
    out = Path(folder)
    return {
        "report_md": write_text(out / f"{name}.md", render_markdown(report.blocks)),
        "report_html": write_text(out / f"{name}.html",
                                  render_html(report.blocks, report.title)),
    }


__all__ = [
    "STYLESHEET",
    "heading_anchor",
    "Align",
    "Block",
    "BulletList",
    "Code",
    "Figure",
    "Heading",
    "Note",
    "Paragraph",
    "Report",
    "Table",
    "format_cell",
    "inline_html",
    "is_numeric_text",
    "render_html",
    "render_markdown",
    "write_report",
]
