"""Generated parts of ``docs/data-format.md``: the schema tables and the PCM mapping.

The document holds hand-written prose and blocks between the markers
``<!-- BEGIN GENERATED <name> -->`` and ``<!-- END GENERATED <name> -->``
whose content is produced by :data:`GENERATED_BLOCKS`.  Regenerate with::

    python -m vfs.database.docs docs/data-format.md

and check (as the tests do) with ``--check``.
"""

from __future__ import annotations

import argparse
import re
import sys
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path

from vfs.database.pcm import pcm_mapping_markdown
from vfs.database.schema import schema_markdown

#: Block name -> function rendering its Markdown.
GENERATED_BLOCKS: dict[str, Callable[[], str]] = {
    "schema": schema_markdown,
    "pcm-mapping": pcm_mapping_markdown,
}

_BLOCK = re.compile(
    r"(<!-- BEGIN GENERATED (?P<name>[\w-]+)[^>]*-->\n)(?P<body>.*?)(<!-- END GENERATED "
    r"(?P=name) -->)",
    re.DOTALL,
)


def render_document(text: str, blocks: Mapping[str, Callable[[], str]] | None = None) -> str:
    """Replace the body of every generated block of ``text`` with fresh output.

    Parameters
    ----------
    text : str
        Markdown document with generated-block markers.
    blocks : mapping, optional
        Block name -> function rendering it (default :data:`GENERATED_BLOCKS`).

    Returns
    -------
    str
        The document with up-to-date generated blocks.

    Raises
    ------
    KeyError
        If a block names an unknown generator.
    """
    blocks = GENERATED_BLOCKS if blocks is None else blocks

    def replace(match: re.Match[str]) -> str:
        body = blocks[match.group("name")]()
        return match.group(1) + body + match.group(4)

    return _BLOCK.sub(replace, text)


def stale_blocks(path: str | Path, blocks: Mapping[str, Callable[[], str]] | None = None
                 ) -> list[str]:
    """Names of generated blocks of the document that differ from the schema (or are missing).

    Parameters
    ----------
    path : path
        The Markdown document.
    blocks : mapping, optional
        Block name -> function rendering it (default :data:`GENERATED_BLOCKS`); only
        those the document holds are compared when given.

    Returns
    -------
    list of str
        Empty if the document is in sync.
    """
    text = Path(path).read_text(encoding="utf-8")
    found = {m.group("name"): m.group("body") for m in _BLOCK.finditer(text)}
    if blocks is None:
        return [name for name, render in GENERATED_BLOCKS.items()
                if found.get(name) != render()]
    return [name for name, body in found.items() if body != blocks[name]()]


def main(argv: Sequence[str] | None = None) -> int:
    """Regenerate (or with ``--check`` verify) the generated blocks of a document."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("document", type=Path)
    parser.add_argument("--check", action="store_true", help="only report stale blocks")
    args = parser.parse_args(argv)
    if args.check:
        stale = stale_blocks(args.document)
        for name in stale:
            print(f"stale generated block: {name}")
        return 1 if stale else 0
    text = args.document.read_text(encoding="utf-8")
    args.document.write_text(render_document(text), encoding="utf-8")
    return 0


if __name__ == "__main__":
    sys.exit(main())
