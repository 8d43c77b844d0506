"""The newer surfaces hold the spec loader's contract: graph files, sweep files, options and library
arguments give one line and exit 2 (the project's exceptions in the library); every command
writes under one output policy; SIGTERM and SIGHUP stop like Ctrl-C and no child outlives its
command; sweeps and designs are estimated before they start; the exact path never asserts.

One regression case per class found by the campaign of ``tests/fuzz_campaign.py``; its
derandomized subset runs in ``tests/test_fuzz_surfaces.py``.
"""

from __future__ import annotations

import re

import math
import os
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path
from typing import Any, Callable

import pytest

import fuzz_support as fs
from glocal_verify import ArgumentError, GlocalVerifyError, SpecError, System, load_example, verify
from glocal_verify.cli import main

ROOT = Path(__file__).resolve().parents[1]


def _one_line(err: str) -> str:
    """The one line of ``err`` (the heartbeat's still-working lines of a slow machine aside)."""
    lines = [ln for ln in err.strip().splitlines() if ln.strip() and ": still working, " not in ln]
    assert len(lines) == 1, lines
    assert "Traceback" not in err and "Warning" not in err
    return lines[0]


def _spec(tmp_path: Path, name: str = "spec.toml") -> Path:
    p = tmp_path / name
    p.write_bytes(fs._spec_text("cycle8"))
    return p


# --------------------------------------------------------------------------------------------
# graph files


def test_a_gml_file_nested_20000_deep_is_one_line_naming_the_line(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    g = tmp_path / "deep.gml"
    g.write_text("graph [\n" + "a [ " * 20_000 + "]" * 20_000 + "\n node [ id 1 ]\n]\n")
    assert main(["verify", "--graph", str(g), "--quiet"]) == 2
    assert "line 2: lists nested deeper than 64 levels" in _one_line(capsys.readouterr().err)


def test_a_graphml_port_tag_prints_no_warning(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    g = tmp_path / "port.graphml"
    g.write_text(fs._graph_texts()[".graphml"].replace('<node id="1" />', '<node id="1"><port name="p"/></node>'))
    assert "<port" in g.read_text()
    assert main(["verify", "--graph", str(g), "--quiet", "--simulate", "never"]) == 0
    assert capsys.readouterr().err == ""


def test_a_graph_of_more_than_100000_nodes_is_refused_in_one_line(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    g = tmp_path / "path.txt"
    g.write_text("".join(f"{i} {i + 1}\n" for i in range(1, 100_001)))
    assert main(["verify", "--graph", str(g), "--quiet"]) == 2
    assert "too many nodes (100001; at most 100000)" in _one_line(capsys.readouterr().err)


def test_an_edge_list_line_of_200000_characters_is_echoed_cut_short(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    g = tmp_path / "deep.txt"
    g.write_text("1 2 {'weight': " + "[" * 100_000 + "1" + "]" * 100_000 + "}\n")
    assert main(["verify", "--graph", str(g), "--quiet"]) == 2
    assert len(_one_line(capsys.readouterr().err)) < 300


@pytest.mark.parametrize(("name", "text"), [("g.csv", "source,target,weight\n1,2,1\n2,3,1e9999999\n"), ("g.txt", "1 2\n2 3 1e9999999\n"), ("g.gml", "graph [ node [ id 1 ] node [ id 2 ] edge [ source 1 target 2 weight " + "9" * 2000 + " ] ]\n")], ids=["csv", "edge-list", "gml"])
def test_a_graph_weight_of_a_huge_exponent_is_refused_like_the_specs(name: str, text: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    # the campaign of 2026-12-05 (#4643, #5178): the graph reader expanded "1e9999999" and the
    # spec writer then failed to print it (exit 70)
    g = tmp_path / name
    g.write_text(text)
    assert main(["verify", "--graph", str(g), "--quiet", "--simulate", "never"]) == 2
    assert "far outside the allowed range" in _one_line(capsys.readouterr().err)


# --------------------------------------------------------------------------------------------
# sweep files: validated before any cluster starts


@pytest.fixture
def no_cluster(monkeypatch: pytest.MonkeyPatch) -> None:
    """Fail the test if a Dask cluster is started."""
    import glocal_verify.extra.dask as dist

    def refuse(*a: Any, **k: Any) -> Any:
        raise AssertionError("a Dask cluster was started")

    monkeypatch.setattr(dist, "dask_client", refuse)


@pytest.mark.parametrize(
    "text,where",
    [
        ('[ensemble]\ngenerator = "random-clustered"\nagents = ' + "[" * 5000 + "30" + "]" * 5000 + "\n", "ensemble.agents: arrays or inline tables nested deeper than 64 levels"),
        ('[ensemble]\ngenerator = ["random-clustered"]\nagents = 30\n', "ensemble.generator: unknown generator ['random-clustered']"),
        ('[ensemble]\ngenerator = "random-clustered"\nagents = 12\nseeds = {start = 18446744073709551616, count = 1}\n', "ensemble.seeds.start: must be an integer in [0, 9223372036854775807]"),
        ('[ensemble]\ngenerator = "random-clustered"\nagents = [4, 30]\nclusters = 3\n', "ensemble.agents: must be in [6, 100000], got 4"),
        ('[ensemble]\ngenerator = "random-clustered"\nagents = 12\nchords = nan\n', "ensemble.chords: expected a finite number"),
    ],
    ids=["nested-5000-deep", "generator-list", "seed-2-to-the-64", "agents-below-clusters", "chords-nan"],
)
def test_a_bad_sweep_file_is_one_line_before_any_cluster_starts(text: str, where: str, tmp_path: Path, capsys: pytest.CaptureFixture[str], no_cluster: None) -> None:
    sw = tmp_path / "sw.toml"
    sw.write_text(text)
    assert main(["sweep", str(sw), "--out", str(tmp_path / "r.csv"), "--quiet"]) == 2
    assert where in _one_line(capsys.readouterr().err)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["sw.toml"]


@pytest.mark.parametrize(
    "ensemble,why",
    [('agents = 12\nclusters = 2\nseeds = {start = 0, count = 1000000}', "1000000 members"), ("agents = [100000]", "time and memory limits")],
    ids=["a-million-members", "100000-agents"],
)
@pytest.mark.slow
def test_a_sweep_above_the_limits_is_refused_with_its_estimate(ensemble: str, why: str, tmp_path: Path, capsys: pytest.CaptureFixture[str], no_cluster: None) -> None:
    sw = tmp_path / "sw.toml"
    sw.write_text(f'[ensemble]\ngenerator = "random-clustered"\n{ensemble}\n')
    assert main(["sweep", str(sw), "--out", str(tmp_path / "r.csv")]) == 2
    line = _one_line(capsys.readouterr().err)
    assert line.startswith("glocal-verify: error: sweep: estimated") and why in line and "--allow-large" in line


def test_a_sweep_too_small_for_workers_runs_in_this_process_and_says_so(tmp_path: Path, capsys: pytest.CaptureFixture[str], no_cluster: None) -> None:
    sw = tmp_path / "sw.toml"
    sw.write_bytes(fs.toml_dumps(fs.SWEEP_BASE).encode())
    assert main(["sweep", str(sw), "--out", str(tmp_path / "r.csv"), "--workers", "2", "--no-figures"]) == 0
    err = capsys.readouterr().err
    assert "in this process (workers would not pay off)" in err.splitlines()[0]
    assert (tmp_path / "r.csv").exists()


def test_quiet_means_quiet_for_a_sweep(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    sw = tmp_path / "sw.toml"
    sw.write_bytes(fs.toml_dumps(fs.SWEEP_BASE).encode())
    assert main(["sweep", str(sw), "--out", str(tmp_path / "r.csv"), "--quiet", "--no-figures"]) == 0
    assert all(ln.startswith("wrote ") for ln in capsys.readouterr().err.splitlines())


# --------------------------------------------------------------------------------------------
# options and library arguments


def test_an_exact_budget_of_1e16_or_inf_runs_instead_of_overflowing(capsys: pytest.CaptureFixture[str]) -> None:
    from glocal_verify.numerics.deadline import call_with_deadline

    assert call_with_deadline(lambda: 7, 1e16) == 7
    assert call_with_deadline(lambda: 7, math.inf) == 7
    assert main(["verify", "--example", "paper19", "--exact-budget", "inf", "--quiet", "--only", "privacy.*"]) == 0
    assert main(["verify", "--example", "paper19", "--exact-budget", "1e16", "--allow-large", "--quiet", "--only", "privacy.*"]) == 0


def test_a_refusal_never_prints_a_number_of_300_digits(capsys: pytest.CaptureFixture[str]) -> None:
    from glocal_verify.conditions.cost import format_seconds

    assert format_seconds(1e300) == "3.2e+292 years"
    assert main(["verify", "--example", "paper19", "--exact-budget", "1e300", "--quiet"]) == 2
    assert len(_one_line(capsys.readouterr().err)) < 400


def test_a_thread_count_beyond_4096_is_one_line(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["--threads", "9" * 80, "conditions"]) == 2
    assert "--threads: must be between 1 and 4096" in _one_line(capsys.readouterr().err)


def test_an_unreachable_scheduler_is_one_line(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    for address in ("tcp://127.0.0.1:1", "xyz"):
        assert main(["audit", str(_spec(tmp_path)), "--scheduler", address, "--quiet"]) == 2
        assert "cannot reach a Dask scheduler there" in _one_line(capsys.readouterr().err)


def _paper19() -> System:
    return System(load_example("paper19"))


LIBRARY_CALLS: list[tuple[str, Callable[[], Any]]] = [
    ("Tolerance(-1)", lambda: __import__("glocal_verify").Tolerance(-1.0)),
    ("Tolerance('x')", lambda: __import__("glocal_verify").Tolerance("x")),
    ("Tolerance(1e-9, inf)", lambda: __import__("glocal_verify").Tolerance(1e-9, math.inf)),
    ("Tolerance(nan)", lambda: __import__("glocal_verify").Tolerance(math.nan)),
    ("verify escalate ''", lambda: verify(_paper19(), ["privacy.kernel"], escalate="")),
    ("verify exact_budget nan", lambda: verify(_paper19(), ["privacy.kernel"], exact_budget=math.nan)),
    ("verify exact_budget 'x'", lambda: verify(_paper19(), ["privacy.kernel"], exact_budget="x")),
    ("verify fragile_below -1", lambda: verify(_paper19(), ["privacy.kernel"], fragile_below=-1)),
    ("verify tol 'x'", lambda: verify(_paper19(), ["privacy.kernel"], tol="x")),
    ("verify only 5", lambda: verify(_paper19(), 5)),
    ("verify None", lambda: verify(None)),
    ("audit max_attackers None", lambda: __import__("glocal_verify.design.audit", fromlist=["audit"]).audit(_paper19(), None)),
    ("audit max_attackers ''", lambda: __import__("glocal_verify.design.audit", fromlist=["audit"]).audit(_paper19(), "")),
    ("audit max_attackers -inf", lambda: __import__("glocal_verify.design.audit", fromlist=["audit"]).audit(_paper19(), -math.inf)),
    ("System(None)", lambda: System(None)),  # type: ignore[arg-type]
    ("System('spec.toml')", lambda: System("spec.toml")),  # type: ignore[arg-type]
]


@pytest.mark.parametrize("call", [c for _, c in LIBRARY_CALLS], ids=[n for n, _ in LIBRARY_CALLS])
def test_library_calls_outside_their_domain_raise_the_projects_argument_error(call: Callable[[], Any]) -> None:
    with pytest.raises(ArgumentError) as info:
        call()
    assert "\n" not in str(info.value) and isinstance(info.value, (ValueError, TypeError))


def test_a_system_of_an_empty_mapping_is_a_spec_error_naming_the_key() -> None:
    with pytest.raises(SpecError, match="missing required key 'format'"):
        System({})  # type: ignore[arg-type]


def test_verify_takes_one_condition_id_as_a_string() -> None:
    [r] = verify(_paper19(), "privacy.kernel").conditions
    assert r.id == "privacy.kernel"


# --------------------------------------------------------------------------------------------
# one output policy


WRITERS: list[tuple[str, Callable[[Path], list[str]]]] = [
    ("design", lambda spec: ["design", str(spec), "--quiet"]),
    ("audit", lambda spec: ["audit", str(spec), "--quiet"]),
    ("verify", lambda spec: ["verify", str(spec), "--quiet"]),
    ("draw", lambda spec: ["draw", str(spec)]),
    ("place-observers", lambda spec: ["place-observers", str(spec), "--quiet"]),
]


@pytest.mark.parametrize("attack", ["same", "hard-link", "sub-dot-dot"])
@pytest.mark.parametrize("writer", [w for _, w in WRITERS], ids=[n for n, _ in WRITERS])
def test_no_writing_command_overwrites_its_input_by_any_path(attack: str, writer: Callable[[Path], list[str]], tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]) -> None:
    spec = _spec(tmp_path)
    before = spec.read_bytes()
    monkeypatch.chdir(tmp_path)
    (tmp_path / "sub").mkdir()
    if attack == "hard-link":
        os.link(spec, tmp_path / "hl.toml")
    out = {"same": "spec.toml", "hard-link": "hl.toml", "sub-dot-dot": "sub/../spec.toml"}[attack]
    assert main(writer(Path("spec.toml")) + ["--out", out]) == 2
    assert "is an input of this command" in _one_line(capsys.readouterr().err)
    assert spec.read_bytes() == before


def test_a_sweep_never_overwrites_its_sweep_file(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    sw = tmp_path / "sw.csv"
    sw.write_bytes(fs.toml_dumps(fs.SWEEP_BASE).encode())
    before = sw.read_bytes()
    assert main(["sweep", str(sw), "--out", str(sw), "--quiet"]) == 2
    assert "is an input of this command" in _one_line(capsys.readouterr().err)
    assert sw.read_bytes() == before


def test_no_command_writes_through_a_symbolic_link_or_a_linked_folder(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    spec = _spec(tmp_path)
    sw = tmp_path / "sw.toml"
    sw.write_bytes(fs.toml_dumps(fs.SWEEP_BASE).encode())
    target = tmp_path / "target.csv"
    target.write_text("keep\n")
    (tmp_path / "link.csv").symlink_to(target)
    real = tmp_path / "real"
    real.mkdir()
    (tmp_path / "linkdir").symlink_to(real)
    runs = [
        ["sweep", str(sw), "--out", str(tmp_path / "link.csv"), "--quiet"],
        ["audit", str(spec), "--out", str(tmp_path / "linkdir") + "/", "--quiet"],
        ["audit", str(spec), "--figure", str(tmp_path / "linkdir" / "a.svg"), "--quiet"],
        ["design", str(spec), "--out", str(tmp_path / "linkdir" / "d.toml"), "--quiet"],
        ["simulate", str(spec), "--out", str(tmp_path / "linkdir"), "--no-figures", "--quiet"],
    ]
    for argv in runs:
        assert main(argv) == 2, argv
        assert "symbolic link" in _one_line(capsys.readouterr().err)
    assert target.read_text() == "keep\n" and list(real.iterdir()) == []


def test_an_audit_folder_is_written_all_or_nothing(tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]) -> None:
    import glocal_verify.reporting.figures.audit as af

    spec = _spec(tmp_path)

    def broken(result: Any, fmt: str = "svg") -> bytes:
        if fmt == "png":
            raise OSError(28, "No space left on device")
        return b"<svg/>"

    monkeypatch.setattr(af, "audit_figure_bytes", broken)
    out = tmp_path / "new" / "audit"
    assert main(["audit", str(spec), "--out", str(out) + "/", "--quiet"]) != 0
    capsys.readouterr()
    assert not (tmp_path / "new").exists()  # no staging folder, no empty folder


def test_a_sweep_into_a_full_disk_is_one_line_and_leaves_nothing_half_written(tmp_path: Path) -> None:
    case = fs.Case("output", "sweep", ["sweep", "sw.toml", "--out", "full/r.csv", "--quiet", "--no-figures"],
                   {"sw.toml": fs.toml_dumps(fs.SWEEP_BASE).encode()}, [("mkdir", "full")], protected=["sw.toml"], fsize=100)
    res = fs.run_case(case, 60)
    assert res.outcome == "clean-error", res.summary()
    assert "cannot write" in res.last_stderr_line and len(res.stderr_lines) == 1


# --------------------------------------------------------------------------------------------
# signals and child processes


@pytest.mark.parametrize("sig,code,line", [(signal.SIGTERM, 143, "terminated (SIGTERM)"), (signal.SIGHUP, 129, "hung up (SIGHUP)"), (signal.SIGINT, 130, "interrupted")])
def test_sigterm_and_sighup_stop_a_command_like_ctrl_c(sig: int, code: int, line: str, tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]) -> None:
    import glocal_verify.cli.verify as cv

    def stopped(*a: Any, **k: Any) -> Any:
        os.kill(os.getpid(), sig)
        time.sleep(5)  # the handler raises before this ends
        raise AssertionError("the signal did not stop the command")

    monkeypatch.setattr(cv, "make_report", stopped)
    out = tmp_path / "r.md"
    assert main(["verify", str(_spec(tmp_path)), "--out", str(out), "--quiet"]) == code
    assert _one_line(capsys.readouterr().err) == f"glocal-verify: {line}"
    assert not out.exists()
    assert signal.getsignal(signal.SIGTERM) is signal.SIG_DFL  # the handlers are restored



_SIGNAL_DURING_IMPORTS = """
import importlib.abc, os, signal, sys, time

class SignalDuringImport(importlib.abc.MetaPathFinder):
    def find_spec(self, name, path, target=None):
        if name == "glocal_verify.cli":
            os.kill(os.getpid(), {sig})
            time.sleep(10)
        return None

sys.meta_path.insert(0, SignalDuringImport())
sys.argv = ["glocal-verify", "verify", "--example", "paper19"]
from glocal_verify.__main__ import entry_point
sys.exit(entry_point())
"""


@pytest.mark.parametrize("sig,code,line", [(signal.SIGINT, 130, "interrupted"), (signal.SIGTERM, 143, "terminated (SIGTERM)"), (signal.SIGHUP, 129, "hung up (SIGHUP)")])
def test_a_stop_signal_during_the_command_lines_imports_is_one_line_without_a_traceback(sig: int, code: int, line: str) -> None:
    res = subprocess.run([sys.executable, "-c", _SIGNAL_DURING_IMPORTS.format(sig=int(sig))], capture_output=True, text=True, timeout=60)
    assert (res.returncode, res.stderr) == (code, f"glocal-verify: {line}\n")


def test_a_stop_signal_between_a_progress_line_and_its_newline_gets_a_line_of_its_own(monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]) -> None:
    # the campaign of 2026-12-05: SIGHUP while `audit` printed its estimate line fell between the
    # text and its newline, and the stop line went on the same line as the estimate
    import glocal_verify.cli.verify as cv

    def cut_short(*a: Any, **k: Any) -> Any:
        sys.stderr.write("glocal-verify: audit of 80 agents: estimated 3 min")  # the newline never came
        os.kill(os.getpid(), signal.SIGHUP)
        time.sleep(5)
        raise AssertionError("the signal did not stop the command")

    monkeypatch.setattr(cv, "make_report", cut_short)
    assert main(["verify", "--example", "paper19", "--quiet"]) == 129
    lines = [ln for ln in capsys.readouterr().err.splitlines() if ln.strip()]
    assert lines == ["glocal-verify: audit of 80 agents: estimated 3 min", "glocal-verify: hung up (SIGHUP)"]


def test_every_progress_line_is_written_with_its_newline_in_one_write(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    import io

    class Writes(io.StringIO):
        calls: list[str] = []

        def write(self, text: str) -> int:
            self.calls.append(text)
            return super().write(text)

    stream = Writes()
    monkeypatch.setattr(sys, "stderr", stream)
    assert main(["design", str(_spec(tmp_path)), "--out", str(tmp_path / "d.toml")]) in (0, 1)
    assert sys.stderr is stream  # the command's wrappers are gone
    assert any(c.startswith("design: auditing the spec as given") for c in stream.calls)
    assert all(c.endswith("\n") for c in stream.calls if c), [c for c in stream.calls if not c.endswith("\n")]


def test_a_stop_line_after_a_finished_line_adds_no_blank_line() -> None:
    import io

    from glocal_verify.runtime.lines import LineStream, write_line

    stream = LineStream(io.StringIO())
    write_line("design: auditing the design ...", stream)  # type: ignore[arg-type]
    write_line("glocal-verify: terminated (SIGTERM)", stream, fresh=True)  # type: ignore[arg-type]
    stream.write("  40%|####      | 4/10")  # a progress bar left mid-line
    write_line("glocal-verify: interrupted", stream, fresh=True)  # type: ignore[arg-type]
    assert stream._inner.getvalue().splitlines() == [
        "design: auditing the design ...", "glocal-verify: terminated (SIGTERM)", "  40%|####      | 4/10", "glocal-verify: interrupted",
    ]

_ORPHAN = r"""
import os, sys, time
sys.path.insert(0, {root!r})
from glocal_verify.numerics.deadline import call_with_deadline

def compute():
    with open({pidfile!r}, "w") as fh:
        fh.write(str(os.getpid()))
    time.sleep(600)

call_with_deadline(compute, 600.0)
"""


def _alive(pid: int) -> bool:
    try:
        with open(f"/proc/{pid}/stat") as fh:
            return fh.read().rsplit(")", 1)[1].split()[0] != "Z"
    except OSError:
        return False


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="the parent-death signal is Linux's prctl")
@pytest.mark.parametrize("sig", [signal.SIGKILL, signal.SIGTERM])
def test_a_forked_exact_computation_dies_with_its_parent(sig: int, tmp_path: Path) -> None:
    pidfile = tmp_path / "child.pid"
    p = subprocess.Popen([sys.executable, "-c", _ORPHAN.format(root=str(ROOT), pidfile=str(pidfile))], start_new_session=True)
    for _ in range(200):
        if pidfile.exists() and pidfile.read_text():
            break
        time.sleep(0.05)
    child = int(pidfile.read_text())
    os.kill(p.pid, sig)
    p.wait(30)
    for _ in range(40):
        if not _alive(child):
            break
        time.sleep(0.05)
    assert not _alive(child), "the forked computation outlived its parent"


def test_dask_workers_are_killed_when_the_command_stops() -> None:
    from glocal_verify.extra.dask import dask_client
    from glocal_verify.runtime.processes import Stopped

    pids: list[int] = []
    with pytest.raises(Stopped):
        with dask_client(None, 1) as client:
            pids += [int(p) for p in client.run(os.getpid).values()]
            raise Stopped(signal.SIGTERM)
    time.sleep(0.5)
    assert pids and not any(_alive(p) for p in pids)


def test_a_dashboard_port_in_use_gives_one_line() -> None:
    from glocal_verify.extra.dask import dask_client

    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        s.listen()
        port = s.getsockname()[1]
        lines: list[str] = []
        with dask_client(None, 1, dashboard=f"127.0.0.1:{port}", notice=lines.append):
            pass
    assert len(lines) == 1 and f"Port {port} is already in use" in lines[0] and "dashboard is at" in lines[0]


def test_a_reader_that_goes_away_ends_the_command_with_141_and_no_traceback() -> None:
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    p = subprocess.Popen([sys.executable, "-m", "glocal_verify.cli", "verify", "--example", "paper19", "--quiet"], stdout=subprocess.PIPE, stderr=subprocess.PIPE, env=env)
    assert p.stdout is not None and p.stderr is not None
    p.stdout.read(10)
    p.stdout.close()
    err = p.stderr.read().decode()
    assert p.wait(120) in (0, 141) and "Traceback" not in err


# --------------------------------------------------------------------------------------------
# progress and estimates


def test_a_silent_phase_gets_a_still_working_line() -> None:
    import io

    from glocal_verify.cli.heartbeat import Heartbeat

    saved = sys.stderr
    buf = io.StringIO()
    sys.stderr = buf
    try:
        with Heartbeat("glocal-verify", "verify", silence=0.3):
            print("checking switched-observability ...", file=sys.stderr)
            time.sleep(1.5)
    finally:
        sys.stderr = saved
    lines = buf.getvalue().splitlines()
    assert lines[0] == "checking switched-observability ..."
    assert any(ln.startswith('glocal-verify: still working, ') and '"checking switched-observability ..."' in ln for ln in lines[1:])


def test_a_design_over_500_safe_modes_is_refused_with_its_estimate() -> None:
    from glocal_verify.conditions.cost import SpecSizes, default_limits, estimate_design, refusal
    from glocal_verify.design.generators import random_clustered_spec

    est = estimate_design(SpecSizes.from_spec(random_clustered_spec(150, 3, seed=1, modes=500, monitors=40)))
    assert refusal(est, default_limits()) is not None
    assert "500 modes" in est.describe()


def test_design_says_which_step_it_is_in(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["design", str(_spec(tmp_path)), "--out", str(tmp_path / "d.toml")]) == 0
    err = capsys.readouterr().err
    for step in ("auditing the spec as given", "placing local observers", "auditing the design"):
        assert f"design: {step} ..." in err


def test_design_refuses_a_safe_mode_phase_above_the_limits_with_its_estimate_before_it_starts(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    from glocal_verify import config

    with config.override(safe_mode_check_seconds=60.0):  # a minute per attack set: far above 10 min for 28 sets
        assert main(["design", str(_spec(tmp_path)), "--out", str(tmp_path / "d.toml")]) == 2
    err = capsys.readouterr().err
    last = err.strip().splitlines()[-1]
    assert last.startswith("glocal-verify: error: design of 8 agents: estimated ") and "--allow-large" in last, last
    # refused by the up-front estimate of the whole design, which bounds the checks before any audit counts the sets
    assert re.search(r"checks of \d+ undetected attack sets", last), last
    assert "designing safe modes" not in err and not (tmp_path / "d.toml").exists()


def test_designs_monitor_step_is_estimated_per_round_and_per_unexposed_set() -> None:
    # the clustered check of 2026-12-06: a design of 42 agents spent 33 s per monitor round on
    # 107 unexposed sets, after an up-front estimate of 6 s that did not count the step
    from glocal_verify.conditions.cost import SpecSizes
    from glocal_verify.conditions.design_cost import estimate_monitor_step, estimate_safe_modes
    from glocal_verify.design.generators import random_clustered_spec

    sizes = SpecSizes.from_spec(random_clustered_spec(42, 4, seed=953938))
    one = estimate_monitor_step(sizes, 107, 1, exact=True)
    three = estimate_monitor_step(sizes, 107, 3, exact=True)
    start = three.seconds - sum(v for _, v in three.phases)  # the start-up constant, once
    assert abs((three.seconds - start) - 3 * (one.seconds - start)) <= 1e-9 * three.seconds
    assert 10.0 <= one.seconds <= 120.0 and "107 unexposed attack sets" in one.describe()
    assert one.seconds > estimate_safe_modes(sizes, 107, exact=True).seconds


@pytest.mark.slow
def test_safe_modes_for_120_targets_are_confirmed_without_an_exact_run_per_set(monkeypatch: pytest.MonkeyPatch) -> None:
    # the clustered check of 2026-12-05: a design of 80 agents with 2,393 targets confirmed
    # each claimed set with a checker run whose computed lambda0 = 0 could not be certified,
    # so every set went to a forked exact re-decision: more than 30 minutes
    import dataclasses
    import itertools

    import glocal_verify.numerics.deadline as deadline
    from glocal_verify.design import network
    from glocal_verify.design.generators import random_clustered_spec
    from glocal_verify.design.safe_modes import design_safe_modes, with_modes
    from glocal_verify.spec.types import AttackSpec

    from glocal_verify.design.pruning import Blueprint, Edit

    spec = network._velocity_only(random_clustered_spec(80, 5, seed=960675))
    obs, _, _ = network._observers(System(spec), 2000)
    spec = Blueprint(spec, observers=obs).build([Edit("observer", k) for k in obs])
    mid = System(spec)
    pairs = list(itertools.combinations(range(1, 17), 2))  # cluster P1: 116 of its 120 pairs are stealthy at lambda0 = 0

    def no_exact_run(*a: Any, **k: Any) -> Any:
        raise AssertionError("a forked exact re-decision")

    monkeypatch.setattr(deadline, "call_with_deadline", no_exact_run)
    ticks: list[tuple[int, int]] = []
    design = design_safe_modes(mid, pairs, None, 1, lambdas={F: 0j for F in pairs}, max_links=1, tick=lambda d, t: ticks.append((d, t)))
    (mode,) = design.modes
    assert len(mode.exposes) >= 100
    assert ticks[-1][0] == ticks[-1][1] and all(a[0] < b[0] for a, b in zip(ticks, ticks[1:]) if a[1] == b[1])
    monkeypatch.undo()
    base = with_modes(spec, [mode.mode_spec()], keep=False)
    for F in (mode.exposes[0], mode.exposes[len(mode.exposes) // 2], mode.exposes[-1]):  # the checker agrees
        rep = verify(System(dataclasses.replace(base, attack=AttackSpec("zda", F, lambda0=0j))), ["switching.avoids-attack"])
        assert [r.status.value for r in rep.conditions] == ["fails"], F

    # a mode that confirms none of its first CONFIRM_GIVE_UP claims is dropped unchecked beyond them
    from glocal_verify.design.safe_modes import CONFIRM_GIVE_UP, _Confirmations
    from glocal_verify.numerics.tolerance import DEFAULT_TOLERANCE

    # 496 sets of clusters P4, P5, far from the mode's link: none is confirmed (with the
    # completeness proof the rule's lambda0 = 0 is certified, so sets near the link would be)
    many = list(itertools.combinations(range(49, 81), 2))
    ticks.clear()
    confirm = _Confirmations(mid, False, {F: 7 + 0j for F in many}, DEFAULT_TOLERANCE, lambda d, t: ticks.append((d, t)))
    got, statuses = confirm(mode.links, "designed-1", many)
    assert got == [] and set(statuses.values()) == {"holds"}
    assert ticks[-1] == (CONFIRM_GIVE_UP, len(many))


@pytest.mark.slow
def test_sets_whose_exposure_stays_undecided_share_one_reason_in_the_design() -> None:
    # the clustered check of 2026-12-06: a design of 63 agents listed 150 requirements not met,
    # one per computed lambda0 the reasons quoted (-0.5-1.6583123951777j, -0.5-1.658312395177694j ...)
    from glocal_verify.design import network
    from glocal_verify.design.audit import audit
    from glocal_verify.design.generators import random_clustered_spec
    from glocal_verify.design.safe_modes import design_safe_modes

    from glocal_verify.design.pruning import Blueprint, Edit

    spec = network._velocity_only(random_clustered_spec(80, 5, seed=960675))
    obs, _, _ = network._observers(System(spec), 2000)
    spec = Blueprint(spec, observers=obs).build([Edit("observer", k) for k in obs])
    mid = System(spec)
    rows = audit(mid, 2, list(range(17, 49))).rows
    targets = [r.actuators for r in rows if r.verdict != "detected" and r.stealthy is True and not r.exposed_by_modes]
    lambdas = {r.actuators: r.lambda0 for r in rows if r.lambda0 is not None}
    assert sum(1 for F in targets if lambdas[F].imag != 0) >= 2  # computed complex zeros, not certifiable
    design = design_safe_modes(mid, targets, None, 3, lambdas=lambdas, max_links=1)
    undecided = [why for why in design.unexposed.values() if "undecided" in why]
    assert len(undecided) >= 2 and len(set(undecided)) == 1
    assert not any("-0.5" in why for why in design.unexposed.values())


# --------------------------------------------------------------------------------------------
# the exact path


def test_the_exact_witness_of_a_zero_with_huge_coefficients_is_evaluated_not_asserted() -> None:
    import flint
    import numpy as np

    from glocal_verify.numerics.cluster_transfer import eval_normalized
    from glocal_verify.numerics.pencil_exact import RootEnclosures

    f = flint.fmpq_poly([2, 0, 1])  # s^2 + 2, roots +-i sqrt(2)
    big = flint.fmpz(10) ** 20_000  # a common factor a fraction-free elimination leaves
    v = [flint.fmpq_poly([3 * big, big]), flint.fmpq_poly([7 * big])]
    x = eval_normalized(v, f, 1.414j, RootEnclosures(f))
    assert x is not None
    root = 1j * math.sqrt(2)
    assert np.allclose(x, np.array([3 + root, 7]) / 7)


@pytest.mark.slow
def test_verify_exact_and_design_finish_on_a_generated_clustered_network(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    from glocal_verify.design.generators import random_clustered_spec

    spec = tmp_path / "r30.toml"
    spec.write_text(random_clustered_spec(30, 3, seed=60).to_toml())
    assert main(["verify", str(spec), "--exact", "--quiet", "--out", str(tmp_path / "r.md")]) in (0, 1)
    # 1: a partial design (written, with what it could not meet), as docs/audit.md says
    assert main(["design", str(spec), "--quiet", "--out", str(tmp_path / "d.toml")]) in (0, 1, 2)
    err = capsys.readouterr().err
    assert "internal error" not in err and "Traceback" not in err


def test_a_stop_signal_that_lands_in_a_finalizer_still_stops_the_command(capsys: pytest.CaptureFixture[str]) -> None:
    # the campaign of 2026-12-05 (#5007): SIGTERM during `simulate --cases` printed a traceback
    # ("Exception ignored in ...") and the command went on to exit 0
    import gc

    from glocal_verify.runtime.processes import Stopped, stop_on_signals

    class Finalized:
        def __del__(self) -> None:
            os.kill(os.getpid(), signal.SIGTERM)
            time.sleep(0.05)  # the handler runs here, inside the finalizer

    went_on = []
    with pytest.raises(Stopped) as stop:
        with stop_on_signals():
            Finalized()
            gc.collect()
            went_on.append(True)
    assert went_on and stop.value.exit_code == 128 + signal.SIGTERM
    assert "Exception ignored" not in capsys.readouterr().err


def test_a_stop_signal_that_surfaces_as_an_import_error_is_reported_as_the_stop(monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]) -> None:
    # the campaign of 2026-12-05 (#480): SIGHUP 0.3 s into place-observers landed in numpy's
    # import, which turned it into "ImportError: numpy._core.multiarray failed to import"
    # (internal error, exit 70)
    import glocal_verify.cli as cli
    from glocal_verify.runtime.processes import Stopped

    def importing() -> Any:
        try:
            os.kill(os.getpid(), signal.SIGHUP)
            time.sleep(0.05)
        except Stopped:
            raise ImportError("numpy._core.multiarray failed to import") from None
        raise AssertionError("the signal did not arrive")

    monkeypatch.setattr(cli, "build_parser", importing)
    assert main(["conditions"]) == 128 + signal.SIGHUP
    err = capsys.readouterr().err
    assert "hung up (SIGHUP)" in _one_line(err) and "internal error" not in err


def test_a_stop_signal_after_the_commands_last_write_leaves_its_exit_status() -> None:
    # the campaign of 2026-12-06: a SIGTERM to design during the interpreter's shutdown (its
    # work done, the handlers restored to the default) killed it with -15, no stop line
    import subprocess
    import sys

    code = (
        "import os, signal\n"
        "from glocal_verify.runtime.processes import stop_on_signals\n"
        "with stop_on_signals(final=True):\n"
        "    pass\n"
        "os.kill(os.getpid(), signal.SIGTERM)\n"
        "print('ended by itself')\n"
    )
    p = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
    assert p.returncode == 0 and p.stdout.strip() == "ended by itself", (p.returncode, p.stderr)
    # the command-line entry point asks for it; an in-process main() restores the handlers
    import signal

    from glocal_verify.cli import main

    before = signal.getsignal(signal.SIGTERM)
    assert main(["conditions"]) == 0
    assert signal.getsignal(signal.SIGTERM) == before
