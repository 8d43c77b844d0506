"""Size limits: every command estimates its time and memory from the spec's sizes and refuses,
at once and in one line, a run above the limits unless ``--allow-large``."""

from __future__ import annotations

import argparse
import dataclasses
import time
from pathlib import Path

import networkx as nx
import pytest

import glocal_verify.model as model
from glocal_verify import config
from glocal_verify import spec_from_graph
from glocal_verify.cli import main
from glocal_verify.cli.common import check_cost
from glocal_verify.conditions import cost
from glocal_verify.conditions.cost import (
    CostEstimate,
    Limits,
    SizeLimitError,
    SpecSizes,
    check_limits,
    default_limits,
    estimate_audit,
    estimate_design,
    estimate_place_observers,
    estimate_verify,
    format_bytes,
    format_seconds,
    refusal,
)
from glocal_verify.errors import GlocalVerifyError, ModelError
from glocal_verify.spec.examples import load_example
from glocal_verify.spec.writer import dump_spec

MIB = 1024.0**2
GIB = 1024.0**3

#: the sizes of random_clustered_spec(1000, 3, seed=7): three clusters, one observer each, two
#: safe modes that both change the middle cluster, an attack
V1000 = SpecSizes(1000, (333, 334, 333), ("P1", "P2", "P3"), (1, 1, 1), (0, 2, 0), modes=2, channels=10, attack=True)


def _clustered(n: int, clusters: int = 3, modes: int = 2, observers: int = 1) -> SpecSizes:
    size = n // clusters
    sizes = tuple([size] * (clusters - 1) + [n - size * (clusters - 1)])
    names = tuple(f"P{i}" for i in range(clusters))
    changed = tuple([modes] + [0] * (clusters - 1))
    return SpecSizes(n, sizes, names, (observers,) * clusters, changed, modes=modes, channels=3, attack=True)


@pytest.fixture(scope="module")
def path20000(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A 20,000-agent path graph with velocity monitors at both ends (no clusters)."""
    spec = spec_from_graph(nx.path_graph(range(1, 20001)), name="path20000", monitor_velocities=[1, 20000])
    path = tmp_path_factory.mktemp("big") / "path20000.toml"
    path.write_text(dump_spec(spec))
    return path


def _one_line(text: str) -> str:
    lines = [ln for ln in text.splitlines() if ln.strip()]
    assert len(lines) == 1, lines
    return lines[0]


# --------------------------------------------------------------------------------------------
# the formula


def test_the_verify_estimate_is_the_documented_formula() -> None:
    est = estimate_verify(V1000, exact_budget=None)
    n3, n2 = 1000.0**3, 1000.0**2
    # clusters of >= 60 agents get the modal UIO design in a numeric run
    uio = cost.C_UIO_MODAL * ((666.0**3) * 1 + (668.0**3) * 3 + (666.0**3) * 1)
    pencil = cost.C_PENCIL * 2 * (666.0**3 + 668.0**3 + 666.0**3)
    # below block_min_agents the normal mode is one eigh; both safe modes (no mode_changes given) are fresh
    glob = (cost.C_EIGH + 2 * cost.C_GLOBAL_MODE + cost.C_GLOBAL_REST) * n3 + cost.C_GLOBAL_REST_SQ * n2
    assert est.seconds == pytest.approx(cost.C_START + glob + uio + pencil)
    arrays = cost.A_GLOBAL + 2 * cost.A_GLOBAL_MODE
    local_bytes = cost.A_UIO_MODAL * 8.0 * (666.0**2 * 1 + 668.0**2 * 3 + 666.0**2 * 1)
    assert est.bytes == pytest.approx(cost.B_BASE + arrays * 8.0 * 1000.0**2 + local_bytes)
    assert est.dense_arrays == arrays
    # the documented constants
    assert (cost.C_START, cost.C_EIGH, cost.C_FACTOR, cost.C_GLOBAL_MODE, cost.C_GLOBAL_REST, cost.C_GLOBAL_REST_SQ) == (3.0, 2.1e-10, 8e-8, 0.5e-9, 3.3e-11, 5e-7)
    assert (cost.C_UIO, cost.C_UIO_MODAL, cost.C_PENCIL) == (6.5e-9, 0.8e-10, 0.6e-10)
    assert (cost.A_GLOBAL, cost.A_GLOBAL_BLOCKS, cost.A_GLOBAL_MODE, cost.A_UIO, cost.A_UIO_MODAL, cost.B_BASE) == (5.0, 2.0, 1.0, 10.0, 1.0, 300 * MIB)


def test_one_link_safe_modes_cost_a_rank_one_factor_not_an_eigendecomposition() -> None:
    fresh = estimate_verify(_clustered(1000), exact_budget=None)
    updated = estimate_verify(dataclasses.replace(_clustered(1000), mode_changes=(1, 1)), exact_budget=None)
    n3, n2 = 1000.0**3, 1000.0**2
    assert fresh.seconds - updated.seconds == pytest.approx(2 * (cost.C_GLOBAL_MODE * n3 - cost.C_FACTOR * n2))
    assert fresh.bytes - updated.bytes == pytest.approx(2 * cost.A_GLOBAL_MODE * 8.0 * n2)  # a factored mode keeps O(N)
    # below rank_one_min_agents, or with more changed links, every safe mode gets its own eigh
    small = dataclasses.replace(_clustered(300), mode_changes=(1, 1))
    assert estimate_verify(small, exact_budget=None).seconds == pytest.approx(estimate_verify(_clustered(300), exact_budget=None).seconds)
    many = dataclasses.replace(_clustered(1000), mode_changes=(4, 1))
    assert estimate_verify(many, exact_budget=None).seconds == pytest.approx(fresh.seconds - cost.C_GLOBAL_MODE * n3 + cost.C_FACTOR * n2)


def test_a_clustered_normal_mode_costs_its_blocks_and_its_links_between_clusters() -> None:
    n = 10_000
    whole = dataclasses.replace(_clustered(n), mode_changes=(1, 1))
    blocks = dataclasses.replace(whole, cut_links=4, partitioned=True)
    assert blocks.block_built and not whole.block_built
    n3, n2 = float(n) ** 3, float(n) ** 2
    sum3 = sum(float(k) ** 3 for k in blocks.cluster_sizes)
    a, b = estimate_verify(whole, exact_budget=None), estimate_verify(blocks, exact_budget=None)
    assert a.seconds - b.seconds == pytest.approx(cost.C_EIGH * (n3 - sum3) - cost.C_FACTOR * 4 * n2)
    assert a.dense_arrays - b.dense_arrays == cost.A_GLOBAL - cost.A_GLOBAL_BLOCKS
    # too many links between clusters, too few agents, or clusters that leave agents out: one eigh
    for other in (dataclasses.replace(blocks, cut_links=config.get("block_max_cut_links") + 1), dataclasses.replace(blocks, partitioned=False)):
        assert not other.block_built
    assert not dataclasses.replace(_clustered(config.get("block_min_agents") - 1), cut_links=4, partitioned=True).block_built


def test_the_verify_estimate_matches_the_calibration_runs_within_a_factor_of_two() -> None:
    # glocal-verify verify on random_clustered_spec(N, 3, seed=7) (two one-link safe modes, four
    # links between clusters), OPENBLAS_NUM_THREADS=1, 2 cores: CPU seconds and peak RSS
    # (/usr/bin/time; 10,000 agents with --allow-large), after the normal mode built from its
    # clusters' blocks and the factored safe modes
    measured = {1000: (5.9, 335 * MIB), 2000: (7.7, 252 * MIB), 4000: (26.2, 670 * MIB), 10000: (250.5, 3234 * MIB)}
    for n, (secs, peak) in measured.items():
        s = dataclasses.replace(_clustered(n), changed_by_modes=(0, 2, 0), mode_changes=(1, 1), cut_links=4, partitioned=True)
        est = estimate_verify(s, exact_budget=None)
        assert secs / 2 < est.seconds < 2 * secs, (n, est.seconds)
        assert peak <= est.bytes < 2 * peak, (n, est.bytes)  # memory errs high, not absurdly


def test_a_20000_agent_path_graph_costs_hours_and_tens_of_gib() -> None:
    est = estimate_verify(SpecSizes(20000, channels=2), exact_budget=None)
    n3, n2 = 20000.0**3, 20000.0**2
    assert est.seconds == pytest.approx(cost.C_START + (cost.C_EIGH + cost.C_GLOBAL_REST) * n3 + cost.C_GLOBAL_REST_SQ * n2)  # 36 min
    assert est.bytes == pytest.approx(cost.B_BASE + cost.A_GLOBAL * 8.0 * n2)  # 15 GiB
    assert est.describe().startswith("36 min and 15 GiB (5 dense 20000 x 20000 arrays")


def test_every_estimate_grows_with_the_number_of_agents() -> None:
    prev: dict[str, CostEstimate] = {}
    for n in (30, 100, 300, 1000, 3000, 10000, 20000):
        s = _clustered(n)
        now = {
            "verify": estimate_verify(s),
            "exact": estimate_verify(s, exact=True),
            "place": estimate_place_observers(s),
            "audit": estimate_audit(s, 2),
            # the default switches from an exact to a numeric assessment above 60 agents: each
            # kind of assessment grows on its own
            "design (numeric assessment)": estimate_design(s, exact_assessment=False),
            "design (exact assessment)": estimate_design(s, exact_assessment=True),
        }
        for key, est in now.items():
            if key in prev:
                assert est.seconds > prev[key].seconds, (key, n)
                assert est.bytes > prev[key].bytes, (key, n)
        prev = now


def test_the_estimate_grows_with_clusters_observers_safe_modes_and_attack_sets() -> None:
    base = _clustered(3000, clusters=3, modes=1)
    assert estimate_verify(_clustered(3000, clusters=2, modes=1)).seconds > estimate_verify(base).seconds  # larger clusters
    assert estimate_verify(_clustered(3000, observers=2, modes=1)).seconds > estimate_verify(base).seconds
    assert estimate_verify(_clustered(3000, modes=3)).seconds > estimate_verify(base).seconds
    assert estimate_verify(_clustered(3000, modes=3)).bytes > estimate_verify(base).bytes
    assert estimate_verify(dataclasses.replace(base, attack=False)).seconds < estimate_verify(base).seconds
    assert estimate_verify(base, exact=True).seconds > estimate_verify(base).seconds
    assert estimate_audit(base, 2).seconds > estimate_audit(base, 1).seconds
    assert estimate_audit(base, 2, 500).seconds < estimate_audit(base, 2).seconds
    assert estimate_audit(base, 2, workers=2).seconds < estimate_audit(base, 2).seconds
    assert estimate_audit(base, 3, 100).bytes > estimate_audit(base, 2, 100).bytes  # rows held
    assert estimate_design(base, max_attackers=2).seconds > estimate_design(base, max_attackers=1).seconds


def test_only_local_checkers_skip_the_global_spectra_and_only_global_ones_skip_the_clusters() -> None:
    s = _clustered(6000)
    full = estimate_verify(s)
    local = estimate_verify(s, ["local.uio", "local.pencil"])
    glob = estimate_verify(s, ["switched-observability", "stealthy.zda"])
    assert local.seconds < full.seconds and glob.seconds < full.seconds
    assert local.dense_arrays == cost.A_LOCAL_ONLY and local.bytes < full.bytes and glob.bytes < full.bytes
    assert all("local" not in name for name, _ in glob.phases)
    assert all(name.startswith("local.") for name, _ in local.phases)
    assert local.seconds + glob.seconds == pytest.approx(full.seconds + cost.C_START)


def test_the_exact_budget_counts_against_the_time_limit_but_not_in_the_estimate() -> None:
    s = _clustered(100)
    a, b = estimate_verify(s, exact_budget=30.0), estimate_verify(s, exact_budget=None)
    assert a.seconds == b.seconds and a.extra_seconds == 30.0 and b.extra_seconds == 0.0
    assert a.bound_seconds == a.seconds + 30.0
    assert estimate_verify(s, exact=True, exact_budget=30.0).extra_seconds == 0.0  # --exact does not escalate


def test_sizes_are_read_from_the_spec_without_building_spectra() -> None:
    spec = load_example("paper19")
    s = SpecSizes.from_spec(spec)
    assert s.n == len(spec.nodes) and s.cluster_sizes == tuple(len(c.nodes) for c in spec.clusters)
    assert s.observers == tuple(len(c.observers) for c in spec.clusters) and s.modes == len(spec.modes)
    assert all(0 <= ch <= s.modes for ch in s.changed_by_modes) and sum(s.changed_by_modes) >= 1
    one = s.only_cluster(s.cluster_names[0])
    assert one.cluster_sizes == s.cluster_sizes[:1] and s.only_cluster("no such cluster") == s
    assert estimate_place_observers(s, s.cluster_names[0]).seconds < estimate_place_observers(s).seconds


# --------------------------------------------------------------------------------------------
# limits


def test_the_default_memory_limit_is_the_smaller_of_8_gib_and_80_percent_of_what_is_available() -> None:
    assert default_limits(available=100 * GIB).bytes == 8 * GIB
    assert default_limits(available=4 * GIB).bytes == pytest.approx(0.8 * 4 * GIB)
    assert default_limits(available=4 * GIB).seconds == 600.0
    assert 0 < default_limits().bytes <= 8 * GIB


def test_small_specs_are_never_refused() -> None:
    limits = Limits(600.0, 1 * GIB)  # even on a machine with little memory
    for s in (SpecSizes.from_spec(load_example("paper19")), _clustered(60), _clustered(250)):
        for est in (estimate_verify(s), estimate_place_observers(s), estimate_audit(s, 2), estimate_design(s)):
            assert refusal(est, limits) is None, est
            check_limits(est, limits)


def test_the_library_raises_the_projects_own_exception_with_one_line() -> None:
    est = estimate_verify(SpecSizes(20000))
    with pytest.raises(SizeLimitError) as info:
        check_limits(est, Limits())
    assert isinstance(info.value, GlocalVerifyError) and isinstance(info.value, ModelError)
    text = str(info.value)
    assert "\n" not in text and text.startswith("verify of 20000 agents: estimated 36 min")
    assert "limits 10 min, 8 GiB" in text and "--allow-large" in text
    assert info.value.estimate is est and refusal(est, Limits()) == "time and memory"


def test_allow_large_passes_the_check() -> None:
    check_limits(estimate_verify(SpecSizes(20000)), Limits(), allow=True)
    check_limits(estimate_audit(SpecSizes(20000), 3), Limits(1.0, 1.0), allow=True)


def test_a_long_run_within_the_limits_is_announced_unless_quiet(capsys: pytest.CaptureFixture[str]) -> None:
    est = CostEstimate("verify", 3000, 120.0, 2 * GIB, 17.0, (("local.uio", 100.0),))
    check_cost(est, argparse.Namespace(quiet=False, allow_large=False))
    line = _one_line(capsys.readouterr().err)
    assert line == "glocal-verify: verify of 3000 agents: estimated 2 min and 2 GiB (17 dense 3000 x 3000 arrays; mostly local.uio)"
    check_cost(est, argparse.Namespace(quiet=True, allow_large=False))
    check_cost(dataclasses.replace(est, seconds=10.0), argparse.Namespace(quiet=False, allow_large=False))
    assert capsys.readouterr().err == ""


def test_durations_and_sizes_read_naturally() -> None:
    assert [format_seconds(x) for x in (12.3, 600.0, 12803.0, 3e6, float("inf"))] == ["12 s", "10 min", "3.6 h", "35 days", "forever"]
    assert [format_bytes(x) for x in (300 * MIB, 8 * GIB, 9.6 * GIB, 36.4 * GIB)] == ["300 MiB", "8 GiB", "9.6 GiB", "36 GiB"]


# --------------------------------------------------------------------------------------------
# the command line


def test_a_20000_agent_path_graph_is_refused_at_once_by_verify(path20000: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    t0 = time.perf_counter()
    code = main(["verify", str(path20000), "--quiet", "--out", str(tmp_path / "r.md")])
    elapsed = time.perf_counter() - t0
    assert code == 2
    line = _one_line(capsys.readouterr().err)
    assert line.startswith("glocal-verify: error: verify of 20000 agents: estimated ")
    assert "GiB" in line and "--allow-large" in line and "--only CONDITION" in line and "Traceback" not in line
    assert not (tmp_path / "r.md").exists()
    assert elapsed < 20.0  # a hang guard, not a performance assertion


def test_audit_and_design_refuse_the_big_path_graph_too(path20000: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["audit", str(path20000), "--max-attackers", "1", "--quiet"]) == 2
    assert "audit of 20000 agents: estimated" in _one_line(capsys.readouterr().err)
    assert main(["design", str(path20000), "--max-attackers", "1", "--quiet"]) == 2
    assert "design of 20000 agents: estimated" in _one_line(capsys.readouterr().err)


def test_allow_large_lets_a_refused_small_run_through(monkeypatch: pytest.MonkeyPatch, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    monkeypatch.setattr(cost, "default_limits", lambda available=None: Limits(0.5, 1.0))  # everything is "large"
    out = tmp_path / "r.md"
    argv = ["verify", "--example", "paper19", "--only", "privacy.*", "--out", str(out)]
    assert main(argv) == 2
    assert "verify of 19 agents: estimated" in _one_line(capsys.readouterr().err)
    assert not out.exists()
    assert main([*argv, "--allow-large"]) == 0
    err = capsys.readouterr().err
    assert "running anyway (--allow-large)" in err and out.exists()
    for cmd in (["place-observers", "--example", "paper19", "--quiet"], ["audit", "--example", "paper19", "--max-attackers", "1", "--quiet"]):
        assert main(cmd) == 2, cmd
        assert "--allow-large" in _one_line(capsys.readouterr().err)
