"""The exact simulator (glocal_verify/simulate.py) against an independent fine-step integrator,
its two propagators against each other, and the stealth of ZDA and covert attacks."""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from glocal_verify import System, load_example, spec_from_dict
from glocal_verify.errors import ModelError
from glocal_verify.simulation.attacks import (
    AttackModel,
    Exosystem,
    covert_attack,
    zda_attack,
    zda_attack_from_direction,
)
from glocal_verify.simulation.engine import UNIT_ROUNDOFF, simulate, taylor_order
from glocal_verify.simulation.observer_models import ObserverBank, ObserverModel
from glocal_verify.simulation.schedule import (
    Schedule,
    SimulationResult,
    random_initial_state,
)

# --------------------------------------------------------------------------------------------
# fixtures


def _small(attack: dict[str, Any] | None = None, switching: dict[str, Any] | None = None) -> System:
    """Five agents, two clusters with one UIO each, two velocity monitors, two safe modes."""
    data: dict[str, Any] = {
        "format": 1,
        "name": "small5",
        "dynamics": {"alpha": 1, "gamma": "3/2"},
        "graph": {"nodes": 5, "edges": [[1, 2, 2], [2, 3, 1], [1, 3, 1], [3, 4, 1], [4, 5, 3]]},
        "modes": [{"name": "m1", "add": [[2, 4, 1]]}, {"name": "m2", "remove": [[1, 3]], "add": [[1, 5, 2]]}],
        "clusters": [
            {"name": "P1", "nodes": [1, 2, 3], "observers": [{"center": 2}]},
            {"name": "P2", "nodes": [4, 5], "observers": [{"center": 4}]},
        ],
        "monitor": {"velocities": [3, 5]},
        "simulation": {"horizon": 3.0, "step": 0.05, "seed": 4},
    }
    if attack:
        data["attack"] = attack
    if switching:
        data["switching"] = switching
    return System(spec_from_dict(data))


@pytest.fixture(scope="module")
def paper19() -> System:
    return System(load_example("paper19"))


@pytest.fixture(scope="module")
def paper19_bank(paper19: System) -> ObserverBank:
    return ObserverBank.for_system(paper19)


def _hand_zda(system: System, lam: complex, xi: np.ndarray, F: tuple[int, ...], amplitude: float = 1.0, start: float = 0.0) -> AttackModel:
    """A ZDA from a hand-made direction: u0 = ((lam^2 + gamma lam) I + alpha L) xi restricted to F."""
    s = lam * lam + system.gamma * lam
    r = (s * np.eye(system.n) + system.alpha * system.laplacian()) @ xi.astype(complex)
    idx = system.idx(F)
    assert np.allclose(np.delete(r, idx), 0.0), "xi is not a zero direction through F"
    return zda_attack_from_direction(system, lam, xi, r[idx], amplitude=amplitude, start=start, actuators=F)


# --------------------------------------------------------------------------------------------
# an independent reference: the physical equations integrated by solve_ivp


def _reference(
    system: System,
    schedule: Schedule,
    attack: AttackModel | None,
    bank: ObserverBank,
    x0: np.ndarray,
    horizon: float,
    step: float,
    signal: Any,
) -> dict[str, np.ndarray]:
    """Integrate plant, attacker copy and observers with DOP853 (rtol 1e-12) between events.

    ``signal(tau)`` is the attack input written out by hand (not the exosystem)."""
    n2 = 2 * system.n
    obs = list(bank)
    copy = attack is not None and attack.has_copy
    B = system.B(attack.actuators) if attack else np.zeros((n2, 0))
    ta = attack.start if attack else math.inf
    spoof = {}
    for o in obs:
        P = np.diag([1.0 if (copy and o.kind == "central" and ch in attack.spoofed) else 0.0 for ch in o.inputs])  # type: ignore[union-attr]
        spoof[o.name] = P
    sizes = [n2, n2] + [o.order for o in obs]
    offs = np.cumsum([0] + sizes)

    def rhs(t: float, s: np.ndarray, mode: str) -> np.ndarray:
        xt, x = s[offs[0] : offs[1]], s[offs[1] : offs[2]]
        u = signal(t - ta) if (attack is not None and t >= ta) else np.zeros(B.shape[1])
        out = [system.A("normal") @ xt + B @ u if copy else np.zeros(n2), system.A(mode) @ x + B @ u]
        for k, o in enumerate(obs):
            z = s[offs[k + 2] : offs[k + 3]]
            F, G = o.dynamics(mode)
            y = o.C @ x - spoof[o.name] @ o.C @ xt
            out.append(F @ z + G @ y)
        return np.concatenate(out)

    K = int(round(horizon / step))
    grid = np.arange(K + 1) * step
    xstart = x0.copy()
    if attack is not None and attack.offset is not None and ta == 0.0:
        xstart = xstart + attack.offset
    s = np.concatenate([np.zeros(n2), xstart] + [o.Z0 @ xstart for o in obs])
    events = sorted({t for t in schedule.switch_times} | ({ta} if attack is not None and 0 < ta < horizon else set()))
    bounds = [0.0] + [e for e in events if e < horizon] + [grid[-1]]
    states = np.full((K + 1, len(s)), np.nan)
    states[0] = s
    prev = schedule.mode_at(0.0)
    for a, b in zip(bounds, bounds[1:]):
        if attack is not None and attack.offset is not None and a == ta and ta > 0:
            s = s.copy()
            s[offs[1] : offs[2]] += attack.offset
        mode = schedule.mode_at(a + 1e-12)
        if mode != prev:  # a UIO whose decoupling matrix changes: z <- z + (h_p - h_q) y
            s = s.copy()
            for k, o in enumerate(obs):
                if o.Hy:
                    H = {m: o.Hy[o.dynamics_key(m)] for m in (prev, mode)}
                    y = o.C @ s[offs[1] : offs[2]] - spoof[o.name] @ o.C @ s[offs[0] : offs[1]]
                    s[offs[k + 2] : offs[k + 3]] += (H[prev] - H[mode]) @ y
            prev = mode
        inside = grid[(grid > a + 1e-12) & (grid < b - 1e-12)]
        scale = max(1.0, float(np.abs(s).max()))
        sol = solve_ivp(rhs, (a, b), s, method="DOP853", rtol=1e-12, atol=1e-13 * scale, t_eval=np.append(inside, b), args=(mode,))
        assert sol.success
        for t, col in zip(sol.t, sol.y.T):
            k = int(round(t / step))
            if abs(k * step - t) < 1e-9:
                states[k] = col
        s = sol.y[:, -1]
    out: dict[str, np.ndarray] = {"x": states[:, offs[1] : offs[2]]}
    modes = [schedule.mode_at(t - 1e-12) for t in grid]  # a sample at a switch holds the state before it
    for k, o in enumerate(obs):
        xt, x, z = states[:, offs[0] : offs[1]], states[:, offs[1] : offs[2]], states[:, offs[k + 2] : offs[k + 3]]
        y = x @ o.C.T - xt @ (spoof[o.name] @ o.C).T
        # r = y - C_loc x_hat, x_hat = z + h_q y (the mode's decoupling matrix)
        Ry = np.stack([np.eye(len(o.channels)) - o.Rz @ o.Hy[o.dynamics_key(m)] if o.Hy else o.Ry for m in modes])
        out[o.name] = np.einsum("kij,kj->ki", Ry, y) - z @ o.Rz.T
    return out


def _compare(res: SimulationResult, ref: dict[str, np.ndarray]) -> float:
    """Largest difference, relative to the largest state norm of the run."""
    scale = max(1.0, float(np.max(res.state_scale)))
    assert res.x is not None
    worst = float(np.max(np.abs(res.x - ref["x"]))) / scale
    for name, r in res.residuals.items():
        worst = max(worst, float(np.max(np.abs(r - ref[name]))) / scale)
    return worst


# --------------------------------------------------------------------------------------------
# exactness


@pytest.mark.parametrize("method", ["dense", "modal"])
def test_the_simulator_matches_a_fine_step_reference_with_a_complex_zda_and_an_off_grid_switch(method: str) -> None:
    system = _small()
    bank = ObserverBank.for_system(system)
    assert len(bank) == 3, bank.notes
    # agents 1 and 2 are attacked; a complex lambda0 makes a 2-dim exosystem
    # agents 1 and 2 share their only other neighbour 3 with equal weights: xi = e1 - e2 keeps
    # (s I + alpha L) xi on {1, 2} for every s; a complex lambda0 makes a 2-dim exosystem
    lam = 0.3 + 1.1j
    atk = _hand_zda(system, lam, np.array([1.0, -1.0, 0, 0, 0]), (1, 2))
    atk = zda_attack_from_direction(system, lam, atk.xi, atk.u0, actuators=(1, 2), start=0.37)  # type: ignore[arg-type]
    sched = Schedule(((0.0, "normal"), (1.234, "m2")))
    x0 = random_initial_state(system, seed=1)
    res = simulate(system, schedule=sched, attack=atk, observers=bank, x0=x0, method=method)

    def sig(tau: float) -> np.ndarray:
        return np.real(atk.u0 * np.exp(lam * tau))  # type: ignore[operator]

    ref = _reference(system, sched, atk, bank, x0, 3.0, 0.05, sig)
    assert _compare(res, ref) < 1e-9


@pytest.mark.parametrize("method", ["dense", "modal"])
def test_the_simulator_matches_a_fine_step_reference_with_a_covert_sine_attack(method: str) -> None:
    system = _small(attack={"kind": "covert", "actuators": [1], "sensors": [3, 5], "signal": "sine", "amplitude": 0.7, "frequency": 0.4, "start": 0.5})
    bank = ObserverBank.for_system(system)
    atk = covert_attack(system, signal="sine", amplitude=0.7, frequency=0.4, start=0.5)
    assert atk.spoofed == ("v:3", "v:5")
    sched = Schedule.single("m1", 2.0)
    x0 = random_initial_state(system, seed=2)
    res = simulate(system, schedule=sched, attack=atk, observers=bank, x0=x0, method=method)

    def sig(tau: float) -> np.ndarray:
        return 0.7 * np.sin(2 * np.pi * 0.4 * tau) * np.ones(1)

    ref = _reference(system, sched, atk, bank, x0, 3.0, 0.05, sig)
    assert _compare(res, ref) < 1e-9


def test_dense_and_modal_propagators_agree_to_rounding_on_paper19(paper19: System, paper19_bank: ObserverBank) -> None:
    atk = zda_attack(paper19, lambda0=0.5)
    sched = Schedule.single("case-2", 10.0)
    x0 = random_initial_state(paper19)
    d = simulate(paper19, schedule=sched, attack=atk, observers=paper19_bank, x0=x0, method="dense", horizon=15.0)
    m = simulate(paper19, schedule=sched, attack=atk, observers=paper19_bank, x0=x0, method="modal", horizon=15.0)
    scale = float(np.max(d.state_scale))
    assert d.x is not None and m.x is not None
    assert np.max(np.abs(d.x - m.x)) / scale < 1e-12
    for name in d.residuals:
        assert np.max(np.abs(d.residuals[name] - m.residuals[name])) / scale < 1e-12
    assert m.taylor_order is not None and m.taylor_order >= 1


def test_the_output_step_only_chooses_the_samples_not_the_accuracy(paper19: System, paper19_bank: ObserverBank) -> None:
    atk = zda_attack(paper19, lambda0=0.5)
    sched = Schedule.single("case-2", 3.3)  # not on the coarse grid
    x0 = random_initial_state(paper19)
    coarse = simulate(paper19, schedule=sched, attack=atk, observers=paper19_bank, x0=x0, horizon=6.0, step=0.25)
    fine = simulate(paper19, schedule=sched, attack=atk, observers=paper19_bank, x0=x0, horizon=6.0, step=0.01)
    scale = float(np.max(fine.state_scale))
    idx = np.rint(coarse.t / 0.01).astype(int)
    for name in coarse.residuals:
        assert np.max(np.abs(coarse.residuals[name] - fine.residuals[name][idx])) / scale < 1e-11


# --------------------------------------------------------------------------------------------
# stealth


def _attack_part(system: System, sched: Schedule, atk: AttackModel, bank: ObserverBank, **kw: Any) -> tuple[SimulationResult, SimulationResult]:
    x0 = random_initial_state(system)
    full = simulate(system, schedule=sched, attack=atk, observers=bank, x0=x0, record_states=False, **kw)
    only = simulate(system, schedule=sched, attack=atk, observers=bank, x0=np.zeros(2 * system.n), record_states=False, **kw)
    return full, only


@pytest.mark.parametrize("lam", [0.5, 1.3, -0.4, 0.2 + 0.9j, 0.0 + 1.5j])
def test_a_zda_is_invisible_in_the_global_residual_before_the_switch_on_paper19(paper19: System, lam: complex) -> None:
    atk = zda_attack(paper19, lambda0=lam)
    bank = ObserverBank.for_system(paper19, local=False)
    full, only = _attack_part(paper19, Schedule.single("case-2", 8.0), atk, bank, horizon=12.0)
    pre = full.t < 8.0
    rel = np.max(np.abs(only.residuals["central"]), axis=1) / np.maximum(1.0, full.state_scale)
    assert np.max(rel[pre]) < 1e-9
    assert np.max(rel[~pre]) > 1e-4  # case 2 touches agent 4: the attack shows after the switch


@pytest.mark.parametrize("seed", [5, 6])
def test_a_zda_is_invisible_before_the_switch_on_a_random_clustered_network(seed: int) -> None:
    from glocal_verify.design.generators import random_clustered_spec

    # seed 5: a zero at lambda0 = 0; seed 6: a complex pair (lambda0 = 0.06 - 2.88j)
    system = System(random_clustered_spec(40, 3, seed=seed, horizon=9.0, step=0.05))
    atk = zda_attack(system)
    bank = ObserverBank.for_system(system, local=False)
    sched = Schedule.from_spec(system)
    full, only = _attack_part(system, sched, atk, bank, method="modal")
    pre = full.t < sched.switch_times[0]
    rel = np.max(np.abs(only.residuals["central"]), axis=1) / np.maximum(1.0, full.state_scale)
    assert np.max(rel[pre]) < 1e-9
    assert np.max(np.abs(only.residuals["central"][pre]) / 1.0) < 1e-9 * np.max(full.state_scale[pre])


def test_the_paper19_zda_is_visible_to_the_local_observer_at_node_5(paper19: System, paper19_bank: ObserverBank) -> None:
    atk = zda_attack(paper19, lambda0=0.5)
    full, only = _attack_part(paper19, Schedule(), atk, paper19_bank, horizon=5.0)
    rel = np.max(np.abs(only.residuals["P1@5"]), axis=1) / np.maximum(1.0, full.state_scale)
    assert np.max(rel) > 0.1
    # the observers of the other clusters are decoupled from P1 (UIO) and see nothing
    rel2 = np.max(np.abs(only.residuals["P2@10"]), axis=1) / np.maximum(1.0, full.state_scale)
    assert np.max(rel2) < 1e-9


def test_a_covert_attack_owning_every_reached_channel_is_invisible_until_the_switch() -> None:
    system = _small(attack={"kind": "covert", "actuators": [1], "sensors": [3, 5], "signal": "step", "start": 0.4})
    atk = covert_attack(system, signal="step", amplitude=2.0, start=0.4)
    bank = ObserverBank.for_system(system, local=False)
    full, only = _attack_part(system, Schedule.single("m1", 1.5), atk, bank, method="dense")
    pre = full.t < 1.5
    rel = np.max(np.abs(only.residuals["central"]), axis=1) / np.maximum(1.0, full.state_scale)
    assert np.max(rel[pre]) < 1e-9
    assert np.max(rel[~pre]) > 1e-4  # the attacker keeps the normal-mode model: the switch unmasks it


def test_a_covert_attack_missing_a_reached_channel_is_visible_at_once() -> None:
    system = _small(attack={"kind": "covert", "actuators": [1], "sensors": [3], "start": 0.4})
    atk = covert_attack(system, start=0.4)
    assert atk.spoofed == ("v:3",)
    bank = ObserverBank.for_system(system, local=False)
    full, only = _attack_part(system, Schedule(), atk, bank)
    rel = np.max(np.abs(only.residuals["central"]), axis=1) / np.maximum(1.0, full.state_scale)
    assert np.max(rel) > 1e-4


# --------------------------------------------------------------------------------------------
# building blocks


def test_exosystems_generate_the_documented_signals() -> None:
    tau = np.array([0.0, 0.3, 1.7])
    u0 = np.array([1.0 + 2.0j, -0.5j])
    e = Exosystem.exponential(u0, 0.4 - 1.2j)
    assert np.allclose(e.signal(tau), np.real(np.outer(np.exp((0.4 - 1.2j) * tau), u0)), rtol=1e-13, atol=1e-13)
    assert np.allclose(Exosystem.exponential(np.array([2.0]), -0.3).signal(tau)[:, 0], 2.0 * np.exp(-0.3 * tau))
    assert np.allclose(Exosystem.step(1.5, 2).signal(tau), 1.5)
    assert np.allclose(Exosystem.sine(0.7, 0.25, 1).signal(tau)[:, 0], 0.7 * np.sin(2 * np.pi * 0.25 * tau), atol=1e-14)


def test_the_taylor_order_bounds_the_remainder_below_the_unit_roundoff() -> None:
    for rho in (0.01, 0.3, 1.0):
        J = taylor_order(rho)
        assert rho ** (J + 1) * math.exp(rho) / math.factorial(J + 1) <= UNIT_ROUNDOFF
        assert J == 0 or rho**J * math.exp(rho) / math.factorial(J) > UNIT_ROUNDOFF


def test_schedules_come_from_the_spec_switching_table() -> None:
    s = _small(switching={"mode": "m1", "time": 1.0})
    assert Schedule.from_spec(s).segments == ((0.0, "normal"), (1.0, "m1"))
    assert Schedule.from_spec(s, "m2").segments == ((0.0, "normal"), (1.0, "m2"))
    seq = _small(switching={"sequence": [{"mode": "normal", "duration": 0.5}, {"mode": "m1", "duration": 1.0}, {"mode": "m2", "duration": 2.0}]})
    sch = Schedule.from_spec(seq)
    assert sch.segments == ((0.0, "normal"), (0.5, "m1"), (1.5, "m2"))
    assert sch.mode_at(1.49) == "m1" and sch.mode_at(1.5) == "m2"
    assert Schedule.from_spec(_small()).segments == ((0.0, "normal"),)
    with pytest.raises(ModelError):
        Schedule(((0.0, "normal"), (2.0, "m1"), (1.0, "m2")))


def test_observer_models_from_plain_matrices_run_without_the_design_modules() -> None:
    system = _small()
    C = system.C()
    H = 2.0 * C.T
    o = ObserverModel("mine", "central", C, {"*": system.A() - H @ C}, {"*": H}, np.eye(2), C, np.zeros((10, 10)), ("v:3", "v:5"), ("v:3", "v:5"))
    res = simulate(system, observers=ObserverBank((o,)), horizon=1.0, step=0.1)
    assert res.residuals["mine"].shape == (11, 2)
    assert res.method == "dense"


def test_ctrl_c_propagates_out_of_simulate_and_returns_no_partial_result(monkeypatch: pytest.MonkeyPatch) -> None:
    # requirement changed: an interrupt must stop the whole command (Algorithm 1 must not go on
    # with truncated runs), so simulate lets KeyboardInterrupt through and returns nothing
    from glocal_verify.simulation import engine as sim_mod

    system = _small()
    calls = {"n": 0}
    orig = sim_mod._DenseEngine.advance

    def advance(self: Any, delta: float) -> None:
        calls["n"] += 1
        if calls["n"] == 7:
            raise KeyboardInterrupt
        orig(self, delta)

    monkeypatch.setattr(sim_mod._DenseEngine, "advance", advance)
    got: list[Any] = []
    with pytest.raises(KeyboardInterrupt):
        got.append(simulate(system, observers=ObserverBank.for_system(system), method="dense", progress=True))
    assert got == [] and calls["n"] == 7


def test_a_batch_of_initial_states_needs_a_reduction() -> None:
    system = _small()
    with pytest.raises(ModelError):
        simulate(system, x0=np.eye(10))
    res = simulate(system, x0=np.eye(10), observers=ObserverBank.for_system(system), batch_reduce="abs-sum", horizon=0.5)
    assert res.x is None and all(v.shape[0] == len(res.t) for v in res.residuals.values())
