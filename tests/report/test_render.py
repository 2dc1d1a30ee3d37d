"""The report renderer (blocks -> Markdown / HTML) and the figure helper."""

from __future__ import annotations

import html.parser
import os
import stat
import subprocess
import sys

import numpy as np
import pandas as pd
import pytest

from vfs.errors import ParameterError
from vfs.report.render import (
    BulletList,
    Code,
    Figure,
    Heading,
    Note,
    Paragraph,
    Report,
    Table,
    is_numeric_text,
    render_html,
    render_markdown,
    write_report,
)

HOSTILE = '<script>alert("x")</script> & \'q\''


class _Collect(html.parser.HTMLParser):
    """Tags and text of a page, to check what a browser would see."""

    def __init__(self) -> None:
        super().__init__()
        self.tags: list[str] = []
        self.text: list[str] = []
        self.attrs: list[tuple[str, str | None]] = []

    def handle_starttag(self, tag: str, attrs: list[tuple[str, str | None]]) -> None:
        self.tags.append(tag)
        self.attrs += attrs

    def handle_data(self, data: str) -> None:
        self.text.append(data)


def _parse(page: str) -> _Collect:
    p = _Collect()
    p.feed(page)
    return p


def test_html_escapes_every_text_and_attribute() -> None:
    blocks = [Heading(HOSTILE), Paragraph(HOSTILE), BulletList((HOSTILE,)), Note(HOSTILE),
              Table(("a",), ((HOSTILE,),)), Figure(f"fig {HOSTILE}.png", HOSTILE), Code(HOSTILE)]
    page = _parse(render_html(blocks, title=HOSTILE))
    assert "script" not in page.tags  # nothing became markup
    assert sum(HOSTILE in t for t in page.text) >= 6  # the text survives, unescaped by the parser
    alt = dict(page.attrs)["alt"]
    assert alt == HOSTILE


def test_backticks_become_code_and_an_unpaired_backtick_stays() -> None:
    page = render_html([Paragraph("use `vfs study` now"), Paragraph("a ` b")], "t")
    assert "<code>vfs study</code>" in page
    assert "a ` b" in page


def test_table_alignment_and_intervals_that_never_wrap() -> None:
    t = Table(("system", "avoided", "p"),
              (("ideal", "40.0 % [31.2 %, 48.8 %]", "< 0.001"),
               ("three-stage", "-", "0.25")))
    assert t.alignment() == ("left", "right", "right")
    md = render_markdown([t])
    assert "|---|---:|---:|" in md
    page = render_html([t], "t")
    assert '<td class="r nw">40.0 % [31.2 %, 48.8 %]</td>' in page
    assert '<td class="l nw">three-stage</td>' in page
    assert "tbody tr:nth-child(even)" in page and "white-space:nowrap" in page


@pytest.mark.parametrize(("text", "numeric"), [
    ("12", True), ("-3.5e-4", True), ("1.2 [0.8, 1.6]", True), ("0.7 .. 7.2", True),
    ("< 0.001", True), ("inf", False), ("full", False), ("3 km/h", False), ("", False),
])
def test_numeric_text(text: str, numeric: bool) -> None:
    assert is_numeric_text(text) is numeric


def test_markdown_escapes_pipes_and_renders_every_block() -> None:
    md = render_markdown([
        Heading("T", 2), Table(("a|b",), (("x|y",),)), Table(("a",), (), empty="(no rows)"),
        Table(("a",), ()), Figure("figures/f 1.png", "cap [1]"), Note("careful", "warning"),
        BulletList(("one", "two"), ordered=True), Code("x = 1", "python")])
    assert "## T" in md
    assert "| a\\|b |" in md and "| x\\|y |" in md
    assert md.count("(no rows)") == 1
    assert "![cap \\[1\\]](figures/f%201.png)" in md and "*cap [1]*" in md
    assert "> **Warning:** careful" in md
    assert "1. one\n2. two" in md
    assert "```python\nx = 1\n```" in md


def test_from_frame_formats_floats_and_booleans() -> None:
    df = pd.DataFrame({"x": [1.23456, np.nan], "ok": [True, False], "n": [3, 4]})
    t = Table.from_frame(df, floatfmt="{:.3g}")
    assert t.rows == (("1.23", "yes", "3"), ("", "no", "4"))
    assert Table.from_frame(df).rows[0][0] == "1.23456"


def test_bad_blocks_are_refused() -> None:
    with pytest.raises(ParameterError):
        Table(("a", "b"), (("1",),))
    with pytest.raises(ParameterError):
        Table(("a",), (("1",),), align=("middle",))  # type: ignore[arg-type]
    with pytest.raises(ParameterError):
        Heading("x", 7)
    with pytest.raises(ParameterError):
        render_markdown(["not a block"])  # type: ignore[list-item]


def test_write_report_writes_both_files(tmp_path) -> None:
    files = write_report(tmp_path / "r", Report("Title", (Paragraph("hello"),)))
    assert files["report_md"].read_text() == "hello\n"
    page = files["report_html"].read_text()
    assert page.startswith("<!DOCTYPE html>") and "<title>Title</title>" in page
    assert not [p for p in (tmp_path / "r").iterdir() if p.name.startswith(".")]  # no temp left
    umask = os.umask(0)
    os.umask(umask)
    assert stat.S_IMODE(files["report_html"].stat().st_mode) == 0o666 & ~umask  # as open()


def test_figure_helper_leaves_the_global_backend_alone(tmp_path) -> None:
    code = (
        "import matplotlib, sys\n"
        "matplotlib.use('svg')\n"
        "from vfs.report.figures import new_figure, save_figure\n"
        "fig = new_figure((3, 2))\n"
        "ax = fig.subplots()\n"
        "ax.plot([0, 1], [0, 1])\n"
        f"save_figure(fig, r'{tmp_path / 'f.png'}', tight=True)\n"
        "assert matplotlib.get_backend() == 'svg', matplotlib.get_backend()\n"
        "assert 'matplotlib.pyplot' not in sys.modules\n"
    )
    subprocess.run([sys.executable, "-c", code], check=True)
    assert (tmp_path / "f.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_cell_classes_colour_html_cells_and_must_match_the_rows() -> None:
    from vfs.report.render import Table, render_html, render_markdown

    t = Table(("VUT km/h", "IL 50 %"), (("30", "0.0 green"), ("40", "12.0 red")),
              cell_classes=(("", "band-green"), ("", "band-red")))
    html_text = render_html([t], "grid")
    assert 'band-green">0.0 green</td>' in html_text
    assert "band-red" in html_text and "td.band-red{" in html_text
    assert "band-" not in render_markdown([t])  # markdown keeps the text only
    with pytest.raises(ParameterError):
        Table(("a",), (("1",),), cell_classes=(("x", "y"),))
