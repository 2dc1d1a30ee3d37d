"""Installed or cloned, the same: a wheel installed elsewhere reads the same catalogue.

The wheel is installed into a fresh virtual environment that sees the packages of the
interpreter running the tests (a ``.pth`` file naming its site-packages), so the test needs
no network for vfs's dependencies and passes whether they live in the system Python, a
pyenv or a virtual environment (the README's commands run in any of them).
"""

from __future__ import annotations

import os
import site
import subprocess
import sysconfig
import venv
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]

#: Databases the installed copy must open from another folder, with their case counts.
BUNDLED = (("default", 600), ("crash-tests", 5), ("euro-ncap-c2c", 220),
           ("euro-ncap-c2c-2023", 173))


def _running_site_packages() -> list[str]:
    """The site-packages folders of the interpreter running the tests (venv or not)."""
    paths = [sysconfig.get_paths()["purelib"], sysconfig.get_paths()["platlib"],
             *site.getsitepackages()]
    if site.ENABLE_USER_SITE and site.getusersitepackages():
        paths.append(site.getusersitepackages())
    out: list[str] = []
    for p in paths:
        if p not in out and Path(p).is_dir():
            out.append(p)
    return out


def _fresh_venv(env_dir: Path) -> Path:
    """A venv whose own site-packages come first, then the running interpreter's."""
    venv.create(env_dir, system_site_packages=False, with_pip=True)
    py = env_dir / "bin" / "python"
    own = subprocess.run([str(py), "-c", "import sysconfig; print(sysconfig.get_paths()"
                          "['purelib'])"], capture_output=True, text=True, check=True)
    # plain folder lines: added after the venv's own site-packages; .pth files inside them
    # (an editable vfs of the running environment) are not processed
    (Path(own.stdout.strip()) / "zz_running_interpreter.pth").write_text(
        "\n".join(_running_site_packages()) + "\n")
    return py


def test_catalogue_has_no_python_that_vfs_imports() -> None:
    for folder in ("adas", "scenarios"):
        assert not list((ROOT / folder).rglob("__init__.py")), folder
    for path in (ROOT / "vfs").rglob("*.py"):
        text = path.read_text(encoding="utf-8")
        for name in ("adas", "scenarios"):
            assert f"\nimport {name}" not in text and f"\nfrom {name} " not in text, path


@pytest.mark.slow
def test_non_editable_install_works_from_another_folder(tmp_path: Path) -> None:
    """``pip install .`` (a wheel, not editable) into a fresh venv; commands from elsewhere."""
    py = _fresh_venv(tmp_path / "venv")
    env_dir = py.parent.parent
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "PYTHONHOME")}
    env.update(MPLBACKEND="Agg", CI="true", PIP_DISABLE_PIP_VERSION_CHECK="1")
    built = subprocess.run([str(py), "-m", "pip", "install", "--quiet", "--no-deps", str(ROOT)],
                           capture_output=True, text=True, timeout=600, env=env)
    assert built.returncode == 0, built.stderr[-3000:]
    work = tmp_path / "elsewhere"
    work.mkdir()

    def run(*args: str) -> subprocess.CompletedProcess[str]:
        result = subprocess.run([str(env_dir / "bin" / args[0]), *args[1:]], cwd=work,
                                capture_output=True, text=True, env=env, timeout=600)
        assert result.returncode == 0, result.stderr[-3000:]
        return result

    where = run("python", "-c", "import vfs, os; print(os.path.dirname(vfs.__file__))")
    assert str(env_dir) in where.stdout  # the installed copy, not the source tree
    # the catalogue comes from inside the installed package, equal to the repository's
    cat = run("python", "-c", "from vfs.catalog import catalog_root as r; "
              "print(r('adas')); print(r('scenarios'))").stdout.split()
    assert all(str(env_dir) in c for c in cat)
    for name in ("three-stage.toml", "ideal.toml"):
        assert (Path(cat[0]) / name).read_bytes() == (ROOT / "adas" / name).read_bytes()
    for name, n_cases in BUNDLED:
        run("python", "-c", f"import vfs; assert vfs.open_database({name!r}).n_cases == "
            f"{n_cases}")
    for name in ("adas", "scenarios"):
        probe = subprocess.run([str(py), "-c", f"import {name}"], cwd=work, env=env,
                               capture_output=True)
        assert probe.returncode != 0, f"a top-level {name!r} package is installed"
    run("vfs", "run-case", "--plot", "x.png")
    assert (work / "x.png").stat().st_size > 10_000
    # a system written by the user in the project's adas/ folder, next to a built-in one
    (work / "adas").mkdir()
    text = (ROOT / "adas" / "three-stage.toml").read_text(encoding="utf-8")
    (work / "adas" / "mine.toml").write_text(
        text.replace('name = "three-stage"', 'name = "mine"')
        .replace("latency_s = 0.1", "latency_s = 0.3"), encoding="utf-8")
    run("vfs", "study", "--db", "default", "--where", "case_id <= 12", "--systems",
        "mine,ideal", "--engine", "serial")
    runs = work / "results" / "study-default-mine+ideal" / "runs.parquet"
    assert runs.exists()
    systems = run("python", "-c", f"import pandas as pd; print(sorted(set(pd.read_parquet("
                  f"{str(runs)!r})['system'])))").stdout
    assert "mine" in systems and "ideal" in systems
    # the Euro NCAP test matrix with the user's system, and its protocol view (the protocol
    # file is read from the installed catalogue)
    run("vfs", "study", "--db", "euro-ncap-c2c", "--where", "case_id <= 6", "--systems",
        "mine", "--engine", "serial", "--out", "ncap")
    run("vfs", "report", "effectiveness", "ncap")
    assert any((work / "ncap" / "report").glob("*ncap*.csv"))
