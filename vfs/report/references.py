"""Citations of the source papers in reports, with a link to docs/references.md.

Reports cite a paper by its short name (see ``docs/references.md``) and link the entry there.
The link points at the file in the source checkout the package runs from when it exists (so a
report opened from any output folder finds it), else at the repository-relative path.
"""

from __future__ import annotations

from pathlib import Path

#: Short names of the source papers by anchor in docs/references.md.
PAPERS: dict[str, str] = {
    "momentum-impact-model": "Momentum Based Impact Model paper",
    "collision-uncertainty": "Collision Calculation Uncertainty paper",
    "front-to-side-energy": "Front-to-Side Energy Balance paper",
    "reconstruction-chapter": "Reconstruction chapter",
    "head-on-collisions": "Modeling Head-On Collisions paper",
    "injury-risk": "injury-risk curves",
}


def references_url(anchor: str = "") -> str:
    """Link target of ``docs/references.md`` (optionally one entry)."""
    doc = Path(__file__).resolve().parents[2] / "docs" / "references.md"
    base = doc.as_uri() if doc.is_file() else "docs/references.md"
    return f"{base}#{anchor}" if anchor else base


def cite(anchor: str) -> str:
    """Markdown citation ``the <short name> ([references](url#anchor))`` of one paper."""
    return f"the {PAPERS[anchor]} ([docs/references.md]({references_url(anchor)}))"
