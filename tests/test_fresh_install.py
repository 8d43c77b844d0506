"""The README's test command on a fresh machine: a clean copy of the repository (its tracked
files), a fresh ``python -m venv`` that sees nothing of this interpreter's packages, the
README's install (``python -m pip install '.[test]'``), then the quick packaging tests and the
collection of the whole suite in that venv.

Slow (the install resolves and installs every dependency: 2-4 minutes); ``.ci/run`` runs it,
``-m "not slow"`` leaves it out. The install needs the package index pip is configured with
(PyPI, or a local mirror), as the README's command does."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

pytestmark = pytest.mark.slow

ROOT = Path(__file__).resolve().parent.parent

#: set inside the fresh venv, so that this test does not run itself there
NESTED = "GLOCAL_FRESH_INSTALL"

#: left out when the repository is not a git checkout (an unpacked archive): what a clone has not
IGNORED = shutil.ignore_patterns(".git", "__pycache__", "*.pyc", "*.egg-info", "build", "dist", ".venv", ".pytest_cache", ".hypothesis", ".mypy_cache")


def _clean_copy(dest: Path) -> None:
    """The repository's tracked files (their working-tree content) under ``dest``: a clean clone."""
    listed = subprocess.run(["git", "-C", str(ROOT), "ls-files", "-z"], capture_output=True, timeout=60) if shutil.which("git") else None
    if listed is None or listed.returncode != 0:
        shutil.copytree(ROOT, dest, ignore=IGNORED)
        return
    for name in filter(None, listed.stdout.decode().split("\0")):
        src = ROOT / name
        if src.is_file():  # a file deleted in the working tree is not in the clone either
            (dest / name).parent.mkdir(parents=True, exist_ok=True)
            shutil.copy2(src, dest / name)


def _run(args: list[str], cwd: Path, env: dict[str, str], timeout: float) -> subprocess.CompletedProcess[str]:
    done = subprocess.run(args, cwd=cwd, env=env, capture_output=True, text=True, timeout=timeout)
    assert done.returncode == 0, f"{' '.join(args)}: exit {done.returncode}\n{done.stdout[-3000:]}\n{done.stderr[-3000:]}"
    return done


@pytest.mark.slow
@pytest.mark.skipif(bool(os.environ.get(NESTED)), reason="inside the fresh venv of this very test")
def test_the_readme_test_command_passes_in_a_fresh_venv_on_a_clean_clone(tmp_path: Path) -> None:
    clone = tmp_path / "clone"
    _clean_copy(clone)
    assert not (clone / "glocal_verify.egg-info").exists()
    venv = tmp_path / "venv"
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "PYTHONHOME", "VIRTUAL_ENV", "PYTHONUSERBASE")}
    # a fresh venv sees no site-packages but its own (nor the user's: PYTHONNOUSERSITE)
    _run([sys.executable, "-m", "venv", str(venv)], tmp_path, env, 300)
    env.update(VIRTUAL_ENV=str(venv), PATH=f"{venv / 'bin'}{os.pathsep}{env.get('PATH', '')}", PYTHONNOUSERSITE="1")
    env[NESTED] = "1"
    python = str(venv / "bin" / "python")
    seen = subprocess.run([python, "-c", "import numpy"], cwd=tmp_path, env=env, capture_output=True, text=True, timeout=60)
    assert seen.returncode != 0, "the fresh venv sees this interpreter's packages: it is not fresh"
    # the README's test command: its install, then the packaging tests (the part that needs the
    # venv's own dependencies) and the collection of every test module
    _run([python, "-m", "pip", "install", "--quiet", ".[test]"], clone, env, 1800)
    _run([python, "-m", "pytest", "-q", "-p", "no:cacheprovider", "-m", "not slow", "tests/test_packaging.py"], clone, env, 1800)
    collected = _run([python, "-m", "pytest", "-q", "-p", "no:cacheprovider", "--collect-only"], clone, env, 600)
    assert "error" not in collected.stdout.lower().splitlines()[-1], collected.stdout[-2000:]
