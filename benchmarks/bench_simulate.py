"""Exact simulation (glocal_verify/simulate.py): the paper's example and a 1,000-agent network.

Rows, each against a baseline measured in the same run:

- paper19, three cases of Section IV (Algorithm 1 with envelope thresholds, no figures):
  the exact dense propagator against the same runs' plant + observers integrated by
  ``scipy.integrate.solve_ivp`` (DOP853, rtol 1e-10), which is neither exact nor faster;
- the dense and the modal propagator on a 150-agent network (both exact);
- N = 1000 agents, 3 clusters, 30 s, the centralized observer and one UIO per cluster, modal
  propagator (``--quick``: N = 250), with the design times of the observers (other modules)
  and of the ZDA reported as notes. The generator's observer centres are random and usually
  admit no UIO (a boundary agent's velocity is unmeasured), so every cluster here gets an
  observer at a boundary agent that measures the cluster's boundary agents and its own
  neighbours (Proposition III.2 (ii) holds by construction). These rows time the simulator
  alone, WITHOUT the attack-free threshold pass and the observer designs;
- the full user command ``glocal-verify simulate SPEC --no-figures`` at N = 1000 (``--quick``:
  250) in its own process, thresholds, designs and Algorithm 1 included, against one eigh of
  the Laplacian (the goal: under 30 s).
"""

from __future__ import annotations

import os
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np
from scipy.integrate import solve_ivp

from glocal_verify import System, load_example, spec_from_dict
from glocal_verify.design.generators import random_clustered_spec
from glocal_verify.design.case_study import cases_for, companion_systems, run_case
from glocal_verify.simulation.attacks import zda_attack
from glocal_verify.simulation.engine import simulate
from glocal_verify.simulation.observer_models import (
    ObserverBank,
    central_observer_model,
    local_observer_models,
)
from glocal_verify.simulation.schedule import Schedule, random_initial_state
from glocal_verify.spec.types import SystemSpec

from .bench_verify import command_row
from .harness import Row, best_time, cli, write_spec


def with_boundary_observers(spec: SystemSpec) -> SystemSpec:
    """The same network with one observer per cluster at a boundary agent, measuring the
    positions and velocities of every boundary agent of the cluster and of its neighbours."""
    s = System(spec)
    clusters = []
    for c in spec.clusters:
        bnd = list(s.cluster_model(c.name).boundary)
        centre = bnd[0]
        meas = sorted(set(bnd) | {centre} | {a for a in s.neighbours(centre) if a in c.nodes}, key=s.index.__getitem__)
        clusters.append({"name": c.name, "nodes": list(c.nodes), "observers": [{"center": centre, "positions": meas, "velocities": meas}]})
    data: dict[str, Any] = {
        "format": 1,
        "name": spec.name + "-bo",
        "graph": {"nodes": list(spec.nodes), "edges": [[e.u, e.v, str(e.weight)] for e in spec.edges]},
        "modes": [{"name": m.name, "add": [[e.u, e.v, str(e.weight)] for e in m.add], "remove": [list(r) for r in m.remove]} for m in spec.modes],
        "clusters": clusters,
        "monitor": {"velocities": list(spec.monitor.velocities)},
        "simulation": {"horizon": spec.simulation.horizon, "step": spec.simulation.step, "seed": spec.simulation.seed},
    }
    if spec.attack is not None:
        data["attack"] = {"kind": "zda", "actuators": list(spec.attack.actuators)}
    if spec.switching is not None:
        data["switching"] = {"mode": spec.switching.mode, "time": spec.switching.time}
    return spec_from_dict(data)


def _solve_ivp_run(system: System, bank: ObserverBank, x0: np.ndarray, mode: str, ts: float) -> None:
    """Plant and observers, attack-free, integrated adaptively (the baseline of the first row)."""
    n2 = 2 * system.n
    obs = list(bank)
    offs = np.cumsum([0, n2] + [o.order for o in obs])

    def rhs(t: float, s: np.ndarray, q: str) -> np.ndarray:
        x = s[:n2]
        out = [system.A(q) @ x]
        for k, o in enumerate(obs):
            F, G = o.dynamics(q)
            out.append(F @ s[offs[k + 1] : offs[k + 2]] + G @ (o.C @ x))
        return np.concatenate(out)

    s0 = np.concatenate([x0] + [o.Z0 @ x0 for o in obs])
    grid = np.arange(0, 3001) * 0.01
    a = solve_ivp(rhs, (0, ts), s0, method="DOP853", rtol=1e-10, atol=1e-12, t_eval=grid[grid <= ts], args=("normal",))
    solve_ivp(rhs, (ts, 30.0), a.y[:, -1], method="DOP853", rtol=1e-10, atol=1e-12, t_eval=grid[grid > ts], args=(mode,))


def simulate_command_row(quick: bool) -> Row:
    """``glocal-verify simulate`` from the command line, everything included."""
    n = 250 if quick else 1000
    spec = random_clustered_spec(n, 3, seed=7)
    with tempfile.TemporaryDirectory() as tmp:
        path = write_spec(spec, Path(tmp), f"sim{n}")
        argv = cli("simulate", str(path), "--no-figures", "--quiet", "--out", os.path.join(tmp, "out"))
        return command_row(
            "user commands at scale (each in its own process; ratio = eigh / command)",
            f"simulate, N = {n}, 3 clusters, {spec.simulation.horizon:g} s, step {spec.simulation.step:g} (thresholds included)",
            "glocal-verify simulate --no-figures",
            argv,
            n,
            System(spec),
            goal="< 30 s",
        )


def run(quick: bool) -> list[Row]:
    rows: list[Row] = [simulate_command_row(quick)]

    # paper19: three cases (Algorithm 1 with thresholds: 3 simulations per case)
    p19 = System(load_example("paper19"))
    cases = cases_for(p19, companion_systems(p19))
    t_cases = best_time(lambda: [run_case(c) for c in cases], repeat=1 if quick else 2, budget=120.0)
    bank = ObserverBank.for_system(p19)
    x0 = random_initial_state(p19)
    t_dense = best_time(lambda: simulate(p19, schedule=Schedule.single("case-2", 10.0), observers=bank, x0=x0, method="dense"))
    t_ivp = best_time(lambda: _solve_ivp_run(p19, bank, x0, "case-2", 10.0), repeat=1)
    rows.append(Row("exact simulation, paper19 (N = 19, 30 s, step 0.01)", "one run: plant, central observer, 3 UIOs", "solve_ivp DOP853 rtol 1e-10", t_ivp, "exact dense propagator", t_dense))
    rows.append(
        Row(
            "exact simulation, paper19 (N = 19, 30 s, step 0.01)",
            "three Section IV cases (Algorithm 1, envelope thresholds, attack-only runs; no figures)",
            "-",
            None,
            "run_case x 3",
            t_cases,
            "what `glocal-verify simulate --example paper19 --cases` spends outside matplotlib",
        )
    )

    # dense vs modal on a mid-sized network
    mid = System(random_clustered_spec(150, 3, seed=3, horizon=10.0, step=0.05))
    mb = ObserverBank.for_system(mid, local=False)
    xm = random_initial_state(mid)
    atk_m = zda_attack(mid)
    sm = Schedule.from_spec(mid)
    td = best_time(lambda: simulate(mid, schedule=sm, attack=atk_m, observers=mb, x0=xm, method="dense"), repeat=1, budget=300.0)
    tm = best_time(lambda: simulate(mid, schedule=sm, attack=atk_m, observers=mb, x0=xm, method="modal"), repeat=2)
    rows.append(Row("exact simulation, propagators", "N = 150, 10 s, step 0.05, central observer, ZDA", "dense expm of the augmented matrix", td, "modal + Taylor-input observer blocks", tm))

    # the large network
    n = 250 if quick else 1000
    spec = with_boundary_observers(random_clustered_spec(n, 3, seed=7))
    big = System(spec)
    t0 = time.perf_counter()
    central = central_observer_model(big)
    t_central = time.perf_counter() - t0
    t0 = time.perf_counter()
    loc, notes = local_observer_models(big, modes=[spec.switching.mode] if spec.switching and spec.switching.mode else [])
    t_uio = time.perf_counter() - t0
    t0 = time.perf_counter()
    atk = zda_attack(big)
    t_zda = time.perf_counter() - t0
    bank_big = ObserverBank(tuple([central] + loc), tuple(notes))
    sched = Schedule.from_spec(big)
    xb = random_initial_state(big)
    box: dict[str, Any] = {}
    orders = "+".join(str(o.order) for o in bank_big)
    for step in (spec.simulation.step,):

        def job(step: float = step) -> None:
            box["res"] = simulate(big, schedule=sched, attack=atk, observers=bank_big, x0=xb, method="modal", step=step)

        t_sim = best_time(job, repeat=1, budget=1200.0)
        res = box["res"]
        rows.append(
            Row(
                "exact simulation, large network",
                f"N = {n}, 3 clusters, {spec.simulation.horizon:g} s, step {step:g} ({len(res.t)} samples), ZDA lambda0 = {complex(atk.lambda0).real:g}, switch at {sched.switch_times[0]:g} s",
                "-",
                None,
                f"modal propagator, {len(bank_big)} observers (orders {orders})",
                t_sim,
                f"simulator only (no threshold pass); J = {res.taylor_order}, {res.internal_steps} internal steps per output step; designs (not timed): "
                f"central {t_central:.1f} s, {len(loc)} UIOs {t_uio:.1f} s, ZDA {t_zda:.1f} s",
            )
        )
    return rows
