"""The library's public functions answer bad arguments with the project's own exceptions, in one
line, and the deployment surfaces estimate their cost before they allocate.

One regression test per class the third reliability pass found (docs/reliability.md).
"""

from __future__ import annotations

import json
import math
import random
from pathlib import Path
from typing import Any, Callable

import networkx as nx
import numpy as np
import pytest

from glocal_verify import ArgumentError, GlocalVerifyError, System, UnknownConditionError, assess, load_example, require, spec_from_graph, verify
from glocal_verify.answer.gate import require_holds
from glocal_verify.cli import main
from glocal_verify.conditions.cost import SpecSizes, estimate_verify
from glocal_verify.conditions.export_cost import estimate_export
from glocal_verify.errors import ModelError, shorten
from glocal_verify.reporting.export import ExportError, _encode, _json_value, deployment_tree, export_observers, read_deployment
from glocal_verify.simulation.deployment import design_deployment
from glocal_verify.spec import loads_spec
from glocal_verify.spec.writer import dump_spec

from guarantee_checks.__main__ import UNCERTAINTY, paper19_sampled
from test_cli_outputs import _one_line, _tiny

#: the deployment of guarantee_checks on paper19 (h = 0.01 s)
DEPLOYMENT = UNCERTAINTY


@pytest.fixture(scope="module")
def paper19() -> System:
    return System(load_example("paper19"))


@pytest.fixture(scope="module")
def sampled19() -> System:
    return paper19_sampled()


@pytest.fixture(scope="module")
def report19(paper19: System) -> Any:
    return verify(paper19, ["privacy.*"])


# --------------------------------------------------------------------------------------------
# arguments of public functions


def test_a_reports_unknown_id_is_the_projects_unknown_condition_error_with_did_you_mean(report19: Any) -> None:
    with pytest.raises(UnknownConditionError, match="did you mean privacy.kernel"):
        report19["privacy.kernal"]
    with pytest.raises(KeyError):  # still a KeyError for callers that catch that
        report19["nope"]
    with pytest.raises(ArgumentError, match="a condition id is a string"):
        report19[["privacy.kernel"]]


@pytest.mark.parametrize("call", [
    lambda s, r: assess(None),
    lambda s, r: assess("report"),
    lambda s, r: require(r, None),
    lambda s, r: require(r, 5),
    lambda s, r: require(r, []),
    lambda s, r: require(None, ["privacy.kernel"]),
    lambda s, r: require_holds(r, None),
    lambda s, r: dump_spec(None),
    lambda s, r: dump_spec({"format": 1}),
    lambda s, r: export_observers(None, "x.json"),
    lambda s, r: export_observers(s, "x.json"),  # a System, not its Deployment
    lambda s, r: export_observers(design_deployment(s, thresholds=False), None),
    lambda s, r: read_deployment(None),
    lambda s, r: verify(s, ["privacy.kernel"], options="x"),
    lambda s, r: verify(s, ["privacy.kernel"], options={1: 2}),
    lambda s, r: verify(s, ["privacy.kernel"], progress=5),
    lambda s, r: verify(s, np.array([["privacy.kernel"]])),
    lambda s, r: spec_from_graph(nx.cycle_graph(4), weight=[]),
    lambda s, r: spec_from_graph(nx.cycle_graph(4), monitor_velocities=np.array([[1]])),
    lambda s, r: spec_from_graph(nx.cycle_graph(4), clusters={"a": np.array([[0, 1], [2, 3]])}),
], ids=lambda f: "")
def test_a_bad_argument_of_a_public_function_is_the_projects_own_exception(call: Callable[[System, Any], Any], paper19: System, report19: Any) -> None:
    with pytest.raises(GlocalVerifyError) as info:
        call(paper19, report19)
    assert "\n" not in str(info.value) and len(str(info.value)) < 300


def test_a_deployment_guarantee_refuses_an_infinite_or_nan_horizon(sampled19: System) -> None:
    from glocal_verify.simulation.certified_thresholds import certified_thresholds
    from glocal_verify.simulation.guarantees import detection_guarantee

    for call in (lambda: detection_guarantee(sampled19, size_horizon=math.inf), lambda: detection_guarantee(sampled19, horizon=math.nan),
                 lambda: certified_thresholds(sampled19, horizon=-1.0), lambda: detection_guarantee(sampled19, size=math.inf)):
        with pytest.raises(ArgumentError):
            call()


def test_certified_thresholds_of_an_absurd_horizon_are_refused_before_any_allocation(sampled19: System) -> None:
    from glocal_verify.simulation.certified_thresholds import certified_thresholds
    from glocal_verify.simulation.guarantees import detection_guarantee

    with pytest.raises(ModelError, match="certified thresholds too large.*--allow-large"):
        certified_thresholds(sampled19, horizon=1e7)  # 1e9 samples: was an attempt to allocate 164 GiB
    with pytest.raises(ModelError, match="certified thresholds too large"):
        detection_guarantee(sampled19, horizon=2000.0)  # 2e5 samples of (K, q, d) rows: about 5 GiB


# --------------------------------------------------------------------------------------------
# estimates of the deployment surfaces


def test_verify_refuses_detection_of_a_tiny_period_with_its_estimate(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    spec = tmp_path / "s.toml"
    spec.write_text(dump_spec(load_example("paper19")) + DEPLOYMENT.replace("0.01", "0.00001"))
    assert main(["verify", str(spec), "--only", "detection.*"]) == 2
    line = _one_line(capsys.readouterr().err)
    assert "certified thresholds" in line and "--allow-large" in line and "GiB" in line


def test_a_long_horizon_of_a_small_network_costs_its_simulated_samples() -> None:
    short = SpecSizes.from_spec(loads_spec(_tiny(horizon="10.0")))
    long = SpecSizes.from_spec(loads_spec(_tiny(horizon="100000.0")))
    assert long.samples == 2_000_001
    t_short = estimate_verify(short, ["switching.detects"], simulate=True).seconds
    t_long = estimate_verify(long, ["switching.detects"], simulate=True).seconds
    assert t_long > 20.0 > t_short  # measured 5.5 s for 200,001 samples: about 55 s here


def test_verify_estimates_the_certified_thresholds_from_the_deployment_sizes(sampled19: System) -> None:
    sizes = SpecSizes.from_spec(sampled19.spec)
    assert sizes.threshold_samples == 3001
    # the central observer's 3 channels x (38 + 2) and the four local observers' (2 x measured agents) x (2 n_i + 2)
    from glocal_verify.observers.sampled import sampled_observers

    dets, _ = sampled_observers(sampled19, sampled19.spec.implementation)
    exact = sum(len(o.channels) * (o.F.nrows() + 2) for o in dets)
    assert 0.5 * exact <= sizes.detector_work <= 2.0 * exact
    est = estimate_verify(sizes, ["detection.thresholds"])
    assert dict(est.phases)["certified thresholds and guarantees"] > 0


def test_export_is_estimated_and_refused_above_the_limits_and_allow_large_is_accepted(tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch) -> None:
    from glocal_verify import config

    spec = tmp_path / "s.toml"
    spec.write_text(_tiny())
    est = estimate_export(SpecSizes.from_spec(loads_spec(_tiny())), "json")
    assert est.command == "export" and est.seconds > 0 and est.bytes > 0
    with config.override(max_seconds=1e-3):
        assert main(["export", str(spec), "--out", str(tmp_path / "d.json"), "--quiet"]) == 2
        assert "export of 4 agents: estimated" in _one_line(capsys.readouterr().err)
        assert main(["export", str(spec), "--out", str(tmp_path / "d.json"), "--quiet", "--allow-large"]) == 0
    assert read_deployment(tmp_path / "d.json")["schema"]


def test_the_export_estimate_grows_as_the_square_of_the_agents() -> None:
    def ring(n: int) -> SpecSizes:
        return SpecSizes.from_spec(spec_from_graph(nx.cycle_graph(n), monitor_velocities=[0]))

    small, big = estimate_export(ring(200), "json"), estimate_export(ring(800), "json")
    assert big.bytes > 4 * (small.bytes - 300 * 1024**2)
    assert estimate_export(ring(800), "mat").seconds < big.seconds


# --------------------------------------------------------------------------------------------
# the deployment file


def test_the_streamed_json_is_the_text_of_json_dumps_with_indent_1(paper19: System) -> None:
    tree = deployment_tree(design_deployment(paper19))
    odd = {"a": np.array([[1.5, np.nan], [-np.inf, 0.0]]), "b": np.array([], dtype=float), "c": np.array([1, 2], dtype=np.int64),
           "d": [], "e": {}, "f": [np.float64(2.5), np.int32(3), True, None, "t\u00e9xt \"q\""], "g": np.zeros((2, 0))}
    for t in (tree, odd):
        assert b"".join(_encode(t, "json")) == (json.dumps(_json_value(t), indent=1, allow_nan=False) + "\n").encode("utf-8")


def test_a_corrupt_deployment_file_is_an_export_error_whatever_the_damage(paper19: System, tmp_path: Path) -> None:
    rng = random.Random(20261207)
    deployment = design_deployment(paper19, thresholds=False)
    originals = {fmt: export_observers(deployment, tmp_path / f"p.{fmt}").read_bytes() for fmt in ("json", "mat", "npz")}
    for k in range(150):
        fmt = rng.choice(sorted(originals))
        data = bytearray(originals[fmt])
        how = k % 4
        if how == 0:
            for _ in range(rng.randint(1, 20)):
                data[rng.randrange(len(data))] = rng.randrange(256)
        elif how == 1:
            data = data[: rng.randrange(len(data))]
        elif how == 2:
            at = rng.randrange(len(data))
            data[at:at + 64] = bytes(min(64, len(data) - at))
        else:
            data = bytearray(b"[" * 50_000 if fmt == "json" else b"\x00" * 200)
        bad = tmp_path / f"bad.{fmt}"
        bad.write_bytes(bytes(data))
        try:
            read_deployment(bad)
        except ExportError as exc:
            assert "\n" not in str(exc) and len(str(exc)) < 400
        except GlocalVerifyError as exc:  # pragma: no cover - the wrong class of the project's own
            raise AssertionError(f"{type(exc).__name__}: {exc}") from exc


# --------------------------------------------------------------------------------------------
# one readable line


def test_a_500_character_noise_channel_key_gives_one_short_line(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    spec = tmp_path / "s.toml"
    spec.write_text(dump_spec(load_example("paper19")) + DEPLOYMENT.replace("noise = 0.001", 'noise = {"v:' + "a" * 500 + '" = 0.002}'))
    assert main(["verify", str(spec), "--quiet"]) == 2
    line = _one_line(capsys.readouterr().err)
    assert len(line) <= 420 and "uncertainty.noise" in line


def test_shorten_keeps_the_start_and_the_end_of_a_long_line() -> None:
    text = "start " + "x" * 1000 + " end"
    out = shorten(text, 100)
    assert len(out) == 100 and out.startswith("start ") and out.endswith(" end") and "..." in out
    assert shorten("one\ntwo") == "one"


# --------------------------------------------------------------------------------------------
# guarantee_checks and long names on every path a command reads or writes


@pytest.mark.parametrize("argv", [["--runs", "0"], ["--seed", "-1"], ["--attack-runs", "x"], ["--out", "/dev/null/x"], ["--bogus"]])
def test_guarantee_checks_refuses_bad_arguments_in_one_line_before_any_work(argv: list[str], capsys: pytest.CaptureFixture[str]) -> None:
    from guarantee_checks.__main__ import main as guarantee_main

    assert guarantee_main(argv) == 2
    line = _one_line(capsys.readouterr().err)
    assert line.startswith("python -m guarantee_checks: error:")


@pytest.mark.parametrize("argv", [["findings", "--dir", "d" * 400], ["audit", "--example", "paper19", "--out", "n" * 400 + ".md"],
                                  ["audit", "--example", "paper19", "--figure", "f" * 400 + ".svg"]])
def test_a_name_too_long_to_exist_is_one_line_on_every_path(argv: list[str], capsys: pytest.CaptureFixture[str]) -> None:
    assert main(argv) == 2
    assert len(_one_line(capsys.readouterr().err)) < 300


def test_the_export_estimate_counts_the_sampled_deployment_of_the_schedule(sampled19: System) -> None:
    with_sampled = estimate_export(SpecSizes.from_spec(sampled19.spec), "json")
    without = estimate_export(SpecSizes.from_spec(load_example("paper19")), "json")
    phases = dict(with_sampled.phases)
    assert phases["certified thresholds of the schedule"] > 3.0  # measured 9-12 s on paper19 at h = 0.01 s
    assert with_sampled.seconds > without.seconds and with_sampled.bytes > without.bytes
