"""The wheel alone: built from the sources, installed into a fresh virtual environment, run
outside the repository, it writes the same findings report as the repository does (the
counterexample specs and the examples are package data)."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import zipfile
from pathlib import Path

import pytest

from glocal_verify.design.findings import verify_findings
from glocal_verify.reporting.findings import findings_markdown
from glocal_verify.spec.examples import example_names, finding_names

ROOT = Path(__file__).resolve().parent.parent

#: what the build reads (pyproject.toml names README.md as the long description)
SOURCES = ("pyproject.toml", "README.md", "glocal_verify", "proofs_checks", "glocal_check")


def _run(args: list[str], cwd: Path, env: dict[str, str]) -> subprocess.CompletedProcess[str]:
    done = subprocess.run(args, cwd=cwd, env=env, capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, f"{' '.join(args)}: exit {done.returncode}\n{done.stdout[-2000:]}\n{done.stderr[-2000:]}"
    return done


@pytest.fixture(scope="module")
def venv(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, dict[str, str]]:
    """A fresh venv (dependencies from the running interpreter's site-packages) holding the wheel.

    ``--ignore-installed``: the running interpreter may itself hold a (non-editable) install of
    the project, which the venv sees through its system site-packages; pip would call the wheel
    already satisfied and the test would run that copy instead."""
    base = tmp_path_factory.mktemp("wheel")
    src = base / "src"
    src.mkdir()
    ignore = shutil.ignore_patterns("__pycache__", "*.pyc", "*.egg-info", "build")
    for name in SOURCES:
        if (ROOT / name).is_dir():
            shutil.copytree(ROOT / name, src / name, ignore=ignore)
        else:
            shutil.copy2(ROOT / name, src / name)
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "PYTHONHOME", "VIRTUAL_ENV")}
    _run([sys.executable, "-m", "pip", "wheel", "--no-deps", "--quiet", "-w", str(base / "dist"), str(src)], base, env)
    (wheel,) = (base / "dist").glob("glocal_verify-*.whl")
    env_dir = base / "venv"
    _run([sys.executable, "-m", "venv", "--system-site-packages", "--without-pip", str(env_dir)], base, env)
    python = env_dir / "bin" / "python"
    _run([sys.executable, "-m", "pip", "--python", str(python), "install", "--no-deps", "--no-index", "--ignore-installed", "--quiet", str(wheel)], base, env)
    return env_dir, env


def test_the_wheel_holds_every_bundled_spec_and_schema(venv: tuple[Path, dict[str, str]]) -> None:
    env_dir, _ = venv
    (wheel,) = (env_dir.parent / "dist").glob("glocal_verify-*.whl")
    names = set(zipfile.ZipFile(wheel).namelist())
    for name in example_names():
        assert f"glocal_verify/spec/data/{name}.toml" in names
    for name in finding_names():
        assert f"glocal_verify/spec/data/{name}.toml" in names
    assert {"glocal_verify/spec/schemas/spec.schema.json", "glocal_verify/reporting/schemas/report.schema.json"} <= names


def test_findings_from_the_installed_wheel_writes_the_repositorys_report(venv: tuple[Path, dict[str, str]], tmp_path: Path) -> None:
    env_dir, env = venv
    where = _run([str(env_dir / "bin" / "python"), "-c", "import glocal_verify; print(glocal_verify.__file__)"], tmp_path, env).stdout.strip()
    assert Path(where).resolve().is_relative_to(env_dir.resolve()), where
    done = _run([str(env_dir / "bin" / "glocal-verify"), "findings", "--out", "findings.md"], tmp_path, env)
    assert "warning" not in done.stderr
    assert (tmp_path / "findings.md").read_text(encoding="utf-8") == findings_markdown(verify_findings())
    run = _run([str(env_dir / "bin" / "glocal-verify"), "verify", "--example", finding_names()[0], "--quiet", "--escalate", "never"], tmp_path, env)
    assert run.stdout.startswith("#")


def test_the_installed_wheel_checks_the_certificates_it_writes(venv: tuple[Path, dict[str, str]], tmp_path: Path) -> None:
    env_dir, env = venv
    bin_ = env_dir / "bin"
    where = _run([str(bin_ / "python"), "-c", "import glocal_check; print(glocal_check.__file__)"], tmp_path, env).stdout.strip()
    assert Path(where).resolve().is_relative_to(env_dir.resolve()), where
    (tmp_path / "s.toml").write_text(_run([str(bin_ / "glocal-verify"), "example", "paper19"], tmp_path, env).stdout, encoding="utf-8")
    _run([str(bin_ / "glocal-verify"), "verify", "s.toml", "--quiet", "--out", "r.md", "--certificates", "c.json"], tmp_path, env)
    done = subprocess.run([str(bin_ / "python"), "-m", "glocal_check", "s.toml", "c.json"], cwd=tmp_path, env=env, capture_output=True, text=True, timeout=600)
    assert done.stdout.strip().endswith("75 accepted, 0 rejected; 3 decided verdicts without a certificate"), done.stdout
