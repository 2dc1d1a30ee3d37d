"""--figure-format and --dpi: vector output beside every PNG, resolution as asked."""

from __future__ import annotations

import xml.etree.ElementTree as ET

import pytest
from PIL import Image

from vfs.cli import main
from vfs.errors import ParameterError
from vfs.report.figures import figure_options, new_figure, save_figure


def _figure():
    fig = new_figure((4.0, 3.0))
    ax = fig.add_subplot()
    ax.plot([0, 1, 2], [0, 1, 4])
    return fig


def test_formats_are_written_and_parse(tmp_path):
    with figure_options("png,svg,pdf", dpi=50):
        save_figure(_figure(), tmp_path / "f.png")
    root = ET.parse(tmp_path / "f.svg").getroot()
    assert root.tag.endswith("svg")
    pdf = (tmp_path / "f.pdf").read_bytes()
    assert pdf.startswith(b"%PDF-") and pdf.rstrip().endswith(b"%%EOF")
    # 4 x 3 inch at 50 dpi
    with Image.open(tmp_path / "f.png") as im:
        assert im.size == (200, 150)


def test_dpi_scales_the_png_and_outside_the_context_nothing_changes(tmp_path):
    with figure_options("png", dpi=100):
        save_figure(_figure(), tmp_path / "a.png")
    save_figure(_figure(), tmp_path / "b.png", dpi=200)
    with Image.open(tmp_path / "a.png") as a, Image.open(tmp_path / "b.png") as b:
        assert a.size == (400, 300) and b.size == (800, 600)
    assert not (tmp_path / "b.svg").exists()
    with pytest.raises(ParameterError, match="unknown"):
        with figure_options("png,jpg"):
            pass
    with pytest.raises(ParameterError, match="dpi"):
        with figure_options("png", dpi=5):
            pass


def test_every_drawing_command_takes_the_options(tmp_path):
    out = tmp_path / "case.png"
    assert main(["run-case", "--db", "default", "--plot", str(out), "--figure-format",
                 "svg,pdf", "--dpi", "60"]) == 0
    assert out.exists() and out.with_suffix(".svg").exists() and out.with_suffix(".pdf").exists()
    from vfs.cli import build_parser

    parser = build_parser()
    helps = []
    sub = next(a for a in parser._actions if a.__class__.__name__ == "_SubParsersAction")
    for name, p in sub.choices.items():
        helps.append((name, p.format_help()))
        for a in p._actions:
            if a.__class__.__name__ == "_SubParsersAction":
                helps += [(n, q.format_help()) for n, q in a.choices.items()]
    drawn = {n for n, h in helps if "--figure-format" in h}
    # declared by each command (vfs.cli.common.add_figure_options), not by a list of names
    assert drawn == {"run-case", "compare", "diagnose", "calibrate", "ledger", "effectiveness",
                     "uncertainty", "sensitivity", "reconstruct", "evaluate-policy"}
    assert drawn == {n for n, h in helps if "--dpi" in h}
    assert {"compare", "effectiveness", "run-case", "diagnose"} <= drawn
