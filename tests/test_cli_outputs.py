"""The command line and the files it writes: atomic, all or nothing, never outside --out."""

from __future__ import annotations

import errno
import json
import os
import re
import sys
import types
from pathlib import Path
from typing import Any

import pytest
from hypothesis import given
from hypothesis import strategies as st

import glocal_verify
from glocal_verify import config
from glocal_verify.cli import main
from glocal_verify.errors import ModelError
from glocal_verify.runtime import files as output_mod
from glocal_verify.runtime.files import OutputFolder, safe_component, write_text_atomic
from glocal_verify.simulation.engine import check_size, estimate_size

SAFE = re.compile(r"[A-Za-z0-9][A-Za-z0-9._-]*")


def _tiny(name: str = "tiny4", mode: str = "q", horizon: str = "6.0") -> str:
    """A four-agent spec (covert attack, one safe mode) with the given name and mode name."""
    n, q = json.dumps(name), json.dumps(mode)
    return (
        f"format = 1\nname = {n}\n[graph]\nnodes = 4\nedges = [[1, 2, 1], [2, 3, 2], [3, 4, 1], [1, 4, 1]]\n"
        f"[[modes]]\nname = {q}\nadd = [[1, 3, 1]]\n"
        '[[clusters]]\nname = "A"\nnodes = [1, 2]\n[[clusters.observers]]\ncenter = 1\n'
        '[[clusters]]\nname = "B"\nnodes = [3, 4]\n[[clusters.observers]]\ncenter = 4\n'
        '[monitor]\nvelocities = [1, 3]\n[attack]\nkind = "covert"\nactuators = [2]\nsensors = [1, 3]\namplitude = 50.0\nstart = 1.0\n'
        f"[switching]\nmode = {q}\ntime = 3.0\n[simulation]\nhorizon = {horizon}\nstep = 0.05\n"
    )


def _spec(tmp_path: Path, **kw: str) -> Path:
    d = tmp_path / "specs"
    d.mkdir(exist_ok=True)
    p = d / "tiny.toml"
    p.write_text(_tiny(**kw), encoding="utf-8")
    return p


def _files(root: Path) -> set[Path]:
    return {p for p in root.rglob("*") if p.is_file()}


def _one_line(err: str) -> str:
    lines = err.strip().splitlines()
    assert len(lines) == 1, lines
    assert "Traceback" not in err
    return lines[0]


# --------------------------------------------------------------------------------------------
# --version and "wrote <path>"


def test_version_prints_the_package_version(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["--version"]) == 0
    assert capsys.readouterr().out.strip() == f"glocal-verify {glocal_verify.__version__}"


def test_help_exits_0(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["--help"]) == 0 and main(["simulate", "--help"]) == 0
    out = capsys.readouterr().out
    assert "--no-figures" in out and "--allow-large" in out


def test_every_out_says_which_path_it_wrote(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    spec = _spec(tmp_path)
    out = tmp_path / "r" / "report.md"
    out.parent.mkdir()
    assert main(["verify", str(spec), "--only", "privacy.connected", "--out", str(out), "--quiet"]) == 0
    assert _one_line(capsys.readouterr().err) == f"wrote {out}"
    assert out.read_text().startswith("# glocal-verify report: tiny4")
    assert [p.name for p in out.parent.iterdir()] == ["report.md"]  # no temporary file left


# --------------------------------------------------------------------------------------------
# refusing bad output locations before computing


def test_verify_refuses_to_overwrite_its_input_spec(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    spec = _spec(tmp_path)
    before = spec.read_text()
    assert main(["verify", str(spec), "--out", str(spec)]) == 2
    assert "is an input of this command" in _one_line(capsys.readouterr().err)
    assert spec.read_text() == before


def test_a_symbolic_link_as_out_is_refused(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    spec = _spec(tmp_path)
    target = tmp_path / "elsewhere.md"
    target.write_text("keep")
    link = tmp_path / "link.md"
    link.symlink_to(target)
    assert main(["verify", str(spec), "--only", "privacy.connected", "--out", str(link)]) == 2
    assert "symbolic link" in _one_line(capsys.readouterr().err)
    assert target.read_text() == "keep" and link.is_symlink()
    dlink = tmp_path / "dlink"
    dlink.symlink_to(tmp_path / "specs")
    assert main(["simulate", str(spec), "--out", str(dlink), "--no-figures", "--quiet"]) == 2
    assert "symbolic link" in _one_line(capsys.readouterr().err)


def _fail_if_computed(monkeypatch: pytest.MonkeyPatch) -> None:
    def boom(*a: Any, **k: Any) -> Any:
        raise AssertionError("computed before checking the output location")

    monkeypatch.setattr("glocal_verify.cli.verify.make_report", boom)
    monkeypatch.setattr("glocal_verify.design.case_study.algorithm1", boom)


def test_an_unwritable_output_location_fails_at_once_with_one_line(tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]) -> None:
    spec = _spec(tmp_path)
    _fail_if_computed(monkeypatch)
    blocker = tmp_path / "a-file"
    blocker.write_text("x")
    assert main(["verify", str(spec), "--out", str(blocker / "report.md")]) == 2
    assert "not a folder" in _one_line(capsys.readouterr().err)
    assert main(["simulate", str(spec), "--out", str(blocker / "sim"), "--quiet"]) == 2
    assert "not a folder" in _one_line(capsys.readouterr().err)
    assert main(["simulate", str(spec), "--out", str(blocker), "--quiet"]) == 2
    assert "not a folder" in _one_line(capsys.readouterr().err)


@pytest.mark.skipif(hasattr(os, "geteuid") and os.geteuid() == 0, reason="root may write into read-only folders")
def test_simulate_into_a_read_only_folder_fails_before_simulating(tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]) -> None:
    spec = _spec(tmp_path)
    _fail_if_computed(monkeypatch)
    ro = tmp_path / "ro"
    ro.mkdir()
    ro.chmod(0o555)
    try:
        assert main(["simulate", str(spec), "--out", str(ro / "sim"), "--quiet"]) == 2
        assert "not writable" in _one_line(capsys.readouterr().err)
    finally:
        ro.chmod(0o755)


def test_a_full_disk_leaves_the_existing_report_intact(tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]) -> None:
    spec = _spec(tmp_path)
    out = tmp_path / "r" / "report.md"
    out.parent.mkdir()
    out.write_text("previous report")

    def full(path: Path, data: bytes) -> None:
        path.write_bytes(data[: len(data) // 2])
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    monkeypatch.setattr(output_mod, "_write_file", full)
    assert main(["verify", str(spec), "--only", "privacy.connected", "--out", str(out), "--quiet"]) == 2
    assert os.strerror(errno.ENOSPC) in _one_line(capsys.readouterr().err)
    assert out.read_text() == "previous report"
    assert [p.name for p in out.parent.iterdir()] == ["report.md"]


def test_an_output_folder_is_written_all_or_nothing(tmp_path: Path) -> None:
    dest = tmp_path / "d"
    dest.mkdir()
    (dest / "a.json").write_text("old")
    with pytest.raises(KeyboardInterrupt):
        with OutputFolder(dest) as f:
            f.write_text("a.json", "new")
            f.write_text("b.json", "new")
            raise KeyboardInterrupt
    assert {p.name for p in dest.iterdir()} == {"a.json"} and (dest / "a.json").read_text() == "old"
    with OutputFolder(dest) as f:
        f.write_text("a.json", "new")
        f.write_bytes("b.png", b"\x89PNG")
    assert {p.name for p in dest.iterdir()} == {"a.json", "b.png"} and f.written == [dest / "a.json", dest / "b.png"]
    with pytest.raises(ValueError):
        with OutputFolder(dest) as f:
            f.write_text("../escaped.json", "x")
    assert not (tmp_path / "escaped.json").exists()


def test_a_symbolic_link_inside_the_output_folder_is_replaced_never_written_through(tmp_path: Path) -> None:
    victim = tmp_path / "victim.json"
    victim.write_text("keep")
    dest = tmp_path / "d"
    dest.mkdir()
    (dest / "a.json").symlink_to(victim)
    with OutputFolder(dest) as f:
        f.write_text("a.json", "new")
    assert victim.read_text() == "keep"
    assert not (dest / "a.json").is_symlink() and (dest / "a.json").read_text() == "new"


def test_write_text_atomic_replaces_the_file_and_leaves_no_temporary(tmp_path: Path) -> None:
    p = tmp_path / "x" / "r.txt"
    p.parent.mkdir()
    write_text_atomic(p, "one")
    write_text_atomic(p, "two")
    assert p.read_text() == "two" and [q.name for q in p.parent.iterdir()] == ["r.txt"]


def test_a_streamed_text_is_written_whole_or_not_at_all(tmp_path: Path) -> None:
    p = tmp_path / "r.txt"
    write_text_atomic(p, iter(["a", "b", "c"]))
    assert p.read_text() == "abc"

    def broken() -> Any:
        yield "half of a new report"
        raise RuntimeError("the producer failed")

    with pytest.raises(RuntimeError):
        write_text_atomic(p, broken())
    assert p.read_text() == "abc" and [q.name for q in tmp_path.iterdir()] == ["r.txt"]


# --------------------------------------------------------------------------------------------
# spec fields never steer where files go


@given(st.text(max_size=120))
def test_safe_component_is_one_harmless_stable_component(text: str) -> None:
    c = safe_component(text)
    assert SAFE.fullmatch(c) and ".." not in c and len(c) <= 64
    assert safe_component(text) == c and safe_component(c) == c
    assert "/" not in c and "\\" not in c and "\x00" not in c


def test_safe_component_keeps_safe_names_and_marks_changed_ones() -> None:
    assert safe_component("case-1") == "case-1" and safe_component("paper19") == "paper19"
    assert safe_component("") == "unnamed"
    assert safe_component("..").startswith("unnamed-")
    assert safe_component("../a") != safe_component("./a")  # the hash keeps distinct names apart
    assert len(safe_component("n" * 5000)) <= 64


HOSTILE = [
    ("name", "../../../escaped-by-name"),
    ("name", "../../../../tmp/x"),
    ("name", "a\x00b"),
    ("name", "n" * 5000),
    ("mode", "x/../../../escaped-by-mode"),
    ("mode", ".."),
]


@pytest.mark.parametrize(("field", "value"), HOSTILE, ids=["name-up", "name-tmp", "name-nul", "name-5000", "mode-up", "mode-dotdot"])
def test_hostile_names_write_nothing_outside_the_output_folder(field: str, value: str, tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]) -> None:
    spec = _spec(tmp_path, **{field: value})
    work = tmp_path / "w" / "x" / "y" / "z"
    work.mkdir(parents=True)
    monkeypatch.chdir(work)
    out = work / "DIR"
    code = main(["simulate", str(spec), "--out", str(out), "--no-figures", "--quiet"])
    err = capsys.readouterr().err
    assert "Traceback" not in err
    written = _files(tmp_path) - {spec}
    if "\x00" in value or len(value) > 200:  # refused when the spec is loaded (control characters, over-long names): one line, nothing written
        assert code == 2 and len(err.strip().splitlines()) == 1 and not written
        return
    assert code == 0
    assert written and all(out in p.parents for p in written), written
    assert all(SAFE.fullmatch(p.name) for p in written)
    assert not any(list(a.glob("escaped*")) for a in tmp_path.parents[:3])


def test_cases_with_a_hostile_name_stay_in_the_default_folder(tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]) -> None:
    spec = _spec(tmp_path, name="../../escaped-cases")
    work = tmp_path / "w" / "x"
    work.mkdir(parents=True)
    monkeypatch.chdir(work)
    assert main(["simulate", str(spec), "--cases", "--no-figures", "--quiet"]) == 0
    folder = work / "glocal-out" / safe_component("../../escaped-cases")
    written = _files(tmp_path) - {spec}
    assert {p.name for p in written} == {"cases.md", "cases.json", "q.json"}
    assert all(p.parent == folder for p in written)
    assert capsys.readouterr().err.strip().endswith(f"wrote {Path('glocal-out') / folder.name}")


def test_simulate_defaults_to_glocal_out_in_the_working_folder(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    spec = _spec(tmp_path)
    monkeypatch.chdir(tmp_path)
    assert main(["simulate", str(spec), "--no-figures", "--quiet"]) == 0
    assert {p.name for p in (tmp_path / "glocal-out" / "tiny4").iterdir()} == {"simulation-q.json"}


# --------------------------------------------------------------------------------------------
# simulate: figures, progress, limits, Ctrl-C


def test_no_figures_never_loads_matplotlib(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    spec = _spec(tmp_path)
    monkeypatch.setitem(sys.modules, "matplotlib", None)
    monkeypatch.setitem(sys.modules, "glocal_verify.reporting.figures", None)
    assert main(["simulate", str(spec), "--out", str(tmp_path / "o"), "--no-figures", "--quiet"]) == 0
    data = json.loads((tmp_path / "o" / "simulation-q.json").read_text())
    assert data["chosen_mode"] == "q"


def test_simulate_prints_a_line_per_phase_when_stderr_is_not_a_terminal(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    spec = _spec(tmp_path)
    assert main(["simulate", str(spec), "--out", str(tmp_path / "o"), "--no-figures"]) == 0
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) >= 3 and all(line.startswith("glocal-verify: ") for line in err[:-1])
    assert err[-1] == f"wrote {tmp_path / 'o'}"


def test_an_astronomical_horizon_is_refused_before_allocating(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    spec = _spec(tmp_path, horizon="1e16")
    assert main(["simulate", str(spec), "--out", str(tmp_path / "o"), "--quiet"]) == 2
    line = _one_line(capsys.readouterr().err)
    # refused by the spec's documented domain at load time, or else by the size estimate
    assert "simulation.horizon" in line or ("too large" in line and "samples" in line and "--allow-large" in line)
    assert not (tmp_path / "o").exists()


def test_the_size_limits_are_checked_from_the_estimate() -> None:
    est = estimate_size(19, 1e16, 0.01)
    assert est.samples > config.get("simulation_max_samples")
    with pytest.raises(ModelError):
        check_size(est, allow=False)
    check_size(est, allow=True)  # lifted: the estimate alone allocates nothing
    check_size(estimate_size(19, 30.0, 0.01), allow=False)


def test_ctrl_c_stops_simulate_with_exit_130_one_line_and_no_partial_files(tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]) -> None:
    from glocal_verify.simulation import engine

    spec = _spec(tmp_path)
    out = tmp_path / "o"
    out.mkdir()
    (out / "old.json").write_text("old")
    calls = {"n": 0}
    orig = engine._DenseEngine.advance

    def advance(self: Any, delta: float) -> None:
        calls["n"] += 1
        if calls["n"] == 50:
            raise KeyboardInterrupt
        orig(self, delta)

    monkeypatch.setattr(engine._DenseEngine, "advance", advance)
    assert main(["simulate", str(spec), "--out", str(out), "--quiet", "--method", "dense"]) == 130
    assert _one_line(capsys.readouterr().err) == "glocal-verify: interrupted"
    assert calls["n"] == 50  # nothing ran on after the interrupt
    assert [p.name for p in out.iterdir()] == ["old.json"]


def test_ctrl_c_while_writing_leaves_the_folder_as_it_was(tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]) -> None:
    spec = _spec(tmp_path)
    out = tmp_path / "o"
    calls = {"n": 0}
    orig = OutputFolder.write_text

    def write_text(self: OutputFolder, name: str, text: str) -> Path:
        calls["n"] += 1
        if calls["n"] == 2:
            raise KeyboardInterrupt
        return orig(self, name, text)

    monkeypatch.setattr(OutputFolder, "write_text", write_text)
    assert main(["simulate", str(spec), "--cases", "--out", str(out), "--no-figures", "--quiet"]) == 130
    assert _one_line(capsys.readouterr().err) == "glocal-verify: interrupted"
    assert not out.exists()  # the folder the run created is gone again: no empty output folder


# --------------------------------------------------------------------------------------------
# verify: certified-verdict flags, html, graph files; draw


def test_verify_passes_the_escalation_flags_to_the_registry(tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]) -> None:
    import glocal_verify.cli.verify as cli_verify

    seen: dict[str, Any] = {}
    real = cli_verify.make_report

    def spy(*a: Any, **k: Any) -> Any:
        seen.update(k)
        return real(*a, **k)

    monkeypatch.setattr(cli_verify, "make_report", spy)
    spec = _spec(tmp_path)
    assert main(["verify", str(spec), "--only", "privacy.connected"]) == 0
    assert (seen["escalate"], seen["exact_budget"], seen["fragile_below"]) == ("auto", 30.0, 1e-9)
    argv = ["verify", str(spec), "--only", "privacy.connected", "--escalate", "never", "--exact-budget", "0", "--fragile-below", "1e-6"]
    assert main(argv) == 0
    assert (seen["escalate"], seen["exact_budget"], seen["fragile_below"]) == ("never", None, 1e-6)
    capsys.readouterr()
    assert main(["verify", str(spec), "--exact-budget", "-1"]) == 2
    assert "--exact-budget" in _one_line(capsys.readouterr().err)


def test_format_html_goes_to_the_renderer(tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]) -> None:
    import glocal_verify.cli.verify as cli_verify

    asked: list[str] = []
    monkeypatch.setattr(cli_verify, "render_report", lambda report, fmt, system=None: asked.append(fmt) or "<html></html>\n")
    out = tmp_path / "r.html"
    assert main(["verify", str(_spec(tmp_path)), "--only", "privacy.connected", "--format", "html", "--out", str(out)]) == 0
    assert asked == ["html"] and out.read_text() == "<html></html>\n"


def test_verify_builds_the_spec_from_a_graph_file(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    g = tmp_path / "ring.txt"
    g.write_text("1 2\n2 3 2\n3 4\n4 1\n")
    assert main(["verify", "--graph", str(g), "--velocities", "1,3", "--only", "privacy.connected", "--format", "json"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert data["system"]["agents"] == 4 and data["system"]["name"] == "ring"
    assert main(["verify", "--graph", str(g), "--velocities", "9"]) == 2
    assert "--velocities" in _one_line(capsys.readouterr().err)
    assert main(["verify", "--example", "paper19", "--velocities", "3"]) == 2
    assert "--graph" in _one_line(capsys.readouterr().err)


def test_draw_writes_the_svg_of_the_network_svg_module(tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]) -> None:
    calls: list[tuple[str, str]] = []
    fake = types.ModuleType("glocal_verify.reporting.network_svg")
    fake.network_svg = lambda system, mode: calls.append((system.name, mode)) or "<svg/>"  # type: ignore[attr-defined]
    monkeypatch.setitem(sys.modules, "glocal_verify.reporting.network_svg", fake)
    out = tmp_path / "net.svg"
    assert main(["draw", "--example", "paper19", "--mode", "case-1", "--out", str(out)]) == 0
    assert calls == [("paper19", "case-1")] and out.read_text() == "<svg/>\n"
    assert _one_line(capsys.readouterr().err) == f"wrote {out}"
    assert main(["draw", "--example", "paper19", "--mode", "nope"]) == 2
    assert "nope" in _one_line(capsys.readouterr().err)


def test_draw_says_in_one_line_when_the_renderer_is_missing(monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]) -> None:
    monkeypatch.setitem(sys.modules, "glocal_verify.reporting.network_svg", None)
    assert main(["draw", "--example", "paper19"]) == 2
    assert "network_svg" in _one_line(capsys.readouterr().err)


def test_the_simulator_refuses_a_run_whose_estimate_exceeds_the_limits_unless_allowed() -> None:
    from glocal_verify.errors import GlocalVerifyError
    from glocal_verify.simulation.engine import allow_large, check_size, estimate_size

    est = estimate_size(1000, 1e6, 1e-3)
    with pytest.raises(GlocalVerifyError, match="allow-large"):
        check_size(est)
    with allow_large():
        check_size(est)
    check_size(estimate_size(19, 30.0, 0.05))


def test_a_stiff_network_is_refused_before_simulating_and_switching_detects_says_why(tmp_path: Path) -> None:
    from glocal_verify import System, spec_from_dict, verify
    from glocal_verify.results import Status

    data = {
        "format": 1,
        "dynamics": {"alpha": 1000000},
        "graph": {"nodes": 4, "edges": [[1, 2], [2, 3], [3, 4]]},
        "modes": [{"name": "s", "add": [[1, 3]]}],
        "monitor": {"velocities": [1]},
        "switching": {"mode": "s", "time": 1.0},
        "attack": {"kind": "zda", "actuators": [3]},
        "simulation": {"horizon": 3.0, "step": 0.05},
    }
    (r,) = verify(System(spec_from_dict(data)), ["switching.detects"], options={"simulate": True}).conditions
    assert r.status is Status.UNDECIDED and "too stiff" in r.witness["note"]


def test_a_finding_rule_whose_numerics_overflow_costs_no_verdict(tmp_path: Path) -> None:
    from glocal_verify import System, spec_from_dict, verify

    data = {
        "format": 1,
        "dynamics": {"gamma": 1000000},
        "graph": {"nodes": 4, "edges": [[1, 2], [2, 3], [3, 4]]},
        "modes": [{"name": "s", "add": [[1, 3]]}],
        "monitor": {"velocities": [1]},
        "switching": {"mode": "s", "time": 1.0},
    }
    report = verify(System(spec_from_dict(data)))
    assert report.results("switched-observability")


def test_design_keeps_the_specs_observers_under_either_spelling_of_the_option(capsys: pytest.CaptureFixture[str]) -> None:
    from glocal_verify.cli import build_parser

    parser = build_parser()
    assert parser.parse_args(["design", "x.toml"]).keep_observers is False
    assert parser.parse_args(["design", "x.toml", "--keep-observers"]).keep_observers is True
    assert parser.parse_args(["design", "x.toml", "--no-observers"]).keep_observers is True
    assert main(["design", "--help"]) == 0
    text = " ".join(capsys.readouterr().out.split())
    assert "--keep-observers keep the spec's local observers instead of placing new ones" in text
    assert "--no-observers" not in text


def test_the_exact_budget_is_described_as_one_budget_per_run(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["verify", "--help"]) == 0
    text = " ".join(capsys.readouterr().out.split())
    help_text = text[text.rindex("--exact-budget SECONDS") :][:160]
    assert "one time budget for all the exact escalations of the run" in help_text and "each" not in help_text


def test_counted_nouns_take_their_number() -> None:
    from glocal_verify.words import counted

    assert [counted(k, "mode") for k in (0, 1, 2)] == ["0 modes", "1 mode", "2 modes"]
    assert counted(1, "matrix", "matrices") == "1 matrix" and counted(3, "matrix", "matrices") == "3 matrices"
