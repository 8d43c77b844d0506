"""Sweeps on Dask: an embedded LocalCluster and a scheduler started as separate processes give
the same rows as computing each member in-process; failures are rows; interrupted sweeps resume."""

from __future__ import annotations

import csv
import dataclasses
import json
import os
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import pytest

from glocal_verify.cli import main
from glocal_verify.design.sweep import SweepPlan, compute_sweep, load_sweep, plan_from_dict, run_member, sweep_rates, wilson_interval
from glocal_verify.reporting.sweep_report import SweepResult, sweep_outputs, write_sweep

SWEEP = """
[ensemble]
generator = "random-clustered"
agents = [12, 16]
clusters = 2
seeds = { start = 0, count = 2 }
[compute]
conditions = ["privacy.*", "switching.image-kernel", "switching.distinct-eigenvalues"]
"""

#: columns that depend on where and when a member ran
VOLATILE = {"seconds"}


def _rows(path: Path) -> list[dict[str, Any]]:
    with path.open(newline="", encoding="utf-8") as fh:
        return [{k: v for k, v in r.items() if k not in VOLATILE} for r in csv.DictReader(fh)]


def _in_process(plan_text: str, tmp: Path) -> list[dict[str, Any]]:
    (tmp / "ref.toml").write_text(plan_text)
    plan = load_sweep(tmp / "ref.toml")
    out = []
    for m in plan.members:
        out.extend(run_member(m, plan.conditions))
    return out


def _normal(rows: list[dict[str, Any]]) -> list[tuple[str, str, str, str]]:
    return sorted((str(r["member"]), str(r["condition"]), str(r.get("scope") or ""), str(r["status"])) for r in rows)


def test_a_sweep_on_a_two_worker_local_cluster_matches_the_members_computed_in_process(tmp_path: Path) -> None:
    (tmp_path / "s.toml").write_text(SWEEP)
    out = tmp_path / "r.csv"
    environ = dict(os.environ)
    assert main(["sweep", str(tmp_path / "s.toml"), "--out", str(out), "--workers", "2", "--quiet"]) == 0
    # the embedded cluster's settings for its workers (MALLOC_TRIM_THRESHOLD_, thread counts) do
    # not stay in this process's environment, where later commands would inherit them
    assert dict(os.environ) == environ
    rows = _rows(out)
    assert {r["member"] for r in rows} == {m.key for m in load_sweep(tmp_path / "s.toml").members}
    assert len({r["member"] for r in rows}) == 4
    assert _normal(rows) == _normal(_in_process(SWEEP, tmp_path))
    assert all(r["source"].startswith("random-clustered(") and "seed=" in r["source"] for r in rows)
    md = (tmp_path / "r.md").read_text()
    assert "Rate of `holds` against `agents`" in md and "privacy.kernel" in md
    assert (tmp_path / "r-agents.svg").exists()


@pytest.mark.slow
def test_a_sweep_through_an_external_scheduler_gives_identical_rows(tmp_path: Path) -> None:
    # this interpreter's modules, not a `dask` script found on PATH: the worker must import the
    # glocal_verify under test (a `dask` of another environment cannot unpickle its tasks)
    dask_cmd = [sys.executable, "-m", "distributed.cli.dask_scheduler"]
    worker_cmd = [sys.executable, "-m", "distributed.cli.dask_worker"]
    sched_file = tmp_path / "scheduler.json"
    env = {**os.environ, "OPENBLAS_NUM_THREADS": "1"}
    sched = subprocess.Popen([*dask_cmd, "--host", "127.0.0.1", "--port", "0", "--no-dashboard", "--scheduler-file", str(sched_file)], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, env=env)
    worker = None
    try:
        for _ in range(300):
            if sched_file.exists() and sched_file.stat().st_size:
                break
            time.sleep(0.1)
        address = json.loads(sched_file.read_text())["address"]
        assert address.startswith("tcp://127.0.0.1:")
        worker = subprocess.Popen([*worker_cmd, "--scheduler-file", str(sched_file), "--nworkers", "1", "--nthreads", "1", "--no-dashboard"], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, env=env)
        from distributed import Client

        with Client(address, timeout="60s") as probe:  # a user's cluster is up before it is used
            probe.wait_for_workers(1, timeout=120)
        (tmp_path / "s.toml").write_text(SWEEP)
        ext = tmp_path / "ext.csv"
        assert main(["sweep", str(tmp_path / "s.toml"), "--out", str(ext), "--scheduler", address, "--quiet"]) == 0
        loc = tmp_path / "loc.csv"
        assert main(["sweep", str(tmp_path / "s.toml"), "--out", str(loc), "--workers", "1", "--quiet"]) == 0
        assert _rows(ext) == _rows(loc)
    finally:
        for proc in (worker, sched):
            if proc is not None:
                proc.terminate()
                try:
                    proc.wait(timeout=20)
                except subprocess.TimeoutExpired:
                    proc.kill()


def _run_sweep(plan: SweepPlan, out: Path) -> SweepResult:
    """The command's steps: check the outputs, compute the members (one worker), write the table and summary."""
    run = compute_sweep(plan, sweep_outputs(plan, out)[1], workers=1)
    return write_sweep(run, plan, out, rates=sweep_rates(run.rows, plan.grid), figures=False)


@pytest.mark.slow
def test_a_failing_member_is_a_row_and_an_interrupted_sweep_resumes_from_its_parts(tmp_path: Path) -> None:
    from glocal_verify.spec.examples import example_text

    specs = tmp_path / "specs"
    specs.mkdir()
    (specs / "a-good.toml").write_text(example_text("paper19"))
    (specs / "b-bad.toml").write_text("[graph]\nnodes = 3\nedges = [[1, 9]]\n")
    plan = plan_from_dict({"ensemble": {"specs": str(specs)}, "compute": {"conditions": ["privacy.kernel"]}})
    out = tmp_path / "r.parquet"
    first = _run_sweep(plan, out)
    assert first.computed == 2 and first.resumed == 0
    bad = [r for r in first.rows if r["status"] == "error"]
    assert len(bad) == 1 and bad[0]["error_class"] == "SpecError" and "b_bad" in bad[0]["member"]
    # an interruption after the first member: its part survives, the rest is recomputed
    parts = sorted((tmp_path / "r.parquet.parts").glob("*.json"))
    parts[1].unlink()
    second = _run_sweep(plan, out)
    assert second.resumed == 1 and second.computed == 1
    assert _normal(list(second.rows)) == _normal(list(first.rows))
    import pyarrow.parquet as pq

    assert pq.read_table(out).num_rows == len(first.rows)


@pytest.mark.parametrize(
    ("text", "needle"),
    [
        ("[ensemble]\ngenerator = 'nope'\n", "ensemble.generator"),
        ("[ensemble]\ngenerator = 'random-clustered'\nagents = []\n", "ensemble.agents"),
        ("[ensemble]\ngenerator = 'random-clustered'\ncolour = 3\n", "ensemble.colour"),
        ("[ensemble]\ngenerator = 'random-clustered'\nseeds = {start = 0, count = 0}\n", "ensemble.seeds"),
        ("[ensemble]\ngenerator = 'random-clustered'\n[compute]\nconditions = ['privacy.kernal']\n", "compute.conditions"),
        ("[ensemble\n", "not valid TOML"),
    ],
)
def test_a_bad_sweep_file_gets_one_line_naming_the_key(tmp_path: Path, capsys: pytest.CaptureFixture[str], text: str, needle: str) -> None:
    (tmp_path / "s.toml").write_text(text)
    assert main(["sweep", str(tmp_path / "s.toml"), "--out", str(tmp_path / "r.csv")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and needle in err[0] and "Traceback" not in err[0]


def test_the_wilson_interval_contains_the_rate_and_narrows_with_more_trials() -> None:
    lo, hi = wilson_interval(5, 10)
    assert lo < 0.5 < hi
    lo2, hi2 = wilson_interval(50, 100)
    assert hi2 - lo2 < hi - lo
    assert wilson_interval(0, 0) == (0.0, 1.0)


@pytest.mark.slow
def test_an_audit_through_dask_gives_the_rows_of_the_in_process_audit() -> None:
    from glocal_verify import System
    from glocal_verify.design.audit import audit
    from glocal_verify.extra.dask import dask_executor
    from glocal_verify.design.generators import random_clustered_spec

    system = System(random_clustered_spec(16, 2, seed=3, attack=False))
    here = audit(system, 2, chunk_size=40)
    there = audit(system, 2, chunk_size=40, executor=dask_executor(workers=2))
    assert [r.to_json() for r in there.rows] == [r.to_json() for r in here.rows]
    assert len(here.rows) == 16 + 16 * 15 // 2
    chains = [r.answer.chain for r in there.rows if r.answer is not None]
    assert len({id(c) for c in chains}) == len(set(chains))  # rows from the workers were received: parts shared


@pytest.mark.slow
def test_tasks_sharing_one_object_send_it_once_not_once_per_task() -> None:
    import cloudpickle
    from distributed import Client, LocalCluster

    from glocal_verify.extra.dask import run_on_dask

    @dataclasses.dataclass(frozen=True)
    class SharedTask:  # local: pickled by value, so workers need not import the tests
        shared: Any
        k: int

        def __call__(self) -> tuple[int, int]:
            return self.k, len(self.shared["big"])

    class Recording:
        def __init__(self, client: Any) -> None:
            self.client, self.scattered, self.sizes = client, 0, []

        def scatter(self, *args: Any, **kwargs: Any) -> Any:
            self.scattered += 1
            return self.client.scatter(*args, **kwargs)

        def submit(self, fn: Any, *args: Any, **kwargs: Any) -> Any:
            self.sizes.append(len(cloudpickle.dumps(args[-1])))
            return self.client.submit(fn, *args, **kwargs)

    payload = {"big": list(range(50_000))}
    tasks = [SharedTask(payload, k) for k in range(8)]
    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None) as cluster, Client(cluster) as client:
        rec = Recording(client)
        out = dict(run_on_dask(rec, tasks))
    assert out == {k: (k, 50_000) for k in range(8)}
    assert rec.scattered == 1
    assert max(rec.sizes) < len(cloudpickle.dumps(payload)) / 20
