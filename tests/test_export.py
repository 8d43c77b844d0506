"""The deployment export (``glocal-verify export``, docs/export.md): every format is readable by
its own reader, and the observers rebuilt from the file alone reproduce the simulator's
residuals and thresholds, on paper19 and on a generated 50-agent network."""

from __future__ import annotations

import json
import re
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import scipy.io

from glocal_verify import System, load_example, simulate
from glocal_verify.cli import main
from glocal_verify.design.generators import random_clustered_spec
from glocal_verify.reporting.export import EXPORT_FORMATS, SCHEMA, SCHEMA_VERSION, ExportError, export_observers, read_deployment
from glocal_verify.simulation.attacks import attack_from_spec
from glocal_verify.simulation.deployment import Deployment, design_deployment
from glocal_verify.simulation.observer_models import ObserverBank, ObserverModel
from glocal_verify.simulation.schedule import ANY_MODE, Schedule, random_initial_state
from glocal_verify.simulation.thresholds import attack_free_thresholds

MATLAB_NAME = re.compile(r"^[A-Za-z][A-Za-z0-9_]{0,62}$")
SYSTEMS = ("paper19", "random-50")


def _system(name: str) -> System:
    if name == "paper19":
        return System(load_example("paper19"))
    return System(random_clustered_spec(50, clusters=3, seed=2))


@pytest.fixture(scope="module", params=SYSTEMS)
def exported(request: pytest.FixtureRequest, tmp_path_factory: pytest.TempPathFactory) -> tuple[System, dict[str, Path]]:
    system = _system(request.param)
    folder = tmp_path_factory.mktemp(request.param)
    deployment = design_deployment(system)
    return system, {fmt: export_observers(deployment, folder / f"observers.{fmt}") for fmt in EXPORT_FORMATS}


def _rebuild(tree: dict[str, Any]) -> ObserverBank:
    """The observers as the simulator runs them, from the file's fields alone (docs/export.md)."""
    out = []
    n2 = 2 * tree["system"]["n"]
    c = tree["central"]
    if c["present"]:
        p = c["C"].shape[0]
        out.append(ObserverModel("central", "central", c["C"], {ANY_MODE: c["F"]}, {ANY_MODE: c["H"]}, np.eye(p), c["C"], np.zeros((n2, n2)), tuple(c["channels"]), tuple(c["channels"])))
    for o in tree["local"]:
        Cg = o["C_loc"] @ o["S"]
        F = {ANY_MODE: o["F"], **{d["mode"]: d["F"] for d in o["designs"]}}
        G = {ANY_MODE: o["K"], **{d["mode"]: d["K"] for d in o["designs"]}}
        ch = tuple(o["channels"])
        H = {ANY_MODE: o["h"], **{d["mode"]: d["h"] for d in o["designs"]}}  # x_hat = z + h_q y, reset at a switch
        H = H if any(not np.array_equal(v, o["h"]) for v in H.values()) else {}
        out.append(ObserverModel(o["name"], "local", Cg, F, G, o["Ry"], o["Rz"], -o["h"] @ Cg, ch, ch, o["cluster"], None, (), H))
    return ObserverBank(tuple(out))


def _schedule(tree: dict[str, Any]) -> Schedule:
    return Schedule(tuple((s["time"], s["mode"]) for s in tree["schedule"]["segments"]))


@pytest.mark.parametrize("fmt", EXPORT_FORMATS)
def test_observers_rebuilt_from_the_file_reproduce_the_simulators_residuals(exported: tuple[System, dict[str, Path]], fmt: str) -> None:
    system, files = exported
    tree = read_deployment(files[fmt])
    assert tree["schema"] == SCHEMA and tree["schema_version"] == SCHEMA_VERSION
    rebuilt = _rebuild(tree)
    schedule = _schedule(tree)
    assert schedule == Schedule.from_spec(system) and len(schedule.segments) == 2
    reference = ObserverBank.for_system(system)
    assert rebuilt.names == reference.names and len(rebuilt) == len(system.observers()) + 1
    x0 = random_initial_state(system, seed=7)
    horizon = schedule.switch_times[0] + 2.0
    run = dict(schedule=schedule, attack=attack_from_spec(system), x0=x0, horizon=horizon, record_states=False)
    ours, theirs = simulate(system, observers=rebuilt, **run), simulate(system, observers=reference, **run)  # type: ignore[arg-type]
    for name in reference.names:
        scale = max(1.0, float(np.abs(theirs.residuals[name]).max()))
        np.testing.assert_allclose(ours.residuals[name], theirs.residuals[name], rtol=0, atol=1e-12 * scale, err_msg=name)


def test_the_files_thresholds_are_the_simulators_attack_free_thresholds(exported: tuple[System, dict[str, Path]]) -> None:
    system, files = exported
    reference = attack_free_thresholds(system, ObserverBank.for_system(system), Schedule.from_spec(system))
    for fmt in EXPORT_FORMATS:
        thr = read_deployment(files[fmt])["thresholds"]
        assert thr["present"] == 1 and thr["rule"]["kind"] == reference.rule.kind
        assert thr["rule"]["box"] == reference.rule.box and thr["rule"]["rounding"] == reference.rule.rounding
        np.testing.assert_array_equal(thr["t"], reference.t)
        assert [o["name"] for o in thr["observers"]] == list(reference.envelope)
        for o in thr["observers"]:
            np.testing.assert_array_equal(o["envelope"], reference.envelope[o["name"]])


def test_every_local_observer_in_the_file_meets_the_uio_equations(exported: tuple[System, dict[str, Path]]) -> None:
    system, files = exported
    tree = read_deployment(files["npz"])
    for o in tree["local"]:
        C, E, A, h, T, F, K = (o[k] for k in ("C_loc", "E", "A", "h", "T", "F", "K"))
        k2 = A.shape[0]
        scale = np.linalg.norm(A) + np.linalg.norm(F)
        assert np.linalg.norm((h @ C - np.eye(k2)) @ E) <= 1e-9 * max(1.0, np.linalg.norm(E))  # uio_conds_1: T E = 0
        assert np.linalg.norm(T - (np.eye(k2) - h @ C)) == 0.0
        assert np.linalg.norm(T @ A - F @ T - K @ C) <= 1e-9 * scale  # the error is free of the cluster state
        assert max(np.linalg.eigvals(F).real) < 0
        assert o["S"].shape == (k2, 2 * system.n) and C.shape == (len(o["channels"]), k2)
        labels = tree["system"]["labels"]
        sel = [labels[int(j)] for j in np.flatnonzero(o["S"][: k2 // 2].any(axis=0))]
        assert sel == o["nodes"]
    assert tree["monitors"]["velocities"] == [str(a) for a in system.monitored_velocities]
    np.testing.assert_array_equal(tree["monitors"]["C"], system.C())
    laplacians = {m["name"]: m["L"] for m in tree["system"]["modes"]}
    for name, L in laplacians.items():
        np.testing.assert_array_equal(L, system.laplacian(name))
    index = {a: k for k, a in enumerate(tree["system"]["labels"])}
    for sw in tree["schedule"]["switches"]:  # L_q = L_1 + sum delta (e_u - e_v)(e_u - e_v)^T
        L = laplacians["normal"].copy()
        for u, v, d in zip(sw["u"], sw["v"], sw["delta"]):
            e = np.zeros(system.n)
            e[index[u]], e[index[v]] = 1.0, -1.0
            L += d * np.outer(e, e)
        np.testing.assert_allclose(L, laplacians[sw["mode"]], rtol=0, atol=1e-12)


def test_each_format_reads_with_its_own_reader(exported: tuple[System, dict[str, Path]]) -> None:
    _, files = exported
    # MATLAB v5: scipy's default reader, and every struct field a valid MATLAB name
    plain = scipy.io.loadmat(files["mat"])
    assert str(plain["schema"][0]) == SCHEMA and int(plain["schema_version"][0, 0]) == SCHEMA_VERSION
    structs = scipy.io.loadmat(files["mat"], struct_as_record=False, squeeze_me=True)

    def names(x: Any) -> list[str]:
        if isinstance(x, scipy.io.matlab.mat_struct):
            return list(x._fieldnames) + [n for f in x._fieldnames for n in names(getattr(x, f))]
        if isinstance(x, np.ndarray) and x.dtype == object:
            return [n for v in x.reshape(-1) for n in names(v)]
        return []

    fields = [k for k in structs if not k.startswith("__")] + [n for k, v in structs.items() if not k.startswith("__") for n in names(v)]
    assert fields and all(MATLAB_NAME.match(f) for f in fields), [f for f in fields if not MATLAB_NAME.match(f)]
    assert {"H", "F", "K", "h", "T", "C_loc", "envelope", "segments"} <= set(fields)
    # npz without pickles; JSON without NaN or Infinity
    with np.load(files["npz"], allow_pickle=False) as z:
        assert str(z["schema"]) == SCHEMA and "local/0/F" in z.files and "central/H" in z.files

    def refuse(token: str) -> None:
        raise AssertionError(f"non-standard JSON constant {token}")

    data = json.loads(files["json"].read_text(encoding="utf-8"), parse_constant=refuse)
    assert data["schema_version"] == SCHEMA_VERSION and isinstance(data["local"][0]["F"][0], list)


def test_the_export_command_writes_each_format_and_refuses_an_unknown_one(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "obs.bin"
    assert main(["export", "--example", "paper19", "--format", "json", "--out", str(out), "--no-thresholds", "--quiet"]) == 0
    tree = json.loads(out.read_text(encoding="utf-8"))
    assert tree["thresholds"]["present"] == 0 and len(tree["local"]) == 4
    assert f"wrote {out}" in capsys.readouterr().err
    assert main(["export", "--example", "paper19", "--out", str(tmp_path / "obs.txt")]) == 2
    err = capsys.readouterr().err
    assert "--format" in err and len(err.strip().splitlines()) == 1
    with pytest.raises(ExportError, match="schema"):
        (tmp_path / "other.json").write_text('{"schema": "something else", "schema_version": 1}', encoding="utf-8")
        read_deployment(tmp_path / "other.json")


def test_the_deployment_is_a_frozen_value_and_the_exporter_only_writes_it(tmp_path: Path) -> None:
    import dataclasses

    from glocal_verify.errors import ArgumentError

    system = System(load_example("paper19"))
    deployment = design_deployment(system, thresholds=False)
    assert isinstance(deployment, Deployment) and deployment.thresholds is None
    with pytest.raises(dataclasses.FrozenInstanceError):
        deployment.name = "other"  # type: ignore[misc]
    with pytest.raises(ArgumentError, match="design_deployment"):
        export_observers(system, tmp_path / "x.json")  # type: ignore[arg-type]
    assert not (tmp_path / "x.json").exists()
