"""Residual thresholds: the attack-free worst-case envelope, and the first crossing of a residual.

The paper leaves thresholds to future work; the default rule bounds every attack-free
residual over a box of initial states exactly (see :class:`ThresholdRule`).

**The envelope.** Attack-free, the residual of an observer is linear in the initial plant
state: :math:`r(t) = \\Psi(t)\\,\\bar x_0` with :math:`\\Psi(t) = R\\,\\Phi(t, 0)\\,E_0`, where
:math:`\\Phi` is the transition matrix of plant + observer under the schedule,
:math:`R = [R_y C, -R_z]` the residual map and :math:`E_0 = [I; Z_0]` the initial state map.
Over the box :math:`\\|\\bar x_0\\|_\\infty \\le b` the supremum of :math:`|r_k(t)|` is
:math:`b \\sum_j |\\Psi_{kj}(t)|` (attained at a vertex, the sign pattern of row k).

:func:`attack_free_thresholds` computes :math:`\\Psi(t)` row-wise (the adjoint recursion):
inside a segment of constant mode q starting at :math:`\\tau`,
:math:`\\Psi(\\tau + s) = Q(s)\\,P_\\tau` with :math:`Q(s) = R\\,e^{M_q s}` (q rows, advanced
one output step at a time by right multiplication, :math:`Q(s + h) = Q(s)\\,e^{M_q h}`: the
exponentials of one constant matrix commute) and :math:`P_\\tau = \\Phi(\\tau, 0) E_0` (the
2N unit initial states at the segment start, obtained at a switch by binary powers of the step
propagator: :math:`O(\\log(\\tau/h))` dense products instead of one per step). The plant is
kept in the eigenbasis of :math:`L_q` (2 x 2 modal blocks) and the observer input over a step
is its Taylor polynomial with the a priori remainder bound of the modal simulator
(:mod:`glocal_verify.simulation.engine`: same J, same internal steps), so every step
propagator is the one the simulator applies, to rounding. Cost per output step and observer:
:math:`O(q (N + n_o) (2N + n_o))` instead of :math:`O((2N + n_o)^2 \\cdot 2N)` for
propagating the 2N unit states (:func:`envelope_by_columns`, the former computation, kept as
the reference the tests compare with).
"""

from __future__ import annotations

import math
import sys
import time
from dataclasses import dataclass
from typing import Any, Callable, Mapping

import numpy as np
import scipy.linalg

from glocal_verify.errors import ModelError
from glocal_verify.model import System
from glocal_verify.numerics.threads import blas_threads
from glocal_verify.results import jsonable
from glocal_verify.simulation.engine import (
    RHO_MAX,
    observer_step_operator,
    simulate,
    taylor_order,
)
from glocal_verify.simulation.observer_models import ObserverBank, ObserverModel
from glocal_verify.simulation.schedule import Schedule, SimulationResult
from glocal_verify.spec.types import NORMAL_MODE

__all__ = [
    "ThresholdRule",
    "Thresholds",
    "Crossing",
    "attack_free_thresholds",
    "envelope_by_columns",
    "first_crossing",
]

# --------------------------------------------------------------------------------------------
# thresholds


@dataclass(frozen=True, slots=True)
class ThresholdRule:
    """How residual thresholds are set (module docstring).

    Attributes
    ----------
    kind : str
        ``"envelope"`` (exact worst case over the box of attack-free initial states) or
        ``"calibrated"`` (``factor`` x the maximum over ``runs`` random attack-free runs).
    box : float
        Half-width b of the admissible attack-free initial states, ``|x0_bar|_inf <= b``.
    rounding : float
        Rounding allowance relative to ``max(box, ||s(t)||_2)``.
    runs, factor, seed : int, float, int
        Parameters of the calibrated rule.
    """

    kind: str = "envelope"
    box: float = 1.0
    rounding: float = 1e-9
    runs: int = 16
    factor: float = 2.0
    seed: int = 12345

    def describe(self) -> str:
        """One sentence stating the rule."""
        if self.kind == "envelope":
            return (
                f"exact attack-free envelope: sup of |r_k(t)| over all initial states with |x0|_inf <= {self.box:g} "
                f"(observers from x_hat(0) = 0, the defender's switching schedule included), plus a rounding "
                f"allowance of {self.rounding:g} x max({self.box:g}, ||state||_2)"
            )
        return (
            f"calibrated: {self.factor:g} x the largest |r_k(t)| over {self.runs} random attack-free runs "
            f"(|x0|_inf <= {self.box:g}), plus a rounding allowance of {self.rounding:g} x max({self.box:g}, ||state||_2)"
        )


@dataclass(frozen=True, slots=True)
class Thresholds:
    """Attack-free envelopes per observer and the rule that made them.

    Attributes
    ----------
    rule : ThresholdRule
    t : ndarray
        Sample times.
    envelope : mapping of str to ndarray
        Per observer, (K + 1, q) attack-free bound of each residual component.
    schedule : Schedule
        The schedule the envelope was computed for.
    """

    rule: ThresholdRule
    t: np.ndarray
    envelope: Mapping[str, np.ndarray]
    schedule: Schedule

    def bound(self, name: str, state_scale: np.ndarray) -> np.ndarray:
        """Threshold of observer ``name`` for a run whose state norm is ``state_scale`` (K + 1,)."""
        env = self.envelope[name]
        k = min(len(env), len(state_scale))
        allow = self.rule.rounding * np.maximum(self.rule.box, state_scale[:k])
        return env[:k] + allow[:, None]


def attack_free_thresholds(
    system: System,
    observers: ObserverBank,
    schedule: Schedule,
    rule: ThresholdRule = ThresholdRule(),
    *,
    horizon: float | None = None,
    step: float | None = None,
    method: str = "auto",
    progress: bool = False,
) -> Thresholds:
    """Attack-free residual envelopes for ``schedule`` (module docstring).

    Parameters
    ----------
    system : System
    observers : ObserverBank
    schedule : Schedule
        The defender's schedule (switches included in the envelope).
    rule : ThresholdRule
    horizon, step : float, optional
        Default: the spec's simulation settings.
    method : str
        Simulation method of the calibrated rule's runs
        (:func:`~glocal_verify.simulation.engine.simulate`). The envelope is always computed
        by the row recursion of the module docstring (exact to rounding, like both simulators).
    progress : bool
        Report progress on stderr: a tqdm bar with ETA when stderr is a terminal, else one
        line per phase (observer, segment, propagation to a switch).
    """
    from glocal_verify.simulation.engine import check_stiffness

    check_stiffness(
        system,
        float(system.spec.simulation.horizon if horizon is None else horizon),
        float(system.spec.simulation.step if step is None else step),
    )
    if rule.kind == "envelope":
        t, env = _envelope_by_rows(system, observers, schedule, rule.box, horizon, step, _reporter(progress))
        return Thresholds(rule, t, env, schedule)
    if rule.kind == "calibrated":
        n2 = 2 * system.n
        rng = np.random.default_rng(rule.seed)
        X = rng.uniform(-rule.box, rule.box, size=(n2, rule.runs))
        res = simulate(system, schedule=schedule, observers=observers, x0=X, horizon=horizon, step=step, method=method, batch_reduce="max-abs", progress=progress and sys.stderr.isatty())
        env = {k: rule.factor * v for k, v in res.residuals.items()}
        return Thresholds(rule, res.t, env, schedule)
    raise ModelError(f"unknown threshold rule {rule.kind!r} (expected envelope or calibrated)")


def envelope_by_columns(
    system: System,
    observers: ObserverBank,
    schedule: Schedule,
    box: float = 1.0,
    *,
    horizon: float | None = None,
    step: float | None = None,
    method: str = "auto",
) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    """The envelope by simulating the 2N unit initial states :math:`b e_j` (reference).

    :math:`b \\sum_j |r(t; e_j)|` per residual component, from one batch simulation
    (:func:`~glocal_verify.simulation.engine.simulate` with ``batch_reduce="abs-sum"``):
    :math:`O(K (2N + n_o)^2 \\cdot 2N)` work, the computation :func:`attack_free_thresholds`
    used before the row recursion. Kept for tests and for small systems.

    Parameters
    ----------
    system, observers, schedule : System, ObserverBank, Schedule
    box : float
        Half-width b of the box of initial states.
    horizon, step, method
        As for :func:`~glocal_verify.simulation.engine.simulate`.

    Returns
    -------
    (t, envelope)
        Sample times and, per observer, the (K + 1, q) envelope.
    """
    X = box * np.eye(2 * system.n)
    res = simulate(system, schedule=schedule, observers=observers, x0=X, horizon=horizon, step=step, method=method, batch_reduce="abs-sum")
    return res.t, {k: v.copy() for k, v in res.residuals.items()}


# --------------------------------------------------------------------------------------------
# the row recursion


@dataclass(frozen=True, slots=True)
class _Step:
    """One exact step of plant + observer in (modal plant, observer) coordinates.

    :math:`\\xi_l \\leftarrow E_l \\xi_l` per modal block l (:math:`\\xi_l = (p_l, v_l)`),
    :math:`z \\leftarrow \\Phi z + X_p p + X_v v`.
    """

    E: np.ndarray  # (N, 2, 2)
    Xp: np.ndarray  # (n_o, N)
    Xv: np.ndarray  # (n_o, N)
    Phi: np.ndarray  # (n_o, n_o)


def _compose(b: _Step, a: _Step) -> _Step:
    """b after a."""
    Ea = a.E
    return _Step(
        np.matmul(b.E, Ea),
        b.Xp * Ea[:, 0, 0] + b.Xv * Ea[:, 1, 0] + b.Phi @ a.Xp,
        b.Xp * Ea[:, 0, 1] + b.Xv * Ea[:, 1, 1] + b.Phi @ a.Xv,
        b.Phi @ a.Phi,
    )


def _apply_rows(op: _Step, Qa: np.ndarray, Qb: np.ndarray, Qz: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Rows times the step: the adjoint recursion Q <- Q L."""
    E = op.E
    return (
        Qa * E[:, 0, 0] + Qb * E[:, 1, 0] + Qz @ op.Xp,
        Qa * E[:, 0, 1] + Qb * E[:, 1, 1] + Qz @ op.Xv,
        Qz @ op.Phi,
    )


def _apply_cols(op: _Step, Pp: np.ndarray, Pv: np.ndarray, Pz: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The step times columns: P <- L P."""
    E = op.E
    return (
        E[:, 0, 0, None] * Pp + E[:, 0, 1, None] * Pv,
        E[:, 1, 0, None] * Pp + E[:, 1, 1, None] * Pv,
        op.Phi @ Pz + op.Xp @ Pp + op.Xv @ Pv,
    )


class _Steps:
    """Step propagators of one observer, cached per (mode, step); J and internal steps as in the
    modal simulator (:class:`~glocal_verify.simulation.engine._ModalEngine`)."""

    def __init__(self, system: System, o: ObserverModel, h: float, modes: tuple[str, ...]) -> None:
        self.system, self.o, self.n = system, o, system.n
        nu = 0.0
        for q in set(modes) | {NORMAL_MODE}:
            mu = system.eigh(q)[0]
            nu = max(nu, float(np.max(np.sqrt(1.0 + (system.alpha * mu) ** 2 + system.gamma**2))))
        self.n_sub = max(1, int(math.ceil(nu * h / RHO_MAX - 1e-12)))
        self.J = taylor_order(nu * h / self.n_sub)
        self.cache: dict[tuple[str, float], _Step] = {}
        self.obs: dict[tuple[str, float], tuple[np.ndarray, np.ndarray]] = {}

    def output_rows(self, mode: str) -> tuple[np.ndarray, np.ndarray]:
        """The observer's measurement in the modal basis of ``mode``: (C_p U, C_v U)."""
        U = self.system.eigh(mode)[1]
        n = self.n
        return self.o.C[:, :n] @ U, self.o.C[:, n:] @ U

    def _observer(self, dk: str, delta: float) -> tuple[np.ndarray, np.ndarray]:
        key = (dk, round(delta, 13))
        got = self.obs.get(key)
        if got is None:
            got = observer_step_operator(self.o.F[dk], self.o.G[dk], self.J, delta)
            self.obs[key] = got
        return got

    def sub(self, mode: str, delta: float) -> _Step:
        """One internal step of length ``delta`` in ``mode`` (exponentials, Taylor input model)."""
        key = (mode, round(delta, 13))
        op = self.cache.get(key)
        if op is None:
            sy = self.system
            mu = sy.eigh(mode)[0]
            n = self.n
            A = np.zeros((n, 2, 2))
            A[:, 0, 1] = 1.0
            A[:, 1, 0] = -sy.alpha * mu
            A[:, 1, 1] = -sy.gamma
            E = scipy.linalg.expm(A * delta)
            Phi, W = self._observer(self.o.dynamics_key(mode), delta)
            # D = [C_mod; C_mod A_xi; ...; C_mod A_xi^J] (the Taylor coefficients of y), row-wise
            cp, cv = self.output_rows(mode)
            p = cp.shape[0]
            Xp = np.zeros((self.o.order, n))
            Xv = np.zeros((self.o.order, n))
            for j in range(self.J + 1):
                Wj = W[:, j * p : (j + 1) * p]
                Xp += Wj @ cp
                Xv += Wj @ cv
                cp, cv = -sy.alpha * mu * cv, cp - sy.gamma * cv
            op = _Step(E, Xp, Xv, Phi)
            self.cache[key] = op
        return op

    def step(self, mode: str, delta: float) -> list[_Step]:
        """The internal steps of one step of length ``delta`` (as the simulator splits it)."""
        return [self.sub(mode, delta / self.n_sub)] * self.n_sub


def _power_cols(ops: list[_Step], m: int, P: tuple[np.ndarray, np.ndarray, np.ndarray]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(product of ``ops``)^m applied to the columns P, by binary powers."""
    if m <= 0:
        return P
    base = ops[0]
    for op in ops[1:]:
        base = _compose(op, base)
    while True:
        if m & 1:
            P = _apply_cols(base, *P)
        m >>= 1
        if not m:
            return P
        base = _compose(base, base)


Reporter = Callable[[str, int], None]


def _reporter(progress: bool) -> Reporter:
    """``report(phase, samples_done)``: nothing, phase lines (not a terminal) or a tqdm bar."""
    if not progress:
        return lambda phase, n: None
    if sys.stderr.isatty():
        from tqdm import tqdm

        bar: Any = None

        def report(phase: str, n: int) -> None:
            nonlocal bar
            if phase.startswith("total:"):
                bar = tqdm(total=int(phase[6:]), file=sys.stderr, desc="thresholds", unit="sample", leave=False)
                return
            if bar is None:
                return
            if phase == "done":
                bar.close()
                return
            if phase:
                bar.set_description(f"thresholds: {phase}")
            bar.update(n)

        return report
    t0 = time.perf_counter()

    def line(phase: str, n: int) -> None:
        if phase and not phase.startswith("total:"):
            print(f"glocal-verify: thresholds: {phase} ({time.perf_counter() - t0:.1f} s)", file=sys.stderr, flush=True)

    return line


def _envelope_by_rows(
    system: System,
    bank: ObserverBank,
    schedule: Schedule,
    box: float,
    horizon: float | None,
    step: float | None,
    report: Reporter,
) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    """The envelope by the row recursion (module docstring): (t, {observer: (K + 1, q)})."""
    for _, m in schedule.segments:
        system.check_mode(m)
    T = float(system.spec.simulation.horizon if horizon is None else horizon)
    h = float(system.spec.simulation.step if step is None else step)
    if not (h > 0 and T > 0 and math.isfinite(T) and math.isfinite(h)):
        raise ModelError(f"horizon {T} and step {h} must be positive and finite")
    K = int(math.floor(T / h + 1e-9))
    end = K * h
    tol = 1e-9 * h
    t_grid = np.arange(K + 1) * h
    events = sorted(t for t in schedule.switch_times if 0.0 < t < end)
    starts, stops = [0.0] + events, events + [end]
    modes = [schedule.mode_at(a + 1e-12 * max(1.0, a)) for a in starts]
    n = system.n
    # samples of each segment: t_k in [start, stop), the last segment up to the end
    seg_k: list[list[int]] = []
    for j, (a, b) in enumerate(zip(starts, stops)):
        last = j == len(starts) - 1
        seg_k.append([k for k in range(K + 1) if t_grid[k] >= a - tol and (t_grid[k] < b - tol or (last and t_grid[k] <= end + tol))])
    report(f"total:{(K + 1) * len(bank)}", 0)
    out: dict[str, np.ndarray] = {}
    chunk = 128
    for i_obs, o in enumerate(bank):
        q = len(o.channels)
        env = np.zeros((K + 1, q))
        out[o.name] = env
        if q == 0:
            report(f"{o.name}: no residual", K + 1)
            continue
        steps = _Steps(system, o, h, tuple(modes))
        U0 = system.eigh(modes[0])[1]
        # the unit initial states at the segment start (None: the first segment, P = [U^T, 0; 0, U^T; Z0])
        P: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None
        z0_zero = not np.any(o.Z0)
        for j, (a, b) in enumerate(zip(starts, stops)):
            mode, ks = modes[j], seg_k[j]
            report(f"{o.name} ({i_obs + 1}/{len(bank)}), segment {j + 1}/{len(starts)} ({mode})", 0)
            cp, cv = steps.output_rows(mode)
            with blas_threads(1):
                Qa, Qb, Qz = o.Ry @ cp, o.Ry @ cv, -np.array(o.Rz, dtype=float)
                d0 = (t_grid[ks[0]] - a) if ks else 0.0
                if ks and d0 > tol:
                    for op in steps.step(mode, d0):
                        Qa, Qb, Qz = _apply_rows(op, Qa, Qb, Qz)
                buf: list[tuple[np.ndarray, np.ndarray, np.ndarray]] = []
                kbuf: list[int] = []
                hstep = steps.step(mode, h)
                for i, k in enumerate(ks):
                    if i:
                        for op in hstep:
                            Qa, Qb, Qz = _apply_rows(op, Qa, Qb, Qz)
                    buf.append((Qa, Qb, Qz))
                    kbuf.append(k)
                    if len(buf) == chunk or i == len(ks) - 1:
                        A_ = np.vstack([x[0] for x in buf])
                        B_ = np.vstack([x[1] for x in buf])
                        Z_ = np.vstack([x[2] for x in buf])
                        if P is None:
                            psi = np.hstack([A_ @ U0.T, B_ @ U0.T])
                            if not z0_zero:
                                psi += Z_ @ o.Z0
                        else:
                            psi = A_ @ P[0] + B_ @ P[1] + Z_ @ P[2]
                        env[kbuf] = box * np.abs(psi).sum(axis=1).reshape(len(kbuf), q)
                        report("", len(kbuf))
                        buf, kbuf = [], []
            if j == len(starts) - 1:
                break
            # the unit initial states at the next switch: binary powers of the step propagator
            report(f"{o.name}: the 2N unit states to the switch at t = {b:g} s", 0)
            with blas_threads(None):
                if P is None:
                    Pp = np.hstack([U0.T, np.zeros((n, n))])
                    Pv = np.hstack([np.zeros((n, n)), U0.T])
                    P = (Pp, Pv, np.array(o.Z0, dtype=float))
                if not ks:
                    if b - a > tol:
                        for op in steps.step(mode, b - a):
                            P = _apply_cols(op, *P)
                else:
                    if d0 > tol:
                        for op in steps.step(mode, d0):
                            P = _apply_cols(op, *P)
                    P = _power_cols(hstep, len(ks) - 1, P)
                    rest = b - t_grid[ks[-1]]
                    if rest > tol:
                        for op in steps.step(mode, h if abs(rest - h) <= tol else rest):
                            P = _apply_cols(op, *P)
                nxt = modes[j + 1]
                if nxt != mode:
                    Tb = system.eigh(nxt)[1].T @ system.eigh(mode)[1]
                    P = (Tb @ P[0], Tb @ P[1], P[2])
    report("done", 0)
    return t_grid, out


# --------------------------------------------------------------------------------------------
# crossings


@dataclass(frozen=True, slots=True)
class Crossing:
    """First threshold crossing of one observer in a time window (or none).

    Attributes
    ----------
    observer : str
    time : float or None
        First sample time with |r_k| > threshold_k for some k (None: no crossing).
    channel : str or None
        The component that crossed first.
    peak_ratio : float
        max over the window and components of |r_k| / threshold_k.
    peak_time : float or None
        Where that maximum is reached.
    window : (float, float)
    """

    observer: str
    time: float | None
    channel: str | None
    peak_ratio: float
    peak_time: float | None
    window: tuple[float, float]

    @property
    def detected(self) -> bool:
        """True when the residual crossed its threshold in the window."""
        return self.time is not None

    def to_json(self) -> dict[str, Any]:
        """JSON-ready dict."""
        return jsonable(
            {
                "observer": self.observer,
                "detected": self.detected,
                "time": self.time,
                "channel": self.channel,
                "peak_ratio": self.peak_ratio,
                "peak_time": self.peak_time,
                "window": list(self.window),
            }
        )


def first_crossing(
    result: SimulationResult,
    thresholds: Thresholds,
    observer: str,
    start: float = 0.0,
    stop: float = math.inf,
) -> Crossing:
    """First sample in ``[start, stop)`` at which a residual component of ``observer`` exceeds
    its threshold.

    Parameters
    ----------
    result : SimulationResult
    thresholds : Thresholds
    observer : str
    start, stop : float
        Time window (half-open).
    """
    r = np.abs(result.residuals[observer])
    thr = thresholds.bound(observer, result.state_scale)
    k = min(len(r), len(thr))
    r, thr, t = r[:k], thr[:k], result.t[:k]
    mask = (t >= start - 1e-12) & (t < stop - 1e-12)
    win = (float(start), float(min(stop, t[-1] if len(t) else stop)))
    if not np.any(mask) or r.shape[1] == 0:
        return Crossing(observer, None, None, 0.0, None, win)
    ratio = np.where(thr > 0, r / np.where(thr > 0, thr, 1.0), np.where(r > 0, np.inf, 0.0))
    rw = ratio[mask]
    tw = t[mask]
    flat = int(np.argmax(rw))
    i_peak, _ = np.unravel_index(flat, rw.shape)
    over = np.any(rw > 1.0, axis=1)
    ch = result.channels[observer]
    if not np.any(over):
        return Crossing(observer, None, None, float(rw.max()), float(tw[i_peak]), win)
    i = int(np.argmax(over))
    j = int(np.argmax(rw[i]))
    return Crossing(observer, float(tw[i]), ch[j], float(rw.max()), float(tw[i_peak]), win)
