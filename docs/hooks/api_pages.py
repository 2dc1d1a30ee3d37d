"""mkdocs hook: pages generated at build time from the repository.

The API reference: one page per subpackage of ``vfs``.  Each page holds one ``::: module``
directive (mkdocstrings) per public module of the subpackage, found by walking the source tree,
so that the reference follows the code when a module is added, moved or removed.
The pages are appended to the navigation under "API reference".

The repository's own READMEs outside ``docs/`` (``adas/``, ``scenarios/``, ``results/``) and the
changelog become pages too, so that the guides' links to them (``../adas/README.md``) resolve on
the site as they do on the repository.  The home page is README.md itself (one text for the
repository and the site), its links rewritten for the site.
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

from mkdocs.structure.files import File, Files

ROOT = Path(__file__).resolve().parents[2]
PACKAGE = ROOT / "vfs"


def _public(path: Path) -> bool:
    return not any(part.startswith("_") and part != "__init__.py" for part in path.parts)


def _groups() -> dict[str, list[str]]:
    """Page name -> dotted module names (top-level modules go to the page ``vfs``)."""
    groups: dict[str, list[str]] = {"vfs": ["vfs"]}
    for path in sorted(PACKAGE.rglob("*.py")):
        rel = path.relative_to(ROOT).with_suffix("")
        if not _public(rel) or "data" in rel.parts[1:2]:
            continue
        parts = list(rel.parts)
        if parts[-1] == "__init__":
            parts = parts[:-1]
        dotted = ".".join(parts)
        if dotted == "vfs":
            continue
        page = "vfs" if len(parts) == 2 and path.name != "__init__.py" else ".".join(parts[:2])
        groups.setdefault(page, []).append(dotted)
    return groups


def _page(name: str, modules: list[str]) -> str:
    lines = [f"# `{name}`", ""]
    if name == "vfs":
        lines += ["The top-level package (its entry points are listed on "
                  "[the Python API page](../api.md)) and the single-module layers.", ""]
    for module in modules:
        lines += [f"::: {module}", "    options:", "      show_submodules: false",
                  "      members_order: source", ""]
    return "\n".join(lines)


#: Repository file -> (site page, title in the navigation).
REPO_PAGES = {
    "adas/README.md": ("repository/adas.md", "AEB definition files (adas/)"),
    "scenarios/README.md": ("repository/scenarios.md", "Scenario catalogue (scenarios/)"),
    "results/README.md": ("repository/results.md", "Output folders (results/)"),
    "CHANGELOG.md": ("repository/changelog.md", "Changelog"),
}


def _home_page() -> str:
    """README.md with its links rewritten for the site (docs/x.md -> x.md)."""
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    pages = {source: page for source, (page, _title) in REPO_PAGES.items()}

    def link(match: re.Match[str]) -> str:
        label, target = match.group(1), match.group(2)
        path, _, anchor = target.partition("#")
        if "://" in target:
            return match.group(0)
        if path.startswith("docs/"):
            return f"[{label}]({target[len('docs/'):]})"
        if path in pages:
            return f"[{label}]({pages[path]}{'#' + anchor if anchor else ''})"
        if label == path:
            return f"`{path}`"
        return label if label.startswith("`") else f"{label} (`{path}`)"

    return re.sub(r"(?<!!)\[([^\]]+)\]\(([^)\s]+)\)", link,
                  text.replace("](docs/figures/", "](figures/")
                  .replace('src="docs/figures/', 'src="figures/'))


def on_config(config: Any) -> Any:
    """Append the API reference and the repository pages to the navigation."""
    pages = [{name: f"reference/{name}.md"} for name in _groups()]
    config["nav"].append({"API reference": pages})
    config["nav"].append({"Repository": [{title: page} for page, title in REPO_PAGES.values()]})
    return config


def on_files(files: Files, config: Any) -> Files:
    """Add the generated pages: the home page, the API reference, the repository pages."""
    files.append(File.generated(config, "index.md", content=_home_page()))
    for name, modules in _groups().items():
        files.append(File.generated(config, f"reference/{name}.md", content=_page(name, modules)))
    for source, (page, _title) in REPO_PAGES.items():
        text = (ROOT / source).read_text(encoding="utf-8")
        # links from the repository file into docs/ become links between site pages
        text = text.replace("](../docs/", "](../").replace("](docs/", "](../")
        files.append(File.generated(config, page, content=text))
    return files


#: Sphinx roles in the docstrings (``:func:`x```), rendered by mkdocstrings as the role's name
#: in front of the code span: the name is dropped, the code span stays.
_ROLE = re.compile(r":(?:class|func|meth|mod|data|attr|exc|obj|const):\s*(?=<code)")


def on_page_content(html: str, page: Any, config: Any, files: Files) -> str:
    """Drop the Sphinx role names from the API reference pages."""
    if page.file.src_uri.startswith("reference/"):
        return _ROLE.sub("", html)
    return html


def on_page_markdown(markdown: str, page: Any, config: Any, files: Files) -> str:
    """Point the guides' links to repository files at their generated pages."""
    for source, (target, _title) in REPO_PAGES.items():
        markdown = markdown.replace(f"](../{source}", f"]({target}")
    return markdown
