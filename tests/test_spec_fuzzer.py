"""Mutated specs end with exit 0/1, or exit 2 and one stderr line naming the key path:
never a traceback, a hang or a memory blow-up.

- ``test_every_command_survives_mutated_specs``: hypothesis mutates valid specs
  (``tests/fuzz_support.py``) and runs one of the four commands (``verify``, ``verify --exact``,
  ``simulate --no-figures``, ``place-observers``) on each. Under the ``ci`` profile it is
  derandomized and small; ``GLOCAL_PROFILE=fuzz`` runs every command on thousands of examples
  and shrinks failures.
- ``test_regression_*``: one explicit case per mutation class the fuzzing campaigns found
  (``tests/fuzz_campaign.py``). In CI only the cases that must be refused at load time run (on
  ``verify``, fast); the fuzz profile runs every case on every command.

Every run is forked with ``RLIMIT_AS = 4 GiB`` and a SIGALRM time budget, so a blow-up or hang
fails one test instead of the session.
"""

from __future__ import annotations

import copy
import os
from pathlib import Path
from typing import Any, Callable

import pytest
from hypothesis import HealthCheck, Phase, given, settings
from hypothesis import strategies as st

import fuzz_support as fs

FUZZ = os.environ.get("GLOCAL_PROFILE") == "fuzz"
MEM = 4 << 30
TIMEOUT = 60.0
#: small bases: every command is fast on them (simulate: horizon 3, step 0.05)
FAST_BASES = ("random-10-2-s0", "random-12-3-s1", "cycle8", "path5-str", "paper19-short")
GIANT = 10**5


def _phases() -> list[Phase]:
    return list(Phase) if FUZZ else [Phase.explicit, Phase.reuse, Phase.generate]


def _run(mutant: fs.Mutant, command: str, tmp_path: Path, timeout: float = TIMEOUT) -> fs.RunResult:
    spec = tmp_path / "spec.toml"
    spec.write_text(mutant.text, encoding="utf-8")
    return fs.run_cli(fs.command_argv(command, spec, tmp_path), timeout, fork=True, memory_bytes=MEM)


def _escaped(tmp_path: Path) -> list[str]:
    """Files written outside tmp_path/sim (and the spec) by a run."""
    return sorted(str(p.relative_to(tmp_path)) for p in tmp_path.rglob("*") if p.is_file() and p.name != "spec.toml" and "sim" not in p.relative_to(tmp_path).parts[:1])


# ---------------------------------------------------------------------------------------------
# property test


@settings(
    max_examples=3000 if FUZZ else (12 if os.environ.get("GLOCAL_FUZZ_QUICK") else 30),
    deadline=None,
    derandomize=not FUZZ,
    phases=_phases(),
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large, HealthCheck.function_scoped_fixture],
)
@given(mutant=fs.mutated_specs(bases=FAST_BASES), command=st.sampled_from(fs.COMMANDS))
def test_every_command_survives_mutated_specs(command: str, mutant: fs.Mutant, tmp_path_factory: pytest.TempPathFactory) -> None:
    tmp = tmp_path_factory.mktemp("fuzz")
    res = _run(mutant, command, tmp)
    assert res.good, f"{command}: {res.summary()}\n{mutant!r}"
    assert not _escaped(tmp), f"{command} wrote outside --out: {_escaped(tmp)}"


@pytest.mark.skipif(not FUZZ, reason="probes the numerics inside the documented domains: GLOCAL_PROFILE=fuzz")
@settings(max_examples=500, deadline=None, phases=_phases(), suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture])
@given(mutant=fs.mutants_of_kind("domain-edge", bases=FAST_BASES), command=st.sampled_from(fs.COMMANDS))
def test_specs_at_the_edges_of_the_documented_domains_survive_every_command(command: str, mutant: fs.Mutant, tmp_path_factory: pytest.TempPathFactory) -> None:
    res = _run(mutant, command, tmp_path_factory.mktemp("edge"))
    assert res.good, f"{command}: {res.summary()}\n{mutant!r}"


@pytest.mark.skipif(not FUZZ, reason="slow (every base through every command): GLOCAL_PROFILE=fuzz")
@pytest.mark.parametrize("command", fs.COMMANDS)
def test_the_unmutated_bases_are_accepted(command: str, tmp_path: Path) -> None:
    for name, data in fs.base_specs():
        if name not in FAST_BASES:
            continue
        (tmp_path / name).mkdir()
        res = _run(fs.Mutant(name, [], [], fs.toml_dumps(data), data), command, tmp_path / name)
        assert res.good, f"{name} {command}: {res.summary()}"


def test_the_toml_writer_round_trips_every_base() -> None:
    import tomllib

    for _, data in fs.base_specs():
        assert tomllib.loads(fs.toml_dumps(data)) == data


# ---------------------------------------------------------------------------------------------
# explicit regressions, one per mutation class

Edit = Callable[[dict[str, Any]], None]


def _set(path: str, value: Any) -> Edit:
    """Edit setting the key path ``a.b[0].c`` to ``value``."""
    import re

    parts: list[Any] = []
    for name, idx in re.findall(r"([A-Za-z_][A-Za-z0-9_]*)|\[(\d+)\]", path):
        parts.append(name if name else int(idx))

    def edit(d: dict[str, Any]) -> None:
        fs.set_at(d, tuple(parts), value)

    return edit


def _drop(path: str) -> Edit:
    parts = tuple(path.split("."))
    return lambda d: fs.del_at(d, parts)


def _both(*edits: Edit) -> Edit:
    def edit(d: dict[str, Any]) -> None:
        for e in edits:
            e(d)

    return edit


def _rename_node(old: Any, new: Any) -> Edit:
    return lambda d: fs._rename_node(d, old, new)


def _mode_name(name: str) -> Edit:
    def edit(d: dict[str, Any]) -> None:
        old = d["modes"][0]["name"]
        d["modes"][0]["name"] = name
        if d.get("switching", {}).get("mode") == old:
            d["switching"]["mode"] = name

    return edit


def _mixed_labels(d: dict[str, Any]) -> None:
    """graph.nodes = [1, "1", 2, ...]: "1" joins the first cluster, linked to node 1."""
    g = d["graph"]
    g["nodes"] = [1, "1"] + list(range(2, g["nodes"] + 1))
    g["edges"].append(["1", 1, 1])
    d["clusters"][0]["nodes"].append("1")


def _deep(path: str, depth: int) -> Edit:
    return _set(path, fs.RawToml("[" * depth + "1" + "]" * depth))


# (id, base, edit, path): path None: ok or any clean error; "p": must be a clean error naming key
# path p; "?p": ok, or a clean error naming p (e.g. 1.0 may be read as node 1 or refused)
CASES: list[tuple[str, str, Edit, str | None]] = [
    # keys dropped / duplicated
    ("drop-graph-edges", "cycle8", _drop("graph.edges"), "graph"),
    ("drop-attack-kind", "cycle8", _drop("attack.kind"), "attack"),
    ("drop-cluster-nodes", "cycle8", lambda d: d["clusters"][0].pop("nodes"), "clusters[0]"),
    ("drop-mode-name", "cycle8", lambda d: d["modes"][0].pop("name"), "modes[0]"),
    ("duplicate-cluster", "cycle8", lambda d: d["clusters"].append(copy.deepcopy(d["clusters"][0])), "clusters[2]"),
    ("duplicate-observer", "cycle8", lambda d: d["clusters"][0]["observers"].append(copy.deepcopy(d["clusters"][0]["observers"][0])), "clusters[0].observers[1].center"),
    ("duplicate-monitor-entry", "cycle8", lambda d: d["monitor"]["velocities"].append(d["monitor"]["velocities"][0]), "monitor.velocities[2]"),
    # types changed
    ("type-alpha-str", "cycle8", _set("dynamics.alpha", "fast"), "dynamics.alpha"),
    ("type-horizon-str", "cycle8", _set("simulation.horizon", "30"), "simulation.horizon"),
    ("type-nodes-float", "cycle8", _set("graph.nodes", 6.0), "graph.nodes"),
    ("type-edges-dict", "cycle8", _set("graph.edges", {"a": 1}), "graph.edges"),
    ("type-center-list", "cycle8", _set("clusters[0].observers[0].center", [2]), "clusters[0].observers[0].center"),
    ("type-center-bool", "cycle8", _set("clusters[0].observers[0].center", True), "clusters[0].observers[0].center"),
    ("type-attack-list", "cycle8", _set("attack", [1, 2]), "attack"),
    ("type-seed-float", "cycle8", _set("simulation.seed", 1.5), "simulation.seed"),
    ("type-start-bool", "cycle8", _set("attack.start", True), "attack.start"),
    ("type-frequency-bool", "path5-str", _set("attack.frequency", False), "attack.frequency"),
    ("type-horizon-bool", "cycle8", _set("simulation.horizon", True), "simulation.horizon"),
    ("type-center-integral-float", "cycle8", _both(_set("clusters[0].observers[0].center", 1.0), _set("monitor.velocities[0]", 1.0)), "?monitor.velocities[0]"),
    ("type-edge-end-integral-float", "cycle8", _set("graph.edges[0][0]", 1.0), "?graph.edges[0][0]"),
    # huge / tiny / NaN / inf numbers
    ("weight-nan", "cycle8", _set("graph.edges[0][2]", float("nan")), "graph.edges[0][2]"),
    ("weight-inf", "cycle8", _set("graph.edges[0][2]", float("inf")), "graph.edges[0][2]"),
    ("weight-1e9999999-float", "cycle8", _set("graph.edges[0][2]", fs.RawToml("1e9999999")), "graph.edges[0][2]"),
    ("weight-1e9999999-string", "cycle8", _set("graph.edges[0][2]", "1e9999999"), "graph.edges[0][2]"),
    ("weight-abc", "cycle8", _set("graph.edges[0][2]", "abc"), "graph.edges[0][2]"),
    ("weight-tiny", "cycle8", _set("graph.edges[0][2]", 5e-324), "graph.edges[0][2]"),
    ("weight-huge", "cycle8", _set("graph.edges[0][2]", 1e308), "graph.edges[0][2]"),
    ("weight-int64max", "cycle8", _set("graph.edges[0][2]", 2**63 - 1), "graph.edges[0][2]"),
    ("weight-10e400-int", "cycle8", _set("graph.edges[0][2]", 10**400), "graph.edges[0][2]"),
    ("alpha-minus-1e308", "cycle8", _set("dynamics.alpha", -1e308), "dynamics.alpha"),
    ("horizon-10e400-int", "cycle8", _set("simulation.horizon", 10**400), "simulation.horizon"),
    ("start-10e400-int", "cycle8", _set("attack.start", 10**400), "attack.start"),
    ("pole-1e9999999-string", "cycle8", _set("clusters[0].observers[0].poles", ["-1e9999999"]), "clusters[0].observers[0].poles[0]"),
    ("poles-tiny", "cycle8", _set("clusters[0].observers[0].poles", [-5e-324, -1e-300, -1, -2]), "clusters[0].observers[0].poles[0]"),
    ("poles-huge", "cycle8", _set("clusters[0].observers[0].poles", [-1e308, -1e307, -2, -3]), "clusters[0].observers[0].poles[0]"),
    ("seed-negative", "cycle8", _set("simulation.seed", -1), "simulation.seed"),
    ("seed-huge", "cycle8", _set("simulation.seed", 10**30), "simulation.seed"),
    ("amplitude-1e308", "path5-str", _set("attack.amplitude", 1e308), "attack.amplitude"),
    # unicode and very long labels
    ("unicode-node", "cycle8", _rename_node(1, "ノード🙂"), None),
    ("unicode-cluster-name", "cycle8", _set("clusters[0].name", "\u202eRTL\u0301"), None),
    ("nul-in-label", "cycle8", _rename_node(2, "a\x00b"), "graph.nodes[1]"),
    ("long-node-label", "cycle8", _rename_node(1, "L" * GIANT), "graph.nodes[0]"),
    ("long-cluster-name", "cycle8", _set("clusters[0].name", "C" * GIANT), "clusters[0].name"),
    ("long-system-name", "cycle8", _set("name", "N" * GIANT), "name"),
    ("long-missing-node", "cycle8", _set("clusters[0].observers[0].center", "G" * GIANT), "clusters[0].observers[0].center"),
    # deeply nested arrays
    ("deep-edges-50", "cycle8", _deep("graph.edges", 50), "graph.edges"),
    ("deep-edges-10000", "cycle8", _deep("graph.edges", 10_000), "graph.edges"),
    ("deep-monitor-10000", "cycle8", _deep("monitor.velocities", 10_000), "monitor.velocities"),
    ("deep-nodes-900", "cycle8", _deep("graph.nodes", 900), "graph.nodes"),
    # odd mode names
    ("mode-dotdot", "cycle8", _mode_name(".."), None),
    ("mode-traversal", "cycle8", _mode_name("../../x"), None),
    ("mode-inner-traversal", "cycle8", _mode_name("x/../../y"), None),
    ("mode-absolute", "cycle8", _mode_name("/tmp/glocal-fuzz-abs"), None),
    ("mode-nul", "cycle8", _mode_name("a\x00b"), "modes[0].name"),
    ("mode-too-long", "cycle8", _mode_name("m" * 300), "modes[0].name"),
    ("mode-newline", "cycle8", _mode_name("a\nb"), None),
    # references to missing nodes
    ("cluster-missing-node", "cycle8", _set("clusters[1].nodes[0]", 25), "clusters[1].nodes[0]"),
    ("observer-center-missing", "cycle8", _set("clusters[0].observers[0].center", 25), "clusters[0].observers[0].center"),
    ("observer-position-missing", "cycle8", _set("clusters[1].observers[0].positions[0]", 25), "clusters[1].observers[0].positions[0]"),
    ("observer-center-int64max", "cycle8", _set("clusters[0].observers[0].center", 2**63 - 1), "clusters[0].observers[0].center"),
    ("attack-missing-node", "cycle8", _set("attack.actuators[0]", "1"), "attack.actuators[0]"),
    ("mode-add-missing-node", "cycle8", _set("modes[0].add[0][1]", 0), "modes[0].add[0][1]"),
    # huge horizons, tiny steps
    ("horizon-1e16", "cycle8", _set("simulation.horizon", 1e16), "simulation.horizon"),
    ("horizon-1e16-step-1e15", "cycle8", _both(_set("simulation.horizon", 1e16), _set("simulation.step", 1e15)), "simulation.horizon"),
    ("horizon-1e8-step-1", "cycle8", _both(_set("simulation.horizon", 1e8), _set("simulation.step", 1.0)), "simulation.horizon"),
    ("step-1e-12", "cycle8", _set("simulation.step", 1e-12), "simulation.step"),
    ("step-denormal", "cycle8", _set("simulation.step", 5e-324), "simulation.step"),
    ("switch-time-1e308", "cycle8", _set("switching.time", 1e308), "switching.time"),
    ("sequence-duration-tiny", "path5-str", _set("switching.sequence[0].duration", 1e-300), "switching.sequence[0].duration"),
    # gains and the ZDA exponent
    ("gamma-int64max", "cycle8", _set("dynamics.gamma", 2**63 - 1), "dynamics.gamma"),
    ("alpha-int64max", "cycle8", _set("dynamics.alpha", 2**63 - 1), "dynamics.alpha"),
    ("gamma-tiny-string", "cycle8", _set("dynamics.gamma", "1e-300"), "dynamics.gamma"),
    ("gamma-1e9999999-string", "cycle8", _set("dynamics.gamma", "1e9999999"), "dynamics.gamma"),
    ("lambda0-minus-1e308", "cycle8", _set("attack.lambda0", -1e308), "attack.lambda0"),
    ("lambda0-plus-1e308", "random-10-2-s0", _set("attack.lambda0", 1e308), "attack.lambda0"),
    ("lambda0-complex-huge", "path5-str", _both(_set("attack.kind", "zda"), lambda d: d["attack"].pop("sensors"), _set("attack.lambda0", [1e308, -1e308])), "attack.lambda0[0]"),
    ("lambda0-1e9999999-string", "cycle8", _set("attack.lambda0", "1e9999999"), "attack.lambda0"),
    # mixed labels
    ("labels-1-and-'1'", "cycle8", _mixed_labels, "graph.nodes[1]"),
    ("labels-1-and-'1'-paper19", "paper19-short", _mixed_labels, "graph.nodes[1]"),
]


def _case_mutant(case: str, base: str, edit: Edit) -> fs.Mutant:
    data = copy.deepcopy(dict(fs.base_specs())[base])
    edit(data)
    return fs.Mutant(base, ["regression"], [case], fs.toml_dumps(data), data)


def _check(case: str, base: str, edit: Edit, path: str | None, command: str, tmp_path: Path) -> None:
    m = _case_mutant(case, base, edit)
    res = _run(m, command, tmp_path)
    assert res.good, f"{case} / {command}: {res.summary()}"
    assert not _escaped(tmp_path), f"{case} / {command} wrote outside --out: {_escaped(tmp_path)}"
    if res.outcome == "clean-error":
        line = res.stderr_lines[0]
        assert len(res.stderr_lines) == 1, res.stderr
        assert len(line) <= 2000, f"{case} / {command}: error line of {len(line)} chars"
    if path is not None and path.startswith("?"):
        path = path[1:]
        if res.outcome == "ok":
            return
    if path is not None:
        assert res.outcome == "clean-error", f"{case} / {command}: accepted ({res.summary()}); expected an error at {path}"
        assert f"{path}:" in res.stderr_lines[0] or f"{path}." in res.stderr_lines[0] or f"{path}[" in res.stderr_lines[0], res.stderr


#: the cases refused at load time: fast, they run in CI
LOAD_CASES = [c for c in CASES if c[3] is not None and not c[3].startswith("?")]


@pytest.mark.parametrize("case,base,edit,path", LOAD_CASES, ids=[c[0] for c in LOAD_CASES])
def test_regression_specs_refused_at_load_time_get_one_line_naming_the_key(case: str, base: str, edit: Edit, path: str, tmp_path: Path) -> None:
    _check(case, base, edit, path, "verify", tmp_path)


@pytest.mark.skipif(not FUZZ, reason="slow (every case through every command): GLOCAL_PROFILE=fuzz")
@pytest.mark.parametrize("case,base,edit,path", CASES, ids=[c[0] for c in CASES])
@pytest.mark.parametrize("command", fs.COMMANDS)
def test_regression_every_case_survives_every_command(case: str, base: str, edit: Edit, path: str | None, command: str, tmp_path: Path) -> None:
    _check(case, base, edit, path, command, tmp_path)


@pytest.mark.parametrize("lines", [1, 200])
def test_a_duplicated_toml_key_is_one_clean_error(lines: int, tmp_path: Path) -> None:
    m = fs.mutate("cycle8", dict(fs.base_specs())["cycle8"], ["duplicate-key"], fs.RandomChooser(lines))
    res = _run(m, "verify", tmp_path)
    assert res.outcome == "clean-error", res.summary()
    assert "not valid TOML" in res.last_stderr_line


def test_run_cli_classifies_outcomes(tmp_path: Path) -> None:
    spec = tmp_path / "ok.toml"
    spec.write_text(fs.toml_dumps(dict(fs.base_specs())["cycle8"]), encoding="utf-8")
    assert fs.run_cli(["verify", str(spec)], 60).outcome == "ok"
    assert fs.run_cli(["verify", str(tmp_path / "missing.toml")], 60).outcome == "clean-error"
    assert fs.run_cli(["verify", "--format"], 60).outcome == "clean-error"
    assert fs.classify(2, "", "a\nb\nc\nd\ne\n") == "multi-line"
    assert fs.classify(0, "", "Traceback (most recent call last):\n") == "traceback"
    assert fs.classify(None, "", "", fs.FuzzTimeout()) == "hang"
    assert fs.classify(None, "", "", MemoryError()) == "blowup"
