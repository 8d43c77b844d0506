"""The attack-free envelope by the row (adjoint) recursion, with binary powers of the step.

:func:`envelope_by_rows` computes, for every observer, :math:`\\Psi(t) = R\\,\\Phi(t, 0)\\,E_0`
(module docstring of :mod:`glocal_verify.simulation.thresholds`) and the envelope
:math:`b \\sum_j |\\Psi_{kj}(t)|`. Coordinates: the plant in the eigenbasis of the active
:math:`L_q` (2 x 2 blocks :math:`E_l` per mode l), the observer state z as it is.

**The step.** One output step h of plant + observer is the product of the ``n_sub`` internal
steps of the modal simulator (same J, same internal steps, the same observer operator
:math:`(\\Phi, \\Gamma)` from :func:`~glocal_verify.simulation.step_operators.observer_step_operator`):
:math:`\\xi_l \\leftarrow E_l \\xi_l`, :math:`z \\leftarrow \\Phi z + \\Gamma (D_p p + D_v v)`, where
:math:`D = [C; C A; \\dots; C A^J]` are the Taylor coefficients of the observer input in the
modal basis (row-wise). :math:`X = \\Gamma D` has rank at most :math:`p (J + 1)`, so a row
step costs :math:`O(q\\,n_o (n_o + p J) + q\\,p J\\,N)` instead of :math:`O(q\\,n_o (n_o + 2N))`.
This is the simulator's step to rounding: only the association of the products differs.

**Rows.** Inside a segment of mode q the rows at the samples are
:math:`Q_k = Q_0 L^k`. Their observer part is the Krylov sequence
:math:`Z_k = Z_0 \\Phi^k`; it is computed in blocks of :math:`B = 2^s` samples
(:math:`Z_{k + B} = Z_k \\Phi^B`, the first block by doubling) when the powers
:math:`\\Phi^{2^i}` are needed anyway for the columns or already known (the same observer
dynamics in another segment), else step by step. The plant part follows exactly:
:math:`(Q_a, Q_b)_{k+1} = (Q_a, Q_b)_k E + (Z_k \\Gamma) D` (2 x 2 blocks, O(qN) per step).

**Columns.** The 2N unit initial states at a switch, :math:`P_\\tau = \\Phi(\\tau, 0) E_0`, by
binary powers :math:`L^{2^i}` (each a product of powers of the step propagator). Before the
first change of basis the columns are taken in modal coordinates, so their plant part stays
2 x 2 block-diagonal and a power is applied at the cost of one :math:`\\Phi^{2^i} P_z`; the
basis change to the original coordinates is undone once, at the switch. The powers
:math:`\\Phi^{2^i}` are shared with the rows and across segments and modes with the same
observer dynamics.

**Across one switch without columns.** When the schedule has one switch, on the output grid,
and the observer's step is the same in both modes (the centralized observer keeps the
normal-mode model; a UIO without a mode-matched design), the observer rows after the switch
are those before it, :math:`Z'_j = Z_j`, and the observer part of :math:`\\Psi` after the switch
is :math:`Z_j P_{z,\\tau} = Z_{j+m} P_{z,0} + \\sum_{i<m} (Z_{j+m-1-i} X) E^i` (m steps to the
switch, modal columns): the Krylov sequence continued to the horizon and sums over windows of
m samples (prefix and suffix sums of blocks, no subtraction) replace the powers of the step
applied to the 2N columns (:func:`_across_the_switch`).

Rounding: every quantity is a product of the simulator's step propagators, evaluated in a
different order (powers by squaring, :math:`(Z \\Gamma) D` for :math:`Z (\\Gamma D)`); the
errors are of order the unit roundoff times the products of the norms involved, as for the
column propagation of :func:`~glocal_verify.simulation.thresholds.envelope_by_columns` (the
reference the tests compare with).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable, Iterator

import numpy as np
import scipy.linalg

from glocal_verify.model import System
from glocal_verify.numerics.threads import blas_threads
from glocal_verify.simulation.limits import RHO_MAX, horizon_and_step
from glocal_verify.simulation.observer_models import ObserverBank, ObserverModel
from glocal_verify.simulation.schedule import Schedule
from glocal_verify.simulation.step_operators import StepOperators
from glocal_verify.spec.types import NORMAL_MODE

__all__ = ["Reporter", "envelope_by_rows"]

#: ``report(phase, samples_done)``: progress of :func:`envelope_by_rows`
Reporter = Callable[[str, int], None]

#: samples per chunk of rows (one dense product with the columns per chunk); a power of two
_CHUNK = 64


# --------------------------------------------------------------------------------------------
# steps


@dataclass(frozen=True, slots=True)
class _Step:
    """One exact transition of plant + observer in (modal plant, observer) coordinates.

    :math:`\\xi_l \\leftarrow E_l \\xi_l` per modal block l (:math:`\\xi_l = (p_l, v_l)`),
    :math:`z \\leftarrow \\Phi z + X [p; v]` with :math:`X = \\Gamma D`, or :math:`X = D` when
    ``Gam`` is None (a composed step stored densely); the first N columns of D act on p.
    """

    E: np.ndarray  # (N, 2, 2)
    Gam: np.ndarray | None  # (n_o, r) or None
    D: np.ndarray  # (r, 2N), or (n_o, 2N) when Gam is None
    Phi: np.ndarray  # (n_o, n_o)

    def dense(self) -> np.ndarray:
        """:math:`X = [X_p, X_v]` (n_o, 2N)."""
        return self.D if self.Gam is None else self.Gam @ self.D


def _times_blocks(D: np.ndarray, E: np.ndarray) -> np.ndarray:
    """:math:`D\\,\\mathrm{blockdiag}(E_l)` for D acting on [p; v] (column scalings, O(rN))."""
    n = E.shape[0]
    Dp, Dv = D[:, :n], D[:, n:]
    return np.hstack([Dp * E[:, 0, 0] + Dv * E[:, 1, 0], Dp * E[:, 0, 1] + Dv * E[:, 1, 1]])


def _after(b: _Step, a: _Step, phi: np.ndarray | None = None) -> _Step:
    """The step ``b`` after ``a`` (``phi``: :math:`\\Phi_b \\Phi_a` when already known).

    :math:`X = X_b E_a + \\Phi_b X_a`; kept factored,
    :math:`X = [\\Gamma_b, \\Phi_b \\Gamma_a] [D_b E_a; D_a]`, while the rank is below the size at
    which the factors stop paying, dense otherwise.
    """
    bD = _times_blocks(b.D, a.E)
    E = np.matmul(b.E, a.E)
    no, n2 = b.Phi.shape[0], b.D.shape[1]
    if phi is None:
        phi = b.Phi @ a.Phi
    if b.Gam is not None and a.Gam is not None:
        r = b.Gam.shape[1] + a.Gam.shape[1]
        if r * (no + n2) < no * n2:
            return _Step(E, np.hstack([b.Gam, b.Phi @ a.Gam]), np.vstack([bD, a.D]), phi)
    X = b.Phi @ a.dense()
    X += b.Gam @ bD if b.Gam is not None else bD
    return _Step(E, None, X, phi)


def _rows_after(op: _Step, Qa: np.ndarray, Qb: np.ndarray, Qz: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Rows times the step, :math:`Q \\leftarrow Q L` (the adjoint recursion)."""
    E = op.E
    n = E.shape[0]
    Y = (Qz @ op.Gam if op.Gam is not None else Qz) @ op.D
    return (
        Qa * E[:, 0, 0] + Qb * E[:, 1, 0] + Y[:, :n],
        Qa * E[:, 0, 1] + Qb * E[:, 1, 1] + Y[:, n:],
        Qz @ op.Phi,
    )


@dataclass(frozen=True, slots=True)
class _Modal:
    """The unit initial states in modal coordinates of the first segment's basis.

    Column l is the unit modal position :math:`p_l`, column N + l the unit velocity
    :math:`v_l`; the plant part is 2 x 2 block-diagonal, ``B[l] @ (1, 0)`` and
    ``B[l] @ (0, 1)`` being the plant state of mode l of those two columns. ``Pz`` (n_o, 2N),
    None while it is zero.
    """

    B: np.ndarray  # (N, 2, 2)
    Pz: np.ndarray | None


@dataclass(frozen=True, slots=True)
class _Dense:
    """The unit initial states in the original coordinates (columns), plant in the modal basis."""

    Pp: np.ndarray  # (N, 2N)
    Pv: np.ndarray  # (N, 2N)
    Pz: np.ndarray  # (n_o, 2N)


def _cols_after(op: _Step, P: _Modal | _Dense) -> _Modal | _Dense:
    """The step times the columns, :math:`P \\leftarrow L P`."""
    E = op.E
    n = E.shape[0]
    if isinstance(P, _Modal):
        # X [p; v] of the modal columns: column scalings of D
        S = _times_blocks(op.D, P.B)
        if op.Gam is not None:
            S = op.Gam @ S
        if P.Pz is not None:
            S += op.Phi @ P.Pz
        return _Modal(np.matmul(E, P.B), S)
    Pp, Pv = P.Pp, P.Pv
    inp = op.D[:, :n] @ Pp + op.D[:, n:] @ Pv
    if op.Gam is not None:
        inp = op.Gam @ inp
    inp += op.Phi @ P.Pz
    return _Dense(
        E[:, 0, 0, None] * Pp + E[:, 0, 1, None] * Pv,
        E[:, 1, 0, None] * Pp + E[:, 1, 1, None] * Pv,
        inp,
    )


class _Steps:
    """Step propagators of one observer and their powers; J and internal steps as in the modal
    simulator (:class:`~glocal_verify.simulation.engine._ModalEngine`)."""

    def __init__(self, system: System, o: ObserverModel, h: float, modes: tuple[str, ...], ops: StepOperators) -> None:
        from glocal_verify.simulation.engine import taylor_order

        self.system, self.o, self.n, self.h, self.ops = system, o, system.n, h, ops
        nu = 0.0
        for q in set(modes) | {NORMAL_MODE}:
            mu = system.spectrum(q).values
            nu = max(nu, float(np.max(np.sqrt(1.0 + (system.alpha * mu) ** 2 + system.gamma**2))))
        self.n_sub = max(1, int(math.ceil(nu * h / RHO_MAX - 1e-12)))
        self.J = taylor_order(nu * h / self.n_sub)
        self._sub: dict[tuple[str, float], _Step] = {}
        self._full: dict[tuple[str, float], _Step] = {}
        #: powers Phi^(2^i) of the full step h, per observer dynamics (shared across modes)
        self._phi: dict[str, list[np.ndarray]] = {}
        #: powers L^(2^i) of the full step h, per mode
        self._pow: dict[str, list[_Step]] = {}

    def output_rows(self, mode: str) -> tuple[np.ndarray, np.ndarray]:
        """The observer's measurement in the modal basis of ``mode``: (C_p U, C_v U)."""
        U = self.system.eigh(mode)[1]
        n = self.n
        return self.o.C[:, :n] @ U, self.o.C[:, n:] @ U

    def sub(self, mode: str, delta: float) -> _Step:
        """One internal step of length ``delta`` in ``mode`` (exponentials, Taylor input model)."""
        key = (mode, round(delta, 13))
        op = self._sub.get(key)
        if op is None:
            sy = self.system
            mu = sy.spectrum(mode).values
            n = self.n
            A = np.zeros((n, 2, 2))
            A[:, 0, 1] = 1.0
            A[:, 1, 0] = -sy.alpha * mu
            A[:, 1, 1] = -sy.gamma
            with blas_threads(1):  # N exponentials of 2 x 2 blocks
                E = scipy.linalg.expm(A * delta)
            dk = self.o.dynamics_key(mode)
            Phi, W = self.ops.get(self.o.F[dk], self.o.G[dk], self.J, delta)
            # D = [C_mod; C_mod A_xi; ...; C_mod A_xi^J] (the Taylor coefficients of y), row-wise
            cp, cv = self.output_rows(mode)
            rows = []
            for _ in range(self.J + 1):
                rows.append(np.hstack([cp, cv]))
                cp, cv = -sy.alpha * mu * cv, cp - sy.gamma * cv
            op = _Step(E, np.ascontiguousarray(W), np.vstack(rows), Phi)
            self._sub[key] = op
        return op

    def step(self, mode: str, delta: float) -> _Step:
        """One step of length ``delta``: the ``n_sub`` internal steps of the simulator, composed."""
        key = (mode, round(delta, 13))
        op = self._full.get(key)
        if op is None:
            s = self.sub(mode, delta / self.n_sub)
            op = s
            for _ in range(self.n_sub - 1):
                op = _after(s, op)
            self._full[key] = op
        return op

    def phi_powers(self, mode: str) -> list[np.ndarray]:
        """The known powers :math:`\\Phi^{2^i}` of the full step in ``mode`` (shared by every mode with
        the same observer dynamics)."""
        dk = self.o.dynamics_key(mode)
        got = self._phi.get(dk)
        if got is None:
            got = [self.step(mode, self.h).Phi]
            self._phi[dk] = got
        return got

    def phi_power(self, mode: str, i: int) -> np.ndarray:
        """:math:`\\Phi^{2^i}` of the full step, by squaring."""
        ph = self.phi_powers(mode)
        while len(ph) <= i:
            with blas_threads(None):  # n_o^3: every core
                ph.append(ph[-1] @ ph[-1])
        return ph[i]

    def power(self, mode: str, i: int) -> _Step:
        """:math:`L^{2^i}` of the full step, by squaring (the observer part shared with :meth:`phi_power`)."""
        pw = self._pow.get(mode)
        if pw is None:
            pw = [self.step(mode, self.h)]
            self._pow[mode] = pw
        ph = self.phi_powers(mode)
        while len(pw) <= i:
            j = len(pw)
            known = ph[j] if len(ph) > j else None
            with blas_threads(None):  # n_o^2 (n_o + 2N): every core
                nxt = _after(pw[-1], pw[-1], known)
            if known is None:
                ph.append(nxt.Phi)
            pw.append(nxt)
        return pw[i]

    def cols_power(self, mode: str, m: int, P: _Modal | _Dense) -> _Modal | _Dense:
        """:math:`L^m P` by binary powers up to :math:`L^{64}`, applied as often as needed
        (a higher power would cost two products, an application one)."""
        top = int(math.log2(_CHUNK))
        ops = [self.power(mode, i) for i in range(top) if (m >> i) & 1] + [self.power(mode, top)] * (m >> top)
        with blas_threads(None):  # n_o^2 2N each: every core
            for op in ops:
                P = _cols_after(op, P)
        return P


# --------------------------------------------------------------------------------------------
# rows of one segment


#: rows at which a product (rows x n_o) times (n_o x n_o) runs at half the peak rate of BLAS
#: (measured on 2-core AMD EPYC, n_o = 2000: 10 rows 14, 80 rows 43, 640 rows 48 GFlop/s)
_HALF_RATE_ROWS = 23


def _doublings(steps: _Steps, mode: str, m: int, q: int, cols_after: int) -> int:
    """How many squarings of :math:`\\Phi` the rows of ``m`` samples use (blocks of 2^s samples).

    Cost model in units of :math:`2 n_o^2` flops at the peak rate: the squarings not yet known
    (:math:`n_o` each; free: those the columns need afterwards, ``cols_after`` steps, and those
    already computed) plus the row products, :math:`m q (1 + r_{1/2} / (2^s q))` with the rate
    of a product of :math:`2^s q` rows taken as :math:`\\text{rows} / (\\text{rows} + r_{1/2})`
    of the peak (:data:`_HALF_RATE_ROWS`). The choice changes only the order of the products.
    """
    if m < 2:
        return 0
    top = min(int(math.log2(_CHUNK)), int(math.log2(m)))
    free = len(steps.phi_powers(mode)) - 1
    if cols_after > 1:
        free = max(free, min(int(math.log2(_CHUNK)), int(math.log2(cols_after))))
    no = steps.o.order

    def cost(s: int) -> float:
        need = s if m > (1 << s) else s - 1  # index of the highest power used
        return max(0, need - free) * no + _HALF_RATE_ROWS * m / (1 << s)

    return min(range(top + 1), key=cost)


def _z_rows(steps: _Steps, mode: str, Z0: np.ndarray, m: int, s: int) -> Iterator[np.ndarray]:
    """The observer rows :math:`Z_k = Z_0 \\Phi^k`, k < m, in chunks of :data:`_CHUNK` samples
    (sample-major), computed in blocks of 2^s samples (the first by doubling, each next one
    from the last by :math:`\\Phi^{2^s}`; s = 0: step by step)."""
    q = Z0.shape[0]
    B = 1 << s
    blk: np.ndarray | None = None  # the last block of B samples
    done = 0
    while done < m:
        c = min(_CHUNK, m - done)
        parts: list[np.ndarray] = []
        got = 0
        while got < c:
            if blk is None:
                blk = Z0
                for i in range(s):
                    blk = np.vstack([blk, blk @ steps.phi_power(mode, i)])
            else:
                blk = blk @ steps.phi_power(mode, s)
            take = min(B, c - got)
            parts.append(blk[: take * q])
            got += take
        yield np.vstack(parts) if len(parts) > 1 else parts[0]
        done += c


def _plant_rows(op: _Step, Qa: np.ndarray, Qb: np.ndarray, Y: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Plant rows of the samples of a chunk, :math:`(Q_a, Q_b)_{k+1} = (Q_a, Q_b)_k E + Y_k` with
    :math:`Y_k = Z_k X` (``Y``: the chunk's, sample-major): (rows of the chunk, rows after it)."""
    q, n = Qa.shape
    c = Y.shape[0] // q
    E00, E01, E10, E11 = op.E[:, 0, 0], op.E[:, 0, 1], op.E[:, 1, 0], op.E[:, 1, 1]
    A_ = np.empty((c * q, n))
    B_ = np.empty_like(A_)
    for i in range(c):
        A_[i * q : (i + 1) * q] = Qa
        B_[i * q : (i + 1) * q] = Qb
        y = Y[i * q : (i + 1) * q]
        Qa, Qb = Qa * E00 + Qb * E10 + y[:, :n], Qa * E01 + Qb * E11 + y[:, n:]
    return A_, B_, Qa, Qb


def _segment_rows(
    steps: _Steps, mode: str, start: tuple[np.ndarray, np.ndarray, np.ndarray], m: int, s: int
) -> Iterator[tuple[int, np.ndarray, np.ndarray, np.ndarray]]:
    """Rows at the m samples of a segment, in chunks: ``(first sample, Qa, Qb, Qz)`` with the
    rows of each sample stacked (sample-major), starting from the rows ``start`` at its first
    sample; blocks of 2^s samples for the observer part (module docstring)."""
    op = steps.step(mode, steps.h)
    Qa, Qb, Z0 = start
    done = 0
    for Zc in _z_rows(steps, mode, Z0, m, s):
        A_, B_, Qa, Qb = _plant_rows(op, Qa, Qb, (Zc @ op.Gam if op.Gam is not None else Zc) @ op.D)
        yield done, A_, B_, Zc
        done += A_.shape[0] // Z0.shape[0]


# --------------------------------------------------------------------------------------------
# the envelope


def _nonzero_cols(M: np.ndarray) -> np.ndarray:
    return np.flatnonzero(np.any(M != 0.0, axis=0))


def envelope_by_rows(
    system: System,
    bank: ObserverBank,
    schedule: Schedule,
    box: float,
    horizon: float | None,
    step: float | None,
    report: Reporter,
    step_operators: StepOperators | None = None,
) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    """The attack-free envelope by the row recursion (module docstring).

    Parameters
    ----------
    system, bank, schedule : System, ObserverBank, Schedule
    box : float
        Half-width b of the box of initial states.
    horizon, step : float or None
        Default: the spec's simulation settings.
    report : Reporter
        Progress (``"total:<samples>"`` once, then phases and samples done, ``"done"``).
    step_operators : StepOperators, optional
        Observer step operators shared with the simulations of the same step.

    Returns
    -------
    (t, envelope)
        Sample times and, per observer, the (K + 1, q) bound :math:`b \\sum_j |\\Psi_{kj}(t)|`.
    """
    for _, m in schedule.segments:
        system.check_mode(m)
    T, h = horizon_and_step(system, horizon, step)
    ops = step_operators if step_operators is not None else StepOperators()
    K = int(math.floor(T / h + 1e-9))
    end = K * h
    tol = 1e-9 * h
    t_grid = np.arange(K + 1) * h
    events = sorted(t for t in schedule.switch_times if 0.0 < t < end)
    starts, stops = [0.0] + events, events + [end]
    modes = [schedule.mode_at(a + 1e-12 * max(1.0, a)) for a in starts]
    # samples of each segment: t_k in [start, stop), the last segment up to the end
    seg_k: list[list[int]] = []
    for j, (a, b) in enumerate(zip(starts, stops)):
        last = j == len(starts) - 1
        seg_k.append([k for k in range(K + 1) if t_grid[k] >= a - tol and (t_grid[k] < b - tol or (last and t_grid[k] <= end + tol))])
    report(f"total:{(K + 1) * len(bank)}", 0)
    out: dict[str, np.ndarray] = {}
    U0 = system.eigh(modes[0])[1]
    plant = _PlantColumns(system, U0)
    for i_obs, o in enumerate(bank):
        q = len(o.channels)
        env = np.zeros((K + 1, q))
        out[o.name] = env
        if q == 0:
            report(f"{o.name}: no residual", K + 1)
            continue
        steps = _Steps(system, o, h, tuple(modes), ops)
        label = f"{o.name} ({i_obs + 1}/{len(bank)})"
        # one thread for the row and column products; the n_o^3 powers take every core
        with blas_threads(1):
            m1 = len(seg_k[0])
            if len(starts) == 2 and m1 and seg_k[1] == list(range(m1, K + 1)) and abs(t_grid[m1] - stops[0]) <= tol:
                if o.reset(modes[0], modes[1]) is None and _same_observer_step(steps.step(modes[0], h), steps.step(modes[1], h)):
                    report(f"{label}: rows continued across the switch at t = {stops[0]:g} s ({modes[0]} -> {modes[1]})", 0)
                    _across_the_switch(steps, (modes[0], modes[1]), m1, K, box, env, plant, report)
                    continue
            _segments(steps, label, starts, stops, modes, seg_k, t_grid, box, env, plant, report)
    report("done", 0)
    return t_grid, out


def _segments(
    steps: _Steps,
    label: str,
    starts: list[float],
    stops: list[float],
    modes: list[str],
    seg_k: list[list[int]],
    t_grid: np.ndarray,
    box: float,
    env: np.ndarray,
    plant: "_PlantColumns",
    report: Reporter,
) -> None:
    """The envelope of one observer, segment by segment: rows inside, columns at each switch."""
    o, n, h = steps.o, steps.n, steps.h
    q = len(o.channels)
    tol = 1e-9 * h
    U0 = plant.U0
    Z0 = np.asarray(o.Z0, dtype=float)
    z0c = _nonzero_cols(Z0)
    # the unit initial states at the segment start (None: the first segment)
    P: _Modal | _Dense | None = None
    for j, (a, b) in enumerate(zip(starts, stops)):
        mode, ks = modes[j], seg_k[j]
        last = j == len(starts) - 1
        report(f"{label}, segment {j + 1}/{len(starts)} ({mode})", 0)
        cp, cv = steps.output_rows(mode)
        Ry = o.output_map(mode)
        start = (Ry @ cp, Ry @ cv, -np.array(o.Rz, dtype=float))
        d0 = (t_grid[ks[0]] - a) if ks else 0.0
        if ks and d0 > tol:
            start = _rows_after(steps.step(mode, d0), *start)
        # steps of the uniform part the columns take to the switch
        n_pow = 0
        if ks and not last:
            n_pow = len(ks) - 1 + (1 if abs(b - t_grid[ks[-1]] - h) <= tol else 0)
        s = _doublings(steps, mode, len(ks), q, n_pow)
        for i0, A_, B_, Z_ in _segment_rows(steps, mode, start, len(ks), s):
            kk = ks[i0 : i0 + A_.shape[0] // q]
            if P is None:
                psi = np.empty((A_.shape[0], 2 * n))
                np.matmul(A_, U0.T, out=psi[:, :n])
                np.matmul(B_, U0.T, out=psi[:, n:])
                if len(z0c):
                    psi[:, z0c] += Z_ @ Z0[:, z0c]
            elif isinstance(P, _Dense):
                psi = A_ @ P.Pp + B_ @ P.Pv + Z_ @ P.Pz
            else:  # pragma: no cover - modal columns are converted at every switch
                raise AssertionError("modal columns after the first segment")
            env[kk] = box * np.abs(psi).sum(axis=1).reshape(len(kk), q)
            report("", len(kk))
        if last:
            break
        # the unit initial states at the next switch: binary powers of the step propagator
        report(f"{o.name}: the 2N unit states to the switch at t = {b:g} s", 0)
        if P is None:
            Pz0 = None
            if len(z0c):
                r0 = z0c[z0c < n]
                r1 = z0c[z0c >= n]
                Pz0 = np.hstack([Z0[:, r0] @ U0[r0, :], Z0[:, r1] @ U0[r1 - n, :]])
            P = _Modal(np.broadcast_to(np.eye(2), (n, 2, 2)).copy(), Pz0)
        if not ks:
            if b - a > tol:
                P = _cols_after(steps.step(mode, b - a), P)
        else:
            if d0 > tol:
                P = _cols_after(steps.step(mode, d0), P)
            P = steps.cols_power(mode, n_pow, P)
            rest = b - t_grid[ks[-1]]
            if rest > tol and abs(rest - h) > tol:
                P = _cols_after(steps.step(mode, rest), P)
        P = _to_dense(plant, j, P, o.order, mode, modes[j + 1])
        D = o.reset(mode, modes[j + 1])
        if D is not None:  # z <- z + (h_p - h_q) y at the switch (ObserverModel.reset)
            cq, vq = steps.output_rows(modes[j + 1])
            P = _Dense(P.Pp, P.Pv, P.Pz + D @ (cq @ P.Pp + vq @ P.Pv))


def _same_observer_step(a: _Step, b: _Step) -> bool:
    """Whether two steps move the observer alike (same :math:`\\Phi` and :math:`\\Gamma`, factored)."""
    if a.Gam is None or b.Gam is None or a.Gam.shape != b.Gam.shape:
        return False
    return (a.Phi is b.Phi or np.array_equal(a.Phi, b.Phi)) and (a.Gam is b.Gam or np.array_equal(a.Gam, b.Gam))


def _blocks_each(Y: np.ndarray, Ec: np.ndarray, out: np.ndarray) -> np.ndarray:
    """:math:`Y_i\\,\\mathrm{blockdiag}(E_i)` into ``out`` for a stack Y (T, q, 2N); ``Ec`` (2, 2, T, N)
    holds the entries of the E_i."""
    n = Ec.shape[3]
    Yp, Yv = Y[..., :n], Y[..., n:]
    tmp = np.empty_like(Yp)
    np.multiply(Yp, Ec[0, 0][:, None, :], out=out[..., :n])
    np.multiply(Yv, Ec[1, 0][:, None, :], out=tmp)
    out[..., :n] += tmp
    np.multiply(Yp, Ec[0, 1][:, None, :], out=out[..., n:])
    np.multiply(Yv, Ec[1, 1][:, None, :], out=tmp)
    out[..., n:] += tmp
    return out


def _window_sums(C: np.ndarray, op: _Step, q: int, m: int, K: int) -> np.ndarray:
    """:math:`W_j = \\sum_{i < m} Y_{j+m-1-i} E^i`, j = 0..K-m, with :math:`Y_k = C_k D` (q rows each).

    Sums over windows of m samples by the prefix/suffix scheme of blocks of length m (van Herk,
    Gil-Werman): every window is a suffix of one block (propagated by a power of E) plus a prefix
    of the next, so no term is subtracted and each costs O(q N). The modes are independent (2 x 2
    blocks): they are taken a few hundred at a time, so the working arrays stay small.
    """
    n = op.E.shape[0]
    W = np.empty((K - m + 1, q, 2 * n))
    width = max(1, min(n, (1 << 19) // max(1, m * q * 2)))  # working arrays of about 4 MiB
    for l0 in range(0, n, width):
        l1 = min(n, l0 + width)
        part = _window_sums_of(C, np.hstack([op.D[:, l0:l1], op.D[:, n + l0 : n + l1]]), op.E[l0:l1], q, m, K)
        W[:, :, l0:l1] = part[:, :, : l1 - l0]
        W[:, :, n + l0 : n + l1] = part[:, :, l1 - l0 :]
    return W


def _window_sums_of(C: np.ndarray, D: np.ndarray, E: np.ndarray, q: int, m: int, K: int) -> np.ndarray:
    """:func:`_window_sums` for the modes of ``E`` (D: their columns, p then v)."""
    n2 = D.shape[1]
    M2 = K - m + 1
    Ep = np.empty((m + 1,) + E.shape)
    Ep[0] = np.eye(2)
    for i in range(m):
        Ep[i + 1] = np.matmul(Ep[i], E)
    Ec = np.ascontiguousarray(Ep.transpose(2, 3, 0, 1))  # (2, 2, m + 1, modes)
    Er = np.ascontiguousarray(Ec[:, :, m - 1 :: -1])  # E^(m-1), ..., E^0
    W = np.empty((M2, q, n2))
    suf = np.empty((m, q, n2))
    work = np.empty((m, q, n2))
    have_suf = False
    c = 0
    while c * m < K:
        lo, hi = c * m, min((c + 1) * m, K)
        Yb = (C[lo * q : hi * q] @ D).reshape(hi - lo, q, n2)
        T = min(m, M2 - (c - 1) * m, hi - lo + 1) if (c >= 1 and have_suf) else 0
        # prefix(i) = sum_{i' <= i} Y_i' E^(i - i') inside the block, written where it is used
        acc = Yb[0].copy()
        for i in range(hi - lo):
            if i:
                acc = _times_blocks(acc, E)
                acc += Yb[i]
            if i < T - 1:
                W[(c - 1) * m + 1 + i] = acc
            if i == m - 1 and lo < M2:
                W[lo] = acc
        if T > 1:
            W[(c - 1) * m + 1 : (c - 1) * m + T] += _blocks_each(suf[1:T], Ec[:, :, 1:T], work[: T - 1])
        have_suf = hi - lo == m
        if have_suf:
            # suffix(i) = sum_{i' >= i in the block} Y_i' E^(block end - i')
            _blocks_each(Yb, Er, suf)
            np.cumsum(suf[::-1], axis=0, out=suf[::-1])
        c += 1
    return W


def _across_the_switch(
    steps: _Steps, modes: tuple[str, str], m: int, K: int, box: float, env: np.ndarray, plant: "_PlantColumns", report: Reporter
) -> None:
    """The envelope of one observer across one switch on the grid when its step is the same in
    both modes (:func:`_same_observer_step`): no columns of the observer state at all.

    With :math:`\\Phi' = \\Phi`, the observer rows after the switch are those before it,
    :math:`Z'_j = Z_j`, so the observer part of :math:`\\Psi` after the switch is
    :math:`Z_j P_{z,\\tau} = Z_{j+m} P_{z,0} + \\sum_{i<m} Y_{j+m-1-i} E^i` with
    :math:`Y_k = Z_k X` (the modal columns, m steps to the switch): the continued Krylov
    sequence and window sums (:func:`_window_sums`) replace the binary powers of the step
    applied to the 2N columns. Rows from t = 0 to the horizon, in modal columns of the first
    basis, converted once per chunk.
    """
    sy, o = steps.system, steps.o
    n, q = sy.n, len(o.channels)
    mode0, mode1 = modes
    op0, op1 = steps.step(mode0, steps.h), steps.step(mode1, steps.h)
    assert op0.Gam is not None
    U0 = plant.U0
    Z0 = np.asarray(o.Z0, dtype=float)
    z0c = _nonzero_cols(Z0)
    nz = K + 1 if len(z0c) else K  # Z_K only for the initial observer state's term
    r = op0.Gam.shape[1]
    C = np.empty((nz * q, r))
    G = np.empty((nz * q, len(z0c)))
    cp, cv = steps.output_rows(mode0)
    Ry0 = o.output_map(mode0)
    Qa, Qb = Ry0 @ cp, Ry0 @ cv
    s = _doublings(steps, mode0, nz, q, 0)
    done = 0
    for Zc in _z_rows(steps, mode0, -np.array(o.Rz, dtype=float), nz, s):
        c = Zc.shape[0] // q
        C[done * q : (done + c) * q] = Zc @ op0.Gam
        if len(z0c):
            G[done * q : (done + c) * q] = Zc @ Z0[:, z0c]
        c1 = min(c, m - done)
        if c1 > 0:  # samples before the switch
            A_, B_, Qa, Qb = _plant_rows(op0, Qa, Qb, C[done * q : (done + c1) * q] @ op0.D)
            psi = np.empty((c1 * q, 2 * n))
            np.matmul(A_, U0.T, out=psi[:, :n])
            np.matmul(B_, U0.T, out=psi[:, n:])
            if len(z0c):
                psi[:, z0c] += G[done * q : (done + c1) * q]
            env[done : done + c1] = box * np.abs(psi).sum(axis=1).reshape(c1, q)
            report("", c1)
        done += c
    report(f"{o.name}: window sums over the {m} steps to the switch", 0)
    W = _window_sums(C, op0, q, m, K)
    # the plant part of the unit states at the switch: E^m blocks, seen in the next basis
    B = np.broadcast_to(np.eye(2), (n, 2, 2)).copy()
    steps_e = m
    base = op0.E.copy()
    while steps_e:
        if steps_e & 1:
            B = np.matmul(base, B)
        steps_e >>= 1
        if steps_e:
            base = np.matmul(base, base)
    Tb = plant.basis_change(mode0, mode1)
    cp, cv = steps.output_rows(mode1)
    Ry1 = o.output_map(mode1)
    Qa, Qb = Ry1 @ cp, Ry1 @ cv
    M2 = K - m + 1
    j0 = 0
    while j0 < M2:
        c = min(_CHUNK, M2 - j0)
        A_, B_, Qa, Qb = _plant_rows(op1, Qa, Qb, C[j0 * q : (j0 + c) * q] @ op1.D)
        At, Bt = A_ @ Tb, B_ @ Tb
        Wc = W[j0 : j0 + c].reshape(c * q, 2 * n)
        mp = At * B[:, 0, 0] + Bt * B[:, 1, 0] + Wc[:, :n]
        mv = At * B[:, 0, 1] + Bt * B[:, 1, 1] + Wc[:, n:]
        psi = np.empty((c * q, 2 * n))
        np.matmul(mp, U0.T, out=psi[:, :n])
        np.matmul(mv, U0.T, out=psi[:, n:])
        if len(z0c):
            psi[:, z0c] += G[(j0 + m) * q : (j0 + m + c) * q]
        env[m + j0 : m + j0 + c] = box * np.abs(psi).sum(axis=1).reshape(c, q)
        report("", c)
        j0 += c


class _PlantColumns:
    """The plant part of the unit states at each switch, in the next mode's basis: the same for
    every observer (a pure function of the plant's step propagators), so computed once."""

    def __init__(self, system: System, U0: np.ndarray) -> None:
        self.system, self.U0 = system, U0
        self._at: dict[int, tuple[np.ndarray, np.ndarray, np.ndarray]] = {}
        self._tb: list[tuple[str, str, np.ndarray]] = []

    def at_switch(self, j: int, P: _Modal | _Dense, mode: str, nxt: str) -> tuple[np.ndarray, np.ndarray]:
        """(Pp, Pv) of ``P`` at the end of segment j, original columns, plant in the basis of ``nxt``."""
        src = P.B if isinstance(P, _Modal) else np.hstack([P.Pp, P.Pv])
        got = self._at.get(j)
        if got is not None and np.array_equal(got[0], src):
            return got[1], got[2]
        if isinstance(P, _Modal):
            B, Ut = P.B, self.U0.T
            Pp = np.hstack([B[:, 0, 0, None] * Ut, B[:, 0, 1, None] * Ut])
            Pv = np.hstack([B[:, 1, 0, None] * Ut, B[:, 1, 1, None] * Ut])
        else:
            Pp, Pv = P.Pp, P.Pv
        if nxt != mode:
            Tb = self.basis_change(mode, nxt)
            Pp, Pv = Tb @ Pp, Tb @ Pv
        self._at[j] = (src, Pp, Pv)
        return Pp, Pv

    def basis_change(self, mode: str, nxt: str) -> np.ndarray:
        """:math:`U_{nxt}^T U_{mode}`: modal coordinates of ``mode`` to those of ``nxt``."""
        for a, b, T in self._tb:
            if a == mode and b == nxt:
                return T
        T = self.system.eigh(nxt)[1].T @ self.system.eigh(mode)[1]
        self._tb.append((mode, nxt, T))
        return T


def _to_dense(plant: _PlantColumns, j: int, P: _Modal | _Dense, no: int, mode: str, nxt: str) -> _Dense:
    """The columns at the end of segment j in original coordinates, the plant in the modal basis
    of ``nxt`` (``no``: observer order)."""
    n = plant.system.n
    Pp, Pv = plant.at_switch(j, P, mode, nxt)
    if isinstance(P, _Modal):
        Ut = plant.U0.T
        if P.Pz is None:  # no step before the switch
            Pz = np.zeros((no, 2 * n))
        else:
            Pz = np.empty((no, 2 * n))
            np.matmul(P.Pz[:, :n], Ut, out=Pz[:, :n])
            np.matmul(P.Pz[:, n:], Ut, out=Pz[:, n:])
        return _Dense(Pp, Pv, Pz)
    return _Dense(Pp, Pv, P.Pz)
