"""Every kind of bad input gets one line naming the key path, exit code 2, and no traceback."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from glocal_verify import GlocalVerifyError, SpecError, loads_spec
from glocal_verify.spec import spec_from_dict, spec_from_graph
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
    # numeric domains (glocal_verify.spec.types): weights, gains, lambda0, poles, times, seed
    ("weight-1e30", BASE.replace("[2, 3, 2.5]", "[2, 3, 1e30]"), "graph.edges[1][2]", "must be at most 1e+12"),
    ("weight-1e-30", BASE.replace("[2, 3, 2.5]", "[2, 3, 1e-30]"), "graph.edges[1][2]", "must be at least 1e-12"),
    ("weight-int64max", BASE.replace("[2, 3, 2.5]", f"[2, 3, {2**63 - 1}]"), "graph.edges[1][2]", "must be at most 1e+12"),
    ("weight-10e400", BASE.replace("[2, 3, 2.5]", f"[2, 3, {10**400}]"), "graph.edges[1][2]", "must be at most 1e+12"),
    ("weight-spread", BASE.replace("[2, 3, 2.5]", "[2, 3, 1e-7]").replace("[3, 4]", "[3, 4, 1e6]"), "graph.edges[2][2]", "within a factor 1e+12"),
    ("weight-spread-across-modes", BASE.replace("[2, 3, 2.5]", "[2, 3, 1e-7]").replace("add = [[1, 4]]", "add = [[1, 4, 1e6]]"), "modes[0].add[0][2]", "within a factor 1e+12"),
    ("weight-string-huge-exponent", BASE.replace("[2, 3, 2.5]", '[2, 3, "1e9999999"]'), "graph.edges[1][2]", "far outside the allowed range"),
    ("weight-string-tiny-exponent", BASE.replace("[2, 3, 2.5]", '[2, 3, "1e-9999999"]'), "graph.edges[1][2]", "far outside the allowed range"),
    ("weight-string-huge-rational", BASE.replace("[2, 3, 2.5]", '[2, 3, "%s/7"]' % ("9" * 5000)), "graph.edges[1][2]", "number text too long"),
    ("weight-float-overflow", BASE.replace("[2, 3, 2.5]", "[2, 3, 1e9999999]"), "graph.edges[1][2]", "finite"),
    ("weight-5000-digit-integer", BASE.replace("[2, 3, 2.5]", "[2, 3, %s]" % ("9" * 5000)), "", "not valid TOML"),
    ("gamma-int64max", BASE.replace('name = "base"', f'name = "base"\n[dynamics]\ngamma = {2**63 - 1}'), "dynamics.gamma", "must be at most 1e+12"),
    ("alpha-minus-1e308", BASE.replace('name = "base"', 'name = "base"\n[dynamics]\nalpha = -1e308'), "dynamics.alpha", "must be > 0"),
    ("gamma-tiny-string", BASE.replace('name = "base"', 'name = "base"\n[dynamics]\ngamma = "1e-300"'), "dynamics.gamma", "must be at least 1e-12"),
    ("gains-spread", BASE.replace('name = "base"', 'name = "base"\n[dynamics]\nalpha = 1e7\ngamma = 1e-7'), "dynamics.gamma", "differ by more than a factor"),
    ("closed-loop-too-stiff", BASE.replace('name = "base"', 'name = "base"\n[dynamics]\ngamma = 1e6').replace("[2, 3, 2.5]", "[2, 3, 1e-3]"), "dynamics.gamma", "closed-loop eigenvalues would spread"),
    ("closed-loop-too-stiff-by-weights", BASE.replace("[2, 3, 2.5]", "[2, 3, 1e-6]").replace("[3, 4]", "[3, 4, 1e6]").replace('name = "base"', 'name = "base"\n[dynamics]\ngamma = 1e-4'), "dynamics.gamma", "closed-loop eigenvalues would spread"),
    ("lambda0-minus-1e308", BASE + "lambda0 = -1e308\n", "attack.lambda0", "must be at least -1e+06"),
    ("lambda0-complex-huge", BASE + "lambda0 = [1e308, -1e308]\n", "attack.lambda0[0]", "must be at most 1e+06"),
    ("lambda0-string-huge-exponent", BASE + 'lambda0 = "1e9999999"\n', "attack.lambda0", "far outside the allowed range"),
    ("pole-huge", BASE.replace("center = 2", "center = 2\npoles = [-1e308, -1]"), "clusters[0].observers[0].poles[0]", "must lie in [-1e+06, -1e-06]"),
    ("pole-denormal", BASE.replace("center = 2", "center = 2\npoles = [-1, -5e-324]"), "clusters[0].observers[0].poles[1]", "must lie in [-1e+06, -1e-06]"),
    ("horizon-1e16", BASE + "[simulation]\nhorizon = 1e16\n", "simulation.horizon", "must be at most 1e+06"),
    ("step-1e-12", BASE + "[simulation]\nstep = 1e-12\n", "simulation.step", "must be at least 1e-06"),
    ("step-denormal", BASE + "[simulation]\nstep = 5e-324\n", "simulation.step", "must be at least 1e-06"),
    ("samples-too-many", BASE + "[simulation]\nhorizon = 1e6\nstep = 1e-3\n", "simulation.step", "samples"),
    ("start-10e400", BASE + f"start = {10**400}\n", "attack.start", "must be at most 1e+06"),
    ("switch-time-1e308", BASE + '[switching]\nmode = "s1"\ntime = 1e308\n', "switching.time", "must be at most 1e+06"),
    ("dwell-tiny", BASE + '[switching]\nsequence = [{mode = "s1", duration = 1e-300}]\n', "switching.sequence[0].duration", "must be at least 1e-06"),
    ("seed-negative", BASE + "[simulation]\nseed = -1\n", "simulation.seed", "must be in [0, 2**63 - 1]"),
    ("seed-huge", BASE + f"[simulation]\nseed = {10**30}\n", "simulation.seed", "must be in [0, 2**63 - 1]"),
    ("amplitude-1e308", BASE + "amplitude = 1e308\n", "attack.amplitude", "must be at most 1e+12"),
    # sizes, nesting, labels
    ("nodes-int64max", BASE.replace("nodes = 6", f"nodes = {2**63 - 1}"), "graph.nodes", "too many agents"),
    ("nodes-float", BASE.replace("nodes = 6", "nodes = 6.0"), "graph.nodes", "expected an integer count"),
    ("nodes-list-too-long", BASE.replace("nodes = 6", f"nodes = {list(range(1, 100_002))}"), "graph.nodes", "too many entries"),
    ("deep-edges-10000", BASE.replace("edges = [[1, 2]", "edges = [" + "[" * 10_000 + "1" + "]" * 10_000 + ", [1, 2]"), "graph.edges", "nested deeper than 64"),
    ("deep-monitor-900", BASE.replace("velocities = [3, 6]", "velocities = " + "[" * 900 + "1" + "]" * 900), "monitor.velocities", "nested deeper than 64"),
    ("deep-monitor-100", BASE.replace("velocities = [3, 6]", "velocities = " + "[" * 100 + "1" + "]" * 100), "monitor.velocities[0]", "nested deeper than 64"),
    ("labels-1-and-string-1", BASE.replace("nodes = 6\n", 'nodes = [1, "1", 2, 3, 4, 5, 6]\n'), "graph.nodes[1]", "ambiguous"),
    ("label-too-long", BASE.replace("nodes = 6\n", 'nodes = ["%s", 2, 3, 4, 5, 6, 1]\n' % ("L" * 300)), "graph.nodes[0]", "too long"),
    ("label-nul-character", BASE.replace("nodes = 6\n", 'nodes = ["a\\u0000b", 1, 2, 3, 4, 5, 6]\n'), "graph.nodes[0]", "NUL characters"),
    ("label-float", BASE.replace("center = 2", "center = 2.0"), "clusters[0].observers[0].center", "expected an integer or string label"),
    ("mode-name-nul", BASE.replace('name = "s1"', 'name = "a\\u0000b"'), "modes[0].name", "NUL characters"),
    ("system-name-too-long", BASE.replace('name = "base"', 'name = "%s"' % ("N" * 100_000)), "name", "too long"),
    ("long-missing-node", BASE.replace("center = 2", 'center = "%s"' % ("G" * 100_000)), "clusters[0].observers[0].center", "is not in the graph"),
    ("bad-item-late-in-a-long-array", BASE.replace("[5, 6], [6, 1]", "[5, 6], [6, 1], [1, true]"), "graph.edges[6][1]", "unexpected value True"),
    ("too-many-switching-entries", BASE + "[switching]\nsequence = [" + ", ".join(['{mode = "s1", duration = 1}'] * 10_001) + "]\n", "switching.sequence", "too many entries"),
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
    assert len(lines[0]) <= len(str(f)) + 300, "echoed values are cut to about 80 characters"
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


# --------------------------------------------------------------------------------------------
# library calls: only GlocalVerifyError subclasses, and what Python callers naturally pass


@pytest.mark.parametrize("text", [None, 123, 4.5, ["format = 1"], object()], ids=["none", "int", "float", "list", "object"])
def test_loads_spec_refuses_what_is_not_text_with_a_spec_error(text: object) -> None:
    with pytest.raises(SpecError, match="expected TOML text"):
        loads_spec(text)  # type: ignore[arg-type]


def test_loads_spec_reads_utf8_bytes_and_refuses_other_bytes() -> None:
    assert loads_spec(BASE.encode("utf-8")).nodes == (1, 2, 3, 4, 5, 6)
    with pytest.raises(SpecError, match="not UTF-8"):
        loads_spec(b"\xff\xfe format = 1")


@pytest.mark.parametrize("data", [None, [1, 2], "format = 1", 7], ids=["none", "list", "str", "int"])
def test_spec_from_dict_refuses_what_is_not_a_mapping_with_a_spec_error(data: object) -> None:
    with pytest.raises(SpecError, match="expected object"):
        spec_from_dict(data)  # type: ignore[arg-type]


def test_a_mapping_with_non_string_keys_or_a_cycle_is_one_spec_error() -> None:
    with pytest.raises(SpecError, match="keys must be strings"):
        spec_from_dict({"format": 1, 1: 2, "graph": {"nodes": 3, "edges": []}})
    edges: list[object] = []
    edges.append(edges)
    with pytest.raises(SpecError, match=r"graph\.edges\[0\]: arrays nested deeper than 64 levels"):
        spec_from_dict({"format": 1, "graph": {"nodes": 3, "edges": edges}})


def test_numpy_numbers_fractions_and_decimals_are_read_exactly_as_weights_gains_and_labels() -> None:
    from decimal import Decimal
    from fractions import Fraction

    import networkx as nx
    import numpy as np

    g = nx.Graph()
    g.add_edge(np.int64(1), np.int64(2), weight=np.float64(0.5))
    g.add_edge(np.int64(2), np.int64(3), weight=Fraction(1, 3))
    g.add_edge(np.int64(3), np.int64(4), weight=Decimal("0.25"))
    g.add_edge(np.int64(4), np.int64(1), weight=np.int32(2))
    spec = spec_from_graph(g, alpha=np.float64(2.0), gamma=Decimal("1.5"), monitor_velocities=[np.int64(1)])
    assert spec.nodes == (1, 2, 3, 4) and all(type(n) is int for n in spec.nodes)
    assert [e.weight for e in spec.edges] == [Fraction(1, 2), Fraction(2), Fraction(1, 3), Fraction(1, 4)]
    assert (spec.alpha, spec.gamma) == (Fraction(2), Fraction(3, 2))
    data = {
        "format": 1,
        "dynamics": {"alpha": Fraction(1, 3), "gamma": np.float32(0.5)},
        "graph": {"nodes": np.int64(3), "edges": [(np.int64(1), np.int64(2), Decimal("0.1")), (2, 3)]},
        "monitor": {"velocities": [np.int64(3)]},
    }
    spec = spec_from_dict(data)
    assert spec.edges[0].weight == Fraction(1, 10) and spec.alpha == Fraction(1, 3) and spec.gamma == Fraction(1, 2)
    assert spec.monitor.velocities == (3,)


def _graph(*edges: tuple[object, ...]) -> object:
    import networkx as nx

    g = nx.Graph()
    for e in edges:
        g.add_edge(e[0], e[1], **({"weight": e[2]} if len(e) > 2 else {}))
    return g


@pytest.mark.parametrize(
    "make,fragment",
    [
        (lambda: _graph((1, 2), (2, 2)), "self-loop at node 2"),
        (lambda: _graph((1, 2, -1), (2, 3)), "must be > 0"),
        (lambda: _graph((1, 2, float("nan")), (2, 3)), "finite"),
        (lambda: _graph((1, 2, 1e30), (2, 3)), "must be at most 1e+12"),
        (lambda: _graph((1, 2, [1]), (2, 3)), "expected number"),
        (lambda: _graph((1, "1"), (1, 2)), "ambiguous"),
        # a tuple label is refused before its text could collide with the string "(1, 2)"
        (lambda: _graph(((1, 2), 3), ("(1, 2)", 3)), "node (1, 2) is a tuple"),
        (lambda: __import__("networkx").MultiGraph([(1, 2), (1, 2)]), "multigraph"),
        (lambda: __import__("networkx").DiGraph([(1, 2)]), "undirected"),
        (lambda: [(1, 2)], "expected a networkx.Graph"),
    ],
    ids=["self-loop", "negative", "nan", "huge", "list-weight", "1-and-'1'", "str-collision", "multigraph", "digraph", "not-a-graph"],
)
def test_spec_from_graph_raises_a_spec_error_for_graphs_it_cannot_take(make: object, fragment: str) -> None:
    with pytest.raises(SpecError) as info:
        spec_from_graph(make())  # type: ignore[operator]
    assert fragment in str(info.value)


def test_spec_from_graph_raises_a_spec_error_for_malformed_keyword_arguments() -> None:
    import networkx as nx

    g = nx.path_graph([1, 2, 3])
    with pytest.raises(SpecError, match=r"modes\[0\]\.add\[0\]: an edge is"):
        spec_from_graph(g, modes={"m": {"add": [(1,)]}})
    with pytest.raises(SpecError, match=r"modes\[0\]\.add: expected a list"):
        spec_from_graph(g, modes={"m": {"add": 5}})
    with pytest.raises(SpecError, match=r"monitor\.velocities\[0\]: unexpected value \[1\]"):
        spec_from_graph(g, monitor_velocities=[[1]])
    with pytest.raises(SpecError, match="attack: expected a mapping"):
        spec_from_graph(g, attack=[1])  # type: ignore[arg-type]


def test_an_error_late_in_a_long_array_names_its_index() -> None:
    n = 10_000
    edges = [[k, k + 1] for k in range(1, n)]
    data = {"format": 1, "graph": {"nodes": n, "edges": edges}, "monitor": {"velocities": [1]}}
    assert len(spec_from_dict(data).edges) == n - 1
    edges[9_000] = [9_001, "x"]
    with pytest.raises(SpecError, match=r"graph\.edges\[9000\]\[1\]: node 'x' is not in the graph"):
        spec_from_dict(data)
    edges[9_000] = [9_001, 9_002, 1, 1]
    with pytest.raises(SpecError, match=r"graph\.edges\[9000\]: an edge is \[i, j\]"):
        spec_from_dict(data)
    edges[9_000] = [9_001, 9_002, "abc"]
    with pytest.raises(SpecError, match=r"graph\.edges\[9000\]\[2\]: unexpected value 'abc'"):
        spec_from_dict(data)


def test_validation_leaves_the_callers_mapping_unchanged() -> None:
    import copy
    import tomllib

    data = tomllib.loads(BASE)
    before = copy.deepcopy(data)
    spec_from_dict(data)
    assert data == before


def test_a_ten_thousand_agent_spec_round_trips_through_the_loader() -> None:
    from glocal_verify.design.generators import random_clustered_spec
    from glocal_verify.spec import dump_spec

    spec = random_clustered_spec(10_000, 50, seed=1)
    assert loads_spec(dump_spec(spec), source=spec.source) == spec


def test_every_echoed_value_is_cut_to_about_eighty_characters() -> None:
    for text in (
        BASE.replace("center = 2", 'center = "%s"' % ("G" * 100_000)),
        BASE.replace("[2, 3, 2.5]", "[2, 3, %s]" % (10**400)),
        BASE.replace('kind = "zda"', 'kind = "%s"' % ("z" * 5000)),
        BASE.replace("velocities = [3, 6]", "velocities = [3, 6, %r]" % ("v" * 5000)),
    ):
        with pytest.raises(SpecError) as info:
            loads_spec(text)
        assert len(str(info.value)) < 250, str(info.value)


@pytest.mark.parametrize(
    "kwargs,path",
    [({"n": 3}, "n"), ({"n": 10**9}, "n"), ({"n": 12, "clusters": 0}, "clusters"), ({"n": 12, "chords": float("nan")}, "chords"),
     ({"n": 12, "horizon": 1e30}, "horizon"), ({"n": 12, "max_weight": 0}, "max_weight"), ({"n": 4, "clusters": 2}, "attack")],
    ids=["n-small", "n-huge", "no-cluster", "nan-chords", "huge-horizon", "zero-weight", "no-room-for-the-attack"],
)
def test_the_random_generator_refuses_arguments_outside_their_domain(kwargs: dict[str, object], path: str) -> None:
    from glocal_verify.design.generators import random_clustered_spec

    with pytest.raises(SpecError) as info:
        random_clustered_spec(**kwargs)  # type: ignore[arg-type]
    assert info.value.path == path


def test_simulate_refuses_a_sample_count_it_cannot_allocate_before_allocating(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    f = tmp_path / "big.toml"
    f.write_text(BASE + "[simulation]\nhorizon = 1e5\nstep = 1e-3\n")
    assert main(["simulate", str(f), "--no-figures", "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "simulation too large" in err[0]
    assert not (tmp_path / "out").exists() or not any((tmp_path / "out").iterdir())


def test_a_graph_with_tuple_labels_is_refused_with_the_way_to_relabel_it() -> None:
    import networkx as nx

    from glocal_verify.spec import dump_spec, loads_spec

    with pytest.raises(SpecError) as info:
        spec_from_graph(nx.grid_2d_graph(2, 2), monitor_velocities=[(0, 0)])
    text = str(info.value)
    assert "graph.nodes[0]" in text and "(0, 0)" in text and "tuple" in text and "relabel" in text
    assert len(text.splitlines()) == 1
    # the two relabelings the message proposes are accepted and round-trip exactly
    for G in (nx.convert_node_labels_to_integers(nx.grid_2d_graph(2, 2), first_label=1), nx.relabel_nodes(nx.grid_2d_graph(2, 2), str)):
        spec = spec_from_graph(G, monitor_velocities=[next(iter(G.nodes))])
        assert loads_spec(dump_spec(spec), source=spec.source) == spec
    with pytest.raises(SpecError, match=r"monitor\.velocities\[0\]"):
        spec_from_graph(nx.path_graph([1, 2, 3]), monitor_velocities=[(1, 2)])


def test_every_bundled_example_and_every_written_spec_ends_with_one_newline() -> None:
    from glocal_verify.spec import dump_spec
    from glocal_verify.spec.examples import example_names, example_text, load_example

    for name in example_names():
        for text in (example_text(name), dump_spec(load_example(name))):
            assert text.endswith("\n") and not text.endswith("\n\n"), name
