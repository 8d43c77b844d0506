"""Fitting the user's tools: python-control export, TOML writing, graph files."""

from __future__ import annotations

import math
from fractions import Fraction
from pathlib import Path
from typing import Any

import control
import networkx as nx
import numpy as np
import pytest
import scipy.linalg
from hypothesis import given, settings
from hypothesis import strategies as st

from glocal_verify import SpecError, System, load_example, loads_spec, random_clustered_spec, spec_from_graph
from glocal_verify.errors import ModelError
from glocal_verify.simulation.attacks import zda_attack
from glocal_verify.simulation.engine import simulate
from glocal_verify.simulation.schedule import Schedule, random_initial_state
from glocal_verify.spec.graph_files import load_graph
from glocal_verify.spec.types import SystemSpec
from glocal_verify.spec.writer import dump_spec


@pytest.fixture(scope="module")
def paper19() -> System:
    return System(load_example("paper19"))


# --------------------------------------------------------------------------------------------
# python-control


def test_the_statespace_has_the_closed_loop_matrices_and_named_signals(paper19: System) -> None:
    for mode in paper19.modes:
        ss = paper19.to_statespace(mode)
        assert np.array_equal(ss.A, paper19.A(mode))
        assert np.array_equal(ss.B, paper19.B()) and np.array_equal(ss.C, paper19.C())
        assert not np.any(ss.D)
    ss = paper19.to_statespace("case-2")
    assert ss.input_labels == ["u:3", "u:4"]
    assert ss.output_labels == ["v:7", "v:12", "v:14"]
    assert ss.state_labels[:2] == ["x:1", "x:2"] and ss.state_labels[19] == "v:1"


def test_a_spec_without_attack_or_monitors_gives_a_statespace_without_inputs_or_outputs() -> None:
    ss = System(spec_from_graph(nx.path_graph([1, 2, 3]))).to_statespace()
    assert (ss.nstates, ss.ninputs, ss.noutputs) == (6, 0, 0)


def test_an_unknown_mode_is_a_model_error(paper19: System) -> None:
    with pytest.raises(ModelError, match="no mode named"):
        paper19.to_statespace("case-9")


def test_the_initial_response_of_the_statespace_matches_the_simulator(paper19: System) -> None:
    # Both are exact propagators (matrix exponentials at working precision, no discretisation
    # error): they may differ only by rounding, of order u = 1.1e-16 times the state norm per
    # step. Over 500 steps that is < 1e-13 * max|x|; 1e-9 leaves a wide margin.
    t = np.arange(501) * 0.01
    x0 = random_initial_state(paper19, seed=3)
    for mode in ("normal", "case-2"):
        sim = simulate(paper19, schedule=Schedule(((0.0, mode),)), x0=x0, horizon=5.0, step=0.01)
        assert sim.x is not None and np.allclose(sim.t, t)
        resp = control.initial_response(paper19.to_statespace(mode), T=t, X0=x0, return_x=True)
        scale = float(np.max(np.abs(sim.x)))
        assert np.max(np.abs(resp.states.T - sim.x)) <= 1e-9 * scale
        y_ctrl = np.atleast_2d(resp.outputs)
        assert np.max(np.abs(y_ctrl.T - sim.x @ paper19.C().T)) <= 1e-9 * scale


def test_the_forced_response_to_the_spec_zda_matches_the_simulator(paper19: System) -> None:
    # The simulator propagates the attack input exactly (through its exosystem); python-control's
    # forced_response interpolates the sampled input linearly between samples (first-order
    # hold). For u(t) = u0 exp(lambda0 t) (lambda0 = 1/2 real) the interpolation error is at most
    # e_u = h^2 / 8 * max|u''| = h^2 / 8 * lambda0^2 * max|u|, and the state error at most
    # e_u * int_0^T ||exp(A s) B||_2 ds, which we bound by T * max over the grid of
    # ||exp(A s) B||_2 (times 2 for the grid maximum and rounding).
    h, T = 0.01, 5.0
    attack = zda_attack(paper19)
    assert attack.lambda0 is not None and attack.offset is not None
    lam = complex(attack.lambda0)
    assert lam.imag == 0.0
    x0 = random_initial_state(paper19, seed=5)
    sim = simulate(paper19, attack=attack, x0=x0, horizon=T, step=h)
    assert sim.x is not None
    t = sim.t
    ex = attack.exosystem
    u = np.array([np.real(ex.G @ (scipy.linalg.expm(ex.S * (tk - attack.start)) @ ex.w0)) for tk in t]).T
    ss = paper19.to_statespace("normal")
    resp = control.forced_response(ss, T=t, U=u, X0=x0 + attack.offset, return_x=True)
    A, B = paper19.A(), paper19.B()
    gain = max(float(np.linalg.norm(scipy.linalg.expm(A * s) @ B, 2)) for s in np.linspace(0.0, T, 51))
    bound = 2.0 * h**2 / 8 * abs(lam) ** 2 * float(np.max(np.abs(u))) * T * gain
    err = float(np.max(np.abs(resp.states.T - sim.x)))
    assert err <= bound + 1e-9 * float(np.max(np.abs(sim.x)))
    # and the attack is the spec's ZDA: python-control also sees a zero global output change
    free = control.initial_response(ss, T=t, X0=x0)
    assert np.max(np.abs(np.atleast_2d(resp.outputs) - np.atleast_2d(free.outputs))) <= bound + 1e-9 * float(np.max(np.abs(sim.x)))


# --------------------------------------------------------------------------------------------
# TOML writing


def _round_trip(spec: SystemSpec) -> SystemSpec:
    return loads_spec(dump_spec(spec), source=spec.source)


@pytest.mark.parametrize("name", ["paper19", "paper19-case3"])
def test_a_bundled_example_survives_a_round_trip_through_toml(name: str) -> None:
    spec = load_example(name)
    assert _round_trip(spec) == spec
    assert spec.to_toml() == dump_spec(spec)


@settings(max_examples=8)
@given(n=st.integers(6, 30), clusters=st.integers(1, 3), seed=st.integers(0, 10**6), attack=st.booleans())
def test_a_random_clustered_spec_survives_a_round_trip_through_toml(n: int, clusters: int, seed: int, attack: bool) -> None:
    spec = random_clustered_spec(n, clusters, seed=seed, observers_per_cluster=2, attack=attack and n >= 8 * clusters)  # room for two interior agents
    assert _round_trip(spec) == spec


def test_rational_weights_are_written_exactly() -> None:
    G = nx.Graph()
    G.add_edge(1, 2, weight=Fraction(1, 3))
    G.add_edge(2, 3, weight=Fraction(1, 10))
    G.add_edge(3, 4, weight=Fraction(10**20 + 1, 10**20))
    spec = spec_from_graph(G, alpha="2/7", gamma=Fraction(3, 2), monitor_velocities=[4])
    text = dump_spec(spec)
    assert '"1/3"' in text and "0.1" in text and '"2/7"' in text
    back = _round_trip(spec)
    assert back == spec and back.edges[2].weight == Fraction(10**20 + 1, 10**20)


def test_awkward_labels_and_descriptions_are_quoted_for_toml() -> None:
    G = nx.Graph()
    G.add_edge('a "quoted" node', "back\\slash", weight=2)
    G.add_edge("back\\slash", "tab\there\x7f", weight=1)
    spec = spec_from_graph(G, name='name with "quotes"\nand a newline', monitor_positions=["tab\there\x7f"])
    assert _round_trip(spec) == spec


def test_switching_sequences_sensors_and_complex_exponents_survive_a_round_trip() -> None:
    text = dump_spec(load_example("paper19")).replace('[switching]\nmode = "case-2"\ntime = 10.0', '[switching]\ntime = 2.5\nsequence = [{mode = "case-1", duration = 1.5}, {mode = "normal", duration = 0.25}]')
    text = text.replace('kind = "zda"', 'kind = "covert"').replace("lambda0 = 0.5", "lambda0 = [-0.25, 1.75]\nsensors = [12]\nsignal = \"sine\"")
    spec2 = loads_spec(text)
    assert spec2.switching is not None and len(spec2.switching.sequence) == 2
    assert spec2.attack is not None and spec2.attack.lambda0 == complex(-0.25, 1.75) and spec2.attack.sensors == (12,)
    assert _round_trip(spec2) == spec2


def test_a_finding_table_survives_a_round_trip() -> None:
    text = load_example("paper19").to_toml() + (
        '\n[finding]\nclaim = "a claim with \\"quotes\\""\nreference = "Theorem III.3"\nconditions = ["switching.coverage"]\n'
        'expect = [{id = "switching.coverage", status = "fails", mode = "case-3"}]\n'
    )
    spec = loads_spec(text)
    assert spec.finding is not None and spec.finding["expect"][0]["mode"] == "case-3"
    assert _round_trip(spec) == spec


_labels = st.one_of(st.integers(-50, 500), st.text(min_size=1, max_size=6))
_weights = st.one_of(
    st.integers(1, 9),
    st.fractions(min_value=Fraction(1, 60), max_value=Fraction(50), max_denominator=60),
    st.sampled_from([0.1, 0.25, 1.5, 2.75, 1e-7]),
)


@settings(max_examples=25)
@given(
    labels=st.lists(_labels, min_size=2, max_size=8, unique_by=str),  # 1 and "1" would be ambiguous (refused)
    data=st.data(),
)
def test_specs_built_from_random_graphs_survive_a_round_trip_through_toml(labels: list[Any], data: st.DataObject) -> None:
    n = len(labels)
    pairs = data.draw(st.lists(st.tuples(st.integers(0, n - 1), st.integers(0, n - 1)), min_size=1, max_size=12))
    G = nx.Graph()
    G.add_nodes_from(labels)
    for i, j in pairs:
        if i != j:
            G.add_edge(labels[i], labels[j], weight=data.draw(_weights))
    mon = data.draw(st.lists(st.sampled_from(labels), max_size=3, unique=True))
    spec = spec_from_graph(G, name=data.draw(st.text(max_size=10)), alpha=data.draw(_weights), monitor_velocities=mon)
    assert _round_trip(spec) == spec


# --------------------------------------------------------------------------------------------
# graph files


def _write(tmp_path: Path, name: str, text: str) -> Path:
    p = tmp_path / name
    p.write_text(text, encoding="utf-8")
    return p


def test_an_edge_list_is_read_with_exact_rational_weights(tmp_path: Path) -> None:
    p = _write(tmp_path, "g.txt", "# a comment\n1 2 0.1\n2 3 1/3\n3 4\nb 4 {'weight': 0.30000000000000001}\n")
    G = load_graph(p)
    w = {frozenset((u, v)): d for u, v, d in G.edges(data="weight")}
    assert w[frozenset((1, 2))] == Fraction(1, 10)
    assert w[frozenset((2, 3))] == Fraction(1, 3)
    assert w[frozenset((3, 4))] == 1
    assert w[frozenset(("b", 4))] == Fraction(30000000000000001, 10**17)
    spec = spec_from_graph(G, monitor_velocities=[4])
    assert {e.key: e.weight for e in spec.edges}[frozenset((1, 2))] == Fraction(1, 10)


def test_a_csv_edge_list_may_have_a_header(tmp_path: Path) -> None:
    G = load_graph(_write(tmp_path, "g.csv", "source,target,weight\n1,2,2\n2,3,0.5\n"))
    assert sorted(G.edges(data="weight")) == [(1, 2, Fraction(2)), (2, 3, Fraction(1, 2))]


def test_graphml_and_gml_files_are_read_with_their_labels(tmp_path: Path) -> None:
    H = nx.Graph()
    H.add_edge(1, 2, weight=0.5)
    H.add_edge(2, "x", weight="1/3")
    nx.write_graphml(H, tmp_path / "g.graphml")
    G = load_graph(tmp_path / "g.graphml")
    assert sorted(G.edges(data="weight"), key=str) == sorted([(1, 2, Fraction(1, 2)), (2, "x", Fraction(1, 3))], key=str)
    gml = 'graph [\n node [ id 0 label "a" ]\n node [ id 1 label "7" ]\n edge [ source 0 target 1 weight 0.2 ]\n]\n'
    G = load_graph(_write(tmp_path, "g.gml", gml))
    assert list(G.edges(data="weight")) == [("a", 7, Fraction(1, 5))]


def test_the_edge_list_of_paper19_gives_back_its_graph(tmp_path: Path, paper19: System) -> None:
    text = "".join(f"{e.u} {e.v} {e.weight}\n" for e in paper19.spec.edges)
    G = load_graph(_write(tmp_path, "paper19.edgelist", text))
    assert {frozenset((u, v)): w for u, v, w in G.edges(data="weight")} == paper19.edges("normal")


@pytest.mark.parametrize(
    ("name", "text", "problem"),
    [
        ("loop.txt", "1 2\n3 3\n", "line 2: self loop at node 3"),
        ("neg.txt", "1 2 -1\n", "line 1: weight '-1' must be > 0"),
        ("zero.csv", "1,2,0\n", "must be > 0"),
        ("nan.txt", "1 2 nan\n", "not a finite number"),
        ("word.txt", "1 2 heavy\n", "weight 'heavy' is not a number"),
        ("extra.txt", "1 2 3 4\n", "line 1: expected 'u v [weight]'"),
        ("dup.txt", "1 2\n2 1 3\n", "edge 2-1 is listed twice (also line 1)"),
        ("one.txt", "1\n", "expected 'u v [weight]'"),
        ("empty.txt", "# nothing\n", "the graph has no nodes"),
        ("nanw.gml", "graph [\n node [ id 0 ]\n node [ id 1 ]\n edge [ source 0 target 1 weight NAN ]\n]\n", "not a finite number"),
        ("dir.gml", "graph [\n directed 1\n node [ id 0 ]\n node [ id 1 ]\n edge [ source 0 target 1 ]\n]\n", "directed"),
        ("multi.gml", "graph [\n multigraph 1\n node [ id 0 ]\n node [ id 1 ]\n edge [ source 0 target 1 ]\n edge [ source 0 target 1 ]\n]\n", "parallel edges"),
        ("dup.gml", "graph [\n node [ id 0 ]\n node [ id 1 ]\n edge [ source 0 target 1 ]\n edge [ source 1 target 0 ]\n]\n", "not a valid GML graph"),
        ("unhash.gml", "graph [\n node [ id 0 label [ a 1 ] ]\n node [ id 1 label \"b\" ]\n edge [ source 0 target 1 ]\n]\n", "not hashable"),
        ("floatlab.gml", "graph [\n node [ id 0 label 1.5 ]\n node [ id 1 label \"b\" ]\n edge [ source 0 target 1 ]\n]\n", "is a float"),
        ("same.gml", "graph [\n node [ id 0 label \"7\" ]\n node [ id 1 label 7 ]\n edge [ source 0 target 1 ]\n]\n", "label 7 is also the label of node id 0"),
        ("bad.graphml", "<graphml><graph", "not a valid GraphML graph"),
        ("g.json", "{}", "unknown graph file type '.json'"),
    ],
)
def test_a_bad_graph_file_is_a_spec_error_naming_the_file_and_the_problem(tmp_path: Path, name: str, text: str, problem: str) -> None:
    p = _write(tmp_path, name, text)
    with pytest.raises(SpecError) as info:
        load_graph(p)
    msg = str(info.value)
    assert msg.startswith(str(p)) and problem in msg, msg


def test_a_directed_graphml_file_is_refused(tmp_path: Path) -> None:
    nx.write_graphml(nx.DiGraph([(1, 2)]), tmp_path / "d.graphml")
    with pytest.raises(SpecError, match="directed"):
        load_graph(tmp_path / "d.graphml")


def test_a_missing_graph_file_is_a_spec_error(tmp_path: Path) -> None:
    with pytest.raises(SpecError, match="file not found"):
        load_graph(tmp_path / "none.gml")


def test_loaded_weights_never_pass_through_rounded_floats(tmp_path: Path) -> None:
    # 1/3 as text stays 1/3 (a float would be 6004799503160661 / 2**54)
    G = load_graph(_write(tmp_path, "g.edgelist", "1 2 1/3\n"))
    w = G[1][2]["weight"]
    assert isinstance(w, Fraction) and w == Fraction(1, 3) and w != Fraction(1 / 3)
    assert not math.isnan(float(w))
