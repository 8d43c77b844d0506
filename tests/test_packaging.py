"""The wheel alone: built from the sources, installed into a fresh virtual environment, run
outside the repository, it writes the same findings report as the repository does (the
counterexample specs and the examples are package data), and every command of the README's
Tour works there from an empty folder.

The virtual environment is isolated (no ``--system-site-packages``: the base interpreter may
lack the dependencies, as in a user's fresh venv); a ``.pth`` file lists the running
interpreter's site-packages folders after the venv's own, so the dependencies are found there
and the wheel shadows any installed copy of the project."""

from __future__ import annotations

import os
import re
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


def _site_folders() -> list[str]:
    """The running interpreter's site-packages folders (its venv's and, with system site-packages, the base's)."""
    return [p for p in sys.path if p and Path(p).is_dir() and Path(p).name in ("site-packages", "dist-packages")]


@pytest.fixture(scope="module")
def venv(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, dict[str, str]]:
    """A fresh, isolated venv holding the wheel; the dependencies come from the running interpreter.

    The ``.pth`` file's plain folder lines add those folders behind the venv's own
    site-packages, without running their ``.pth`` files (an editable install of the project
    there stays inert). ``--ignore-installed``: pip sees the project's metadata in those folders
    and would call the wheel already satisfied."""
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
    _run([sys.executable, "-m", "venv", "--without-pip", str(env_dir)], base, env)
    python = env_dir / "bin" / "python"
    (site,) = (env_dir / "lib").glob("python3*/site-packages")
    (site / "running_interpreter.pth").write_text("".join(f"{p}\n" for p in _site_folders()), encoding="utf-8")
    _run([sys.executable, "-m", "pip", "--python", str(python), "install", "--no-deps", "--no-index", "--ignore-installed", "--quiet", str(wheel)], base, env)
    return env_dir, env


#: a README command whose comment says this runs only in a clone of the repository
IN_THE_REPOSITORY = "repository"


def _readme_blocks(lang: str) -> list[str]:
    return re.findall(rf"```{lang}\n(.*?)```", (ROOT / "README.md").read_text(encoding="utf-8"), re.S)


def _readme_commands() -> list[tuple[str, str]]:
    """(command, comment) of every line of the README's shell blocks, the installs left out
    (the fixture installed the wheel; test_fresh_install runs the README's own)."""
    out = []
    for block in _readme_blocks("bash"):
        for raw in block.splitlines():
            command, _, comment = raw.partition("  #")
            parts = [p.strip() for p in command.split("&&") if p.strip() and not p.strip().startswith("python -m pip install")]
            if parts:
                out.append((" && ".join(parts), comment.strip()))
    return out


def test_the_readme_says_where_each_command_that_needs_the_repository_runs() -> None:
    commands = _readme_commands()
    assert any(c.startswith("glocal-verify verify") for c, _ in commands)
    for command, comment in commands:
        if command.startswith(("python -m pytest", "python -m benchmarks")):
            assert IN_THE_REPOSITORY in comment, f"{command}: the README must say it runs in the repository"


@pytest.mark.slow
def test_every_readme_command_works_from_an_empty_folder_with_the_installed_wheel(venv: tuple[Path, dict[str, str]], tmp_path: Path) -> None:
    env_dir, env = venv
    env = {**env, "PATH": f"{env_dir / 'bin'}{os.pathsep}{env.get('PATH', '')}", "VIRTUAL_ENV": str(env_dir)}
    (sweep,) = _readme_blocks("toml")  # the Tour's sweep.toml is the file under "Sweeps"
    (tmp_path / "sweep.toml").write_text(sweep, encoding="utf-8")
    ran = []
    for command, comment in _readme_commands():
        if IN_THE_REPOSITORY in comment and "only" in comment or command.startswith("python -m pytest"):
            continue  # the test suite, the benchmarks: checked below, they need the repository
        done = subprocess.run(["bash", "-c", command], cwd=tmp_path, env=env, capture_output=True, text=True, timeout=1200)
        allowed = (0, 1) if "--require" in command else (0,)  # a gate that is not met exits 1
        assert done.returncode in allowed, f"{command}: exit {done.returncode}\n{done.stdout[-1500:]}\n{done.stderr[-1500:]}"
        assert "error" not in done.stderr.lower() and "Traceback" not in done.stderr, f"{command}:\n{done.stderr[-2000:]}"
        ran.append(command)
    assert len(ran) >= 15, ran
    for module in sorted(set(re.findall(r"python -m ([\w.]+)", (ROOT / "README.md").read_text(encoding="utf-8")))):
        if module in ("pip", "pytest"):
            continue
        found = _run([str(env_dir / "bin" / "python"), "-c", f"import importlib.util as u; print(u.find_spec({module!r}) is not None)"], tmp_path, env)
        if found.stdout.strip() != "True":  # not installed: every README line naming it says where it runs
            lines = [ln for ln in (ROOT / "README.md").read_text(encoding="utf-8").splitlines() if f"python -m {module}" in ln]
            assert all(IN_THE_REPOSITORY in ln for ln in lines), lines
    (block,) = _readme_blocks("python")  # "From Python, without a file"
    done = subprocess.run([str(env_dir / "bin" / "python"), "-c", block], cwd=tmp_path, env=env, capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr[-2000:]


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
    assert done.stdout.strip().endswith("75 accepted, 0 rejected; 0 decided verdicts without a certificate"), done.stdout
    assert done.returncode == 0, done.stdout  # switching.detects is a simulated observation, not a verdict
