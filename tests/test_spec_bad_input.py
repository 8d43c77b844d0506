"""Every kind of bad input gets one line naming the key path, exit code 2, and no traceback."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from glocal_verify import GlocalVerifyError, SpecError, loads_spec
from glocal_verify.cli import main

BASE = """
format = 1
name = "base"
[graph]
nodes = 6
edges = [[1, 2], [2, 3, 2.5], [3, 4], [4, 5], [5, 6], [6, 1]]
[[modes]]
name = "s1"
add = [[1, 4]]
remove = [[1, 2]]
[[clusters]]
name = "A"
nodes = [1, 2, 3]
[[clusters.observers]]
center = 2
[[clusters]]
name = "B"
nodes = [4, 5, 6]
[monitor]
positions = []
velocities = [3, 6]
[attack]
kind = "zda"
actuators = [1]
"""

# (case id, text, expected key path, fragment of the problem)
CASES = [
    ("not-toml", "format = 1\n[graph\nnodes = 3", "", "not valid TOML"),
    ("missing-graph", "format = 1\nname = 'x'\n", "<top>", "missing required key 'graph'"),
    ("format-2", BASE.replace("format = 1", "format = 2"), "format", "only format 1"),
    ("unknown-node-edge", BASE.replace("[5, 6], [6, 1]", "[5, 6], [6, 9]"), "graph.edges[5][1]", "node 9 is not in the graph"),
    ("unknown-node-mode", BASE.replace("add = [[1, 4]]", "add = [[1, 40]]"), "modes[0].add[0][1]", "node 40 is not in the graph"),
    ("unknown-node-cluster", BASE.replace("nodes = [4, 5, 6]", "nodes = [4, 5, 6, 7]"), "clusters[1].nodes[3]", "node 7 is not in the graph"),
    ("unknown-node-monitor", BASE.replace("velocities = [3, 6]", "velocities = [3, 60]"), "monitor.velocities[1]", "node 60 is not in the graph"),
    ("unknown-node-attack", BASE.replace("actuators = [1]", "actuators = [25]"), "attack.actuators[0]", "node 25 is not in the graph"),
    ("self-loop", BASE.replace("[3, 4], [4, 5]", "[3, 3], [4, 5]"), "graph.edges[2]", "self-loop"),
    ("duplicate-edge", BASE.replace("[3, 4], [4, 5]", "[3, 4], [4, 3]"), "graph.edges[3]", "duplicate edge"),
    ("weight-zero", BASE.replace("[2, 3, 2.5]", "[2, 3, 0]"), "graph.edges[1][2]", "must be > 0"),
    ("weight-negative", BASE.replace("[2, 3, 2.5]", "[2, 3, -1]"), "graph.edges[1][2]", "must be > 0"),
    ("weight-nan", BASE.replace("[2, 3, 2.5]", "[2, 3, nan]"), "graph.edges[1][2]", "finite"),
    ("weight-inf", BASE.replace("[2, 3, 2.5]", "[2, 3, inf]"), "graph.edges[1][2]", "finite"),
    ("remove-missing-edge", BASE.replace("remove = [[1, 2]]", "remove = [[1, 3]]"), "modes[0].remove[0]", "is not in the graph"),
    ("clusters-overlap", BASE.replace("nodes = [4, 5, 6]", "nodes = [3, 4, 5, 6]"), "clusters[1].nodes[0]", "already in cluster 'A'"),
    ("clusters-not-covering", BASE.replace("nodes = [4, 5, 6]", "nodes = [4, 5]"), "clusters", "do not cover node(s) 6"),
    ("empty-cluster", BASE.replace("nodes = [4, 5, 6]", "nodes = []"), "clusters[1].nodes", "at least one node"),
    ("center-outside-cluster", BASE.replace("center = 2", "center = 5"), "clusters[0].observers[0].center", "not in cluster 'A'"),
    ("unknown-attack-kind", BASE.replace('kind = "zda"', 'kind = "replay"'), "attack.kind", "unknown attack kind"),
    ("unknown-key", BASE.replace("[monitor]", "[monitor]\nspeeds = [1]"), "monitor.speeds", "unknown key"),
    ("edge-wrong-arity", BASE.replace("[3, 4], [4, 5]", "[3, 4, 1, 2], [4, 5]"), "graph.edges[2]", "an edge is [i, j]"),
    ("alpha-negative", BASE.replace('name = "base"', 'name = "base"\n[dynamics]\nalpha = -1.0'), "dynamics.alpha", "must be > 0"),
    ("add-existing-edge", BASE.replace("add = [[1, 4]]", "add = [[3, 4]]"), "modes[0].add[0]", "already in the graph"),
    ("switching-unknown-mode", BASE + '\n[switching]\nmode = "nope"\ntime = 1.0\n', "switching.mode", "no safe mode named 'nope'"),
    ("string-weight-garbage", BASE.replace("[2, 3, 2.5]", '[2, 3, "1/0"]'), "graph.edges[1][2]", "cannot read"),
]


def test_the_base_spec_is_valid() -> None:
    spec = loads_spec(BASE)
    assert spec.nodes == (1, 2, 3, 4, 5, 6)


@pytest.mark.parametrize("case,text,path,fragment", CASES, ids=[c[0] for c in CASES])
def test_library_raises_a_spec_error_naming_the_key_path(case: str, text: str, path: str, fragment: str) -> None:
    with pytest.raises(SpecError) as info:
        loads_spec(text, source="bad.toml")
    err = info.value
    assert isinstance(err, GlocalVerifyError) and isinstance(err, ValueError)
    assert err.path == path, str(err)
    assert fragment in err.problem, str(err)
    assert str(err).startswith("bad.toml: ")


@pytest.mark.parametrize("case,text,path,fragment", CASES, ids=[c[0] for c in CASES])
def test_cli_prints_one_line_and_exits_2(case: str, text: str, path: str, fragment: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    f = tmp_path / "bad.toml"
    f.write_text(text)
    code = main(["verify", str(f)])
    out, err = capsys.readouterr()
    assert code == 2
    assert out == ""
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    assert path in lines[0] and fragment in lines[0]
    assert "Traceback" not in err


def test_a_missing_file_is_a_clear_error(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["verify", str(tmp_path / "nope.toml")]) == 2
    assert "file not found" in capsys.readouterr().err


def test_the_installed_command_shows_no_traceback_on_bad_input(tmp_path: Path) -> None:
    f = tmp_path / "bad.toml"
    f.write_text(BASE.replace("center = 2", "center = 25"))
    proc = subprocess.run([sys.executable, "-m", "glocal_verify.cli", "verify", str(f)], capture_output=True, text=True)
    assert proc.returncode == 2
    assert "clusters[0].observers[0].center: node 25 is not in the graph" in proc.stderr
    assert "Traceback" not in proc.stderr


def test_usage_errors_exit_2(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["verify"]) == 2
    assert main(["verify", "--example", "paper19", "--format", "pdf"]) == 2
    assert main(["verify", "--example", "nope"]) == 2
    assert "no bundled example named 'nope'" in capsys.readouterr().err


def test_a_disconnected_graph_is_refused_where_connectivity_is_assumed() -> None:
    from glocal_verify import System

    text = BASE.replace("[5, 6], [6, 1]", "[5, 6]").replace("[3, 4], [4, 5]", "[4, 5]")
    system = System(loads_spec(text.replace("remove = [[1, 2]]", "remove = []"), source="d.toml"))
    with pytest.raises(SpecError, match="graph: the normal graph is disconnected"):
        system.require_connected("simulation")
