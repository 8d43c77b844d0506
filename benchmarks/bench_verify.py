"""`glocal-verify verify` on random clustered networks: structured path at scale.

Baselines, measured in the same run:
- the command line ``glocal-verify verify`` (and ``place-observers``) at N = 1000, 2000,
  4000, on the friendly family (3 clusters) and the realistic one (clusters of about 100
  agents with one observer each, one safe mode), with the undecided verdicts and the
  assessment's bottom line of every run (10,000 with ``python -m benchmarks --large`` or ``GLOCAL_BENCH_LARGE=1``), each in
  its own process (wall and CPU time, peak resident memory), against one
  ``numpy.linalg.eigh`` of the same Laplacian timed in this process: the goal is a few
  eigendecompositions per command (the 10,000-agent row runs without ``--allow-large``: its
  estimate is within the limits); ``verify --exact`` at N = 200; ``verify`` on a 20,000-agent
  path graph, which must finish in 10 min or be refused at once with its estimate;
- the certified spectra of every mode (the normal mode from its clusters' blocks and rank-one
  factors, the safe modes as one more factor each) against ``eigh`` of every mode with the
  ``syrk`` that certifies its orthonormality;
- the same structured verification at N = 250 (scaling ratio);
- the generic dense methods (2N-state pencil for the ZDA, orthogonal staircase for the
  unobservable subspace) against the structured N-sized ones on the same systems;
- the exact (flint) decision of Theorem III.3 (ii) against the numeric one at small N.
"""

from __future__ import annotations

import os
import tempfile
from pathlib import Path

import networkx as nx
import numpy as np

from glocal_verify import System, spec_from_graph, verify
from glocal_verify.analysis.unobservable.subspace import unobservable_subspace
from glocal_verify.analysis.stealthy.zda import zda_analysis
from glocal_verify.design.generators import random_clustered_spec
from glocal_verify.numerics.staircase import unobservable_subspace_dense

from .harness import Row, best_time, cli, eigh_seconds, run_command, write_spec

#: the goal of the scale issue: a command costs at most this many eigendecompositions
EIGH_GOAL = 5.0

#: longest a command row may run before it is killed and reported as not finished
COMMAND_BUDGET = float(os.environ.get("GLOCAL_BENCH_BUDGET", "420"))


def _verdicts(report_json: str) -> tuple[str, str]:
    """(``"3 of 57"`` undecided, the assessment's bottom line) of a ``verify --format json`` report."""
    import json

    try:
        with open(report_json, encoding="utf-8") as fh:
            data = json.load(fh)
    except (OSError, ValueError):
        return "", ""
    results = data.get("conditions", [])
    und = sum(1 for r in results if r.get("status") == "undecided")
    attack = (data.get("assessment") or {}).get("attack") or {}
    return f"{und} of {len(results)}", f"bottom line: {attack.get('verdict', '?')}"


def command_row(group: str, case: str, command: str, argv: list[str], n: int, system: System, budget: float = COMMAND_BUDGET, goal: str = "", report_json: str = "") -> Row:
    """One command-line row: ``argv`` in its own process against one eigh of L (N x N).

    With ``report_json`` (the JSON report the command writes) the row counts its undecided
    verdicts and names the assessment's bottom line."""
    t_eigh = eigh_seconds(system.laplacian())
    if report_json and os.path.exists(report_json):
        os.unlink(report_json)
    m = run_command(argv, timeout=budget)
    x = m.seconds / t_eigh if t_eigh > 0 else float("nan")
    status = m.describe(budget)
    undecided, bottom = _verdicts(report_json) if report_json else ("", "")
    note = f"{status}; {x:.1f} x eigh" + (f"; goal {goal}" if goal else "") + (f"; {bottom}" if bottom else "")
    return Row(group, case, f"one eigh of L ({n} x {n})", t_eigh, command, m.seconds, note, m.peak_mib, undecided)


def command_rows(quick: bool) -> list[Row]:
    """``glocal-verify verify`` and ``place-observers`` at scale (module docstring)."""
    rows: list[Row] = []
    sizes = [250, 500] if quick else [1000, 2000, 4000]
    if os.environ.get("GLOCAL_BENCH_LARGE") and not quick:
        sizes.append(10_000)
    group = "user commands at scale (each in its own process; ratio = eigh / command)"
    with tempfile.TemporaryDirectory() as tmp:
        out = os.path.join(tmp, "r.json")
        for n in sizes:
            spec = random_clustered_spec(n, 3, seed=7)
            path = write_spec(spec, Path(tmp), f"rc{n}")
            goal = "< 5 min, < 8 GiB" if n >= 10_000 else f"<= {EIGH_GOAL:g} x eigh"
            budget = 1800.0 if n >= 10_000 else COMMAND_BUDGET
            argv = cli("verify", str(path), "--quiet", "--format", "json", "--out", out)
            rows.append(command_row(group, f"verify, N = {n}, 3 clusters", "glocal-verify verify", argv, n, System(spec), budget, goal, out))
        # the realistic family: clusters of about 100 agents, one observer each, links between
        # consecutive clusters, weights 1-3, one safe mode
        for n in sizes:
            spec = random_clustered_spec(n, max(2, n // 100), seed=7, modes=1)
            path = write_spec(spec, Path(tmp), f"real{n}")
            goal = "< 5 min, < 8 GiB" if n >= 10_000 else f"<= {EIGH_GOAL:g} x eigh"
            budget = 1800.0 if n >= 10_000 else COMMAND_BUDGET
            argv = cli("verify", str(path), "--quiet", "--format", "json", "--out", out)
            rows.append(command_row(group, f"verify, N = {n}, {max(2, n // 100)} clusters of ~100 (realistic)", "glocal-verify verify", argv, n, System(spec), budget, goal, out))
        if not quick:
            spec = random_clustered_spec(200, 3, seed=7)
            path = write_spec(spec, Path(tmp), "rc200")
            argv = cli("verify", str(path), "--exact", "--quiet", "--format", "json", "--out", out)
            rows.append(command_row(group, "verify --exact, N = 200, 3 clusters", "glocal-verify verify --exact", argv, 200, System(spec), goal="< 60 s per condition", report_json=out))
        # a path graph of 20,000 agents: finish in < 10 min or refuse at once with the estimate
        path = write_spec(spec_from_graph(nx.path_graph(range(1, 20_001)), name="path20000", monitor_velocities=[1, 20_000]), Path(tmp), "path20000")
        m = run_command(cli("verify", str(path), "--quiet", "--out", os.path.join(tmp, "r.md")), timeout=600.0)
        refused = m.returncode == 2
        rows.append(
            Row(group, "verify, path graph of 20,000 agents", "-", None, "glocal-verify verify (refused by the size estimate)" if refused else "glocal-verify verify",
                m.seconds, f"{m.describe(600.0)}; {'refused at once with the estimate' if refused else 'ran'}; goal: finish < 10 min or refuse at once", m.peak_mib)
        )
        n = 250 if quick else 1000
        spec = random_clustered_spec(n, 3, seed=7)
        path = write_spec(spec, Path(tmp), f"po{n}")
        rows.append(command_row(group, f"place-observers, N = {n}, 3 clusters", "glocal-verify place-observers", cli("place-observers", str(path), "--quiet", "--out", os.path.join(tmp, "p.toml")), n, System(spec), goal="< 1 min"))
    return rows


def _deflation_row(n: int) -> Row:
    """The staircase of the modal ZDA pencil: symmetric step (upper triangle; small products on one thread, the two large ones on every core) vs general step.

    The pencil has the modal shape of ``stealthy.zda``: a diagonal state matrix, B and C^T
    columns of one orthogonal matrix, N / 100 outputs (the generator's monitors) and 2 inputs.
    """
    from glocal_verify.numerics.balancing import _reduce
    from glocal_verify.numerics.tolerance import DEFAULT_TOLERANCE

    rng = np.random.default_rng(0)
    U = np.linalg.qr(rng.standard_normal((n, n)))[0]
    A = np.diag(-np.linspace(0.0, 20.0, n))
    p = max(2, n // 100)
    B, C, D = U[:, :2].copy(), U[:, 2 : 2 + p].T.copy(), np.zeros((p, 2))
    tg = best_time(lambda: _reduce(A, B, C, D, DEFAULT_TOLERANCE, 20.0, 0.0, symmetric_step=False), repeat=2, budget=120.0)
    ts = best_time(lambda: _reduce(A, B, C, D, DEFAULT_TOLERANCE, 20.0, 0.0), repeat=2, budget=120.0)
    return Row("stealthy.zda: deflation of the modal pencil", f"N = {n}, {p} outputs, 2 inputs", "general step (both triangles, default threads)", tg, "symmetric step (upper triangle; small products on one thread, the two large ones on every core)", ts)


def _spectra_row(n: int) -> Row:
    """Every mode's certified spectrum: from the clusters' blocks and rank-one factors (as verify builds them) vs eigh + syrk per mode."""
    from glocal_verify.numerics.spectrum import Spectrum

    spec = random_clustered_spec(n, 3, seed=7)
    system = System(spec)
    laps = [system.laplacian_sparse(m) for m in system.modes]

    def eigh_path() -> None:
        for L in laps:
            sp = Spectrum(L)
            _ = sp.error_radius

    def factored() -> None:
        fresh = System(spec)
        for m in fresh.modes:
            _ = fresh.spectrum(m).error_radius

    te = best_time(eigh_path, repeat=1, budget=600.0)
    tf = best_time(factored, repeat=2, budget=300.0)
    from glocal_verify.numerics.block_spectrum import BlockSpectrum

    sp = System(spec).spectrum()
    built = isinstance(getattr(sp, "base", None), BlockSpectrum)
    return Row(
        "certified spectra of every mode (normal + 2 one-link safe modes)",
        f"N = {n}, 3 clusters, 4 links between them",
        "eigh + syrk + residuals per mode",
        te,
        "clusters' blocks + rank-one factors (normal), one more factor per safe mode",
        tf,
        f"normal mode from blocks: {'yes' if built else 'no'}; {te / tf:.1f} x faster",
    )


def run(quick: bool) -> list[Row]:
    rows: list[Row] = command_rows(quick)
    rows.append(_spectra_row(2000 if quick else 4000))
    sizes = [250, 500]
    base_t: float | None = None
    for n in sizes:
        spec = random_clustered_spec(n, 3, seed=7)

        def job(spec=spec) -> None:  # type: ignore[no-untyped-def]
            verify(System(spec))

        t = best_time(job, repeat=2 if n >= 1000 else 3, budget=300.0)
        if base_t is None:
            base_t = t
        rows.append(
            Row(
                "verify (every implemented checker, structured paths)",
                f"N = {n}, 3 clusters",
                "same at N = 250",
                base_t,
                "structured verify",
                t,
                f"time grows x{t / base_t:.1f} for x{n / 250:.0f} agents",
            )
        )
    for n in ([40, 80] if quick else [40, 80, 160]):
        system = System(random_clustered_spec(n, 2, seed=5))
        A, C = system.A(), system.C()

        def fresh(system: System = system) -> System:
            return System(system.spec)  # no cached eigen-decomposition

        td = best_time(lambda: zda_analysis(fresh(), method="dense"), budget=120.0)
        ts = best_time(lambda: zda_analysis(fresh()))
        rows.append(Row("stealthy.zda: structured (N-sized modal pencil) vs dense (2N Rosenbrock pencil)", f"N = {n}", "dense pencil", td, "structured", ts))
        tdo = best_time(lambda: unobservable_subspace_dense(A, C), budget=120.0)
        tso = best_time(lambda: unobservable_subspace(fresh()))
        rows.append(Row("unobservable subspace: modal formula vs dense staircase", f"N = {n}", "dense staircase", tdo, "modal", tso))
    rows.append(_deflation_row(500 if quick else 4000))
    for n in ([20, 40] if quick else [20, 40, 80]):
        spec = random_clustered_spec(n, 2, seed=3)
        system = System(spec)
        tn = best_time(lambda: verify(system, ["switching.distinct-eigenvalues"]))
        te = best_time(lambda: verify(system, ["switching.distinct-eigenvalues"], exact=True))
        rows.append(Row("Theorem III.3 (ii): exact vs numeric", f"N = {n}", "exact (flint charpoly, gcd)", te, "numeric (eigh)", tn))
    return rows
