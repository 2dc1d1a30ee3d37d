"""The settings tables of the documentation, derived from the declarations (:mod:`vfs.settings`).

The pages hold hand-written prose and blocks between ``<!-- BEGIN GENERATED <name> -->``
and ``<!-- END GENERATED <name> -->`` (the markers of :mod:`vfs.database.docs`) whose
content :data:`BLOCKS` renders.  Regenerate with::

    python -m vfs.cli.settings_docs

(the pages of :data:`PAGES`; or name them)
and check (as tests/test_settings.py does) with ``--check``.  A module of the command-line
layer: it reads the declarations of every layer.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Callable, Sequence
from pathlib import Path

#: The pages that hold generated settings tables.
PAGES = ("docs/study.md", "docs/diagnosis.md", "docs/physics.md", "docs/uncertainty.md",
         "docs/effects.md", "docs/performance.md")


def study_settings() -> str:
    """The settings of :class:`vfs.study.StudySpec` (``vfs study`` flags, ``run_study``)."""
    from vfs.settings import markdown_table
    from vfs.study.spec import StudySpec

    return markdown_table(StudySpec) + "\n"


def diagnose_settings() -> str:
    """The settings of :class:`vfs.diagnosis.diagnose_spec.DiagnoseSpec`."""
    from vfs.diagnosis.diagnose_spec import DiagnoseSpec
    from vfs.settings import markdown_table

    return markdown_table(DiagnoseSpec) + "\n"


def simulation_settings() -> str:
    """The settings of :class:`vfs.physics.precrash.PrecrashParams` and
    :class:`vfs.simulation.SimulationParams`.
    """
    from vfs.physics.precrash import PrecrashParams
    from vfs.settings import markdown_table
    from vfs.simulation import SimulationParams

    return ("`PrecrashParams` (the pre-crash phase):\n\n" + markdown_table(PrecrashParams)
            + "\n\n`SimulationParams` (the whole chain):\n\n"
            + markdown_table(SimulationParams) + "\n")


def uncertainty_model() -> str:
    """The ``[model]`` table of an uncertainty configuration (:class:`UncertaintyConfig`)."""
    from vfs.settings import markdown_table
    from vfs.uncertainty.config import UncertaintyConfig

    return markdown_table(UncertaintyConfig) + "\n"


def compute_threads() -> str:
    """The compute-thread setting (:class:`vfs.threads.ComputeThreads`, ``VFS_THREADS``)."""
    from vfs.settings import declared, markdown_table
    from vfs.threads import THREADS_VARIABLE, ComputeThreads

    # the bound of numba's pool differs from machine to machine: the page names it
    most = declared(ComputeThreads)["threads"].allowed()
    table = markdown_table(ComputeThreads, rename={"threads": THREADS_VARIABLE})
    pool = ("an integer from 1 to the size of numba's thread pool (the cores the process "
            "may use, or NUMBA_NUM_THREADS), or absent")
    return table.replace(most, pool) + "\n"


def effect_parameters() -> str:
    """The parameters of every built-in effect (:class:`vfs.effects.EffectParameter`;
    effects registered later by plugins, or by tests in the same process, are not vfs's
    and stay out of its docs).
    """
    from vfs.effects import BUILTIN_EFFECTS, get_effect

    lines = ["| effect | parameter | allowed | nominal | neutral | meaning |",
             "|---|---|---|---|---|---|"]
    for name in BUILTIN_EFFECTS:
        for p in get_effect(name).parameters:
            s = p.setting
            unit = s.si_unit().label
            unit = f" {unit}" if unit not in ("", "-") else ""
            neutral = "" if p.neutral is None else f"{p.neutral:g}{unit}"
            lines.append(f"| `{name}` | `{p.name}` | {s.allowed()} | {p.default:g}{unit} | "
                         f"{neutral} | {p.description} |")
    return "\n".join(lines) + "\n"


#: Block name -> function rendering its Markdown.
BLOCKS: dict[str, Callable[[], str]] = {
    "study-settings": study_settings,
    "diagnose-settings": diagnose_settings,
    "simulation-settings": simulation_settings,
    "uncertainty-model": uncertainty_model,
    "effect-parameters": effect_parameters,
    "compute-threads": compute_threads,
}


def main(argv: Sequence[str] | None = None) -> int:
    """Regenerate (or with ``--check`` verify) the settings tables of the pages."""
    from vfs.database.docs import render_document, stale_blocks

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("pages", type=Path, nargs="*", default=[Path(p) for p in PAGES])
    parser.add_argument("--check", action="store_true", help="only report stale blocks")
    args = parser.parse_args(argv)
    stale = 0
    for page in args.pages:
        if args.check:
            for name in stale_blocks(page, BLOCKS):
                print(f"{page}: stale generated block: {name}")
                stale += 1
        else:
            text = page.read_text(encoding="utf-8")
            page.write_text(render_document(text, BLOCKS), encoding="utf-8")
    return 1 if stale else 0


if __name__ == "__main__":
    sys.exit(main())
