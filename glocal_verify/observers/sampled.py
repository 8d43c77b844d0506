"""Detectors of the sampled implementation: the central observer and the local UIOs at period h.

With a sampled-data consensus controller (``implementation.controller = "sampled"``) the loop
is the rational discrete system :math:`x_{k+1} = \\Phi_q x_k + \\Gamma (u_{a,k} + d_k)`
(:mod:`glocal_verify.analysis.sampled.loop`), and each detector is designed on it, exactly:

**Central observer** (eq. ``obs_cent`` at the samples, normal-mode model):
:math:`\\hat x_{k+1} = \\Phi_1 \\hat x_k + H (y_k - C \\hat x_k)`, :math:`\\hat x_0 = 0`,
:math:`r_{0,k} = y_k - C \\hat x_k`. Under Lemma III.1's privacy the consensus direction
``[1_c; 0]`` of every component without a position monitor is unobservable with eigenvalue
exactly 1, so the gain is designed on the quotient by those directions: with
:math:`\\pi` (positions relative to one representative agent per such component) and its
section :math:`\\sigma` (the representative's position set to 0), :math:`\\pi \\sigma = I`,
:math:`\\Phi_\\pi = \\pi \\Phi_1 \\sigma`, :math:`C_\\pi = C \\sigma`, the gain is the steady-state
Kalman gain :math:`L = \\Phi_\\pi P C_\\pi^T (C_\\pi P C_\\pi^T + I)^{-1}` of the discrete Riccati
equation with unit covariances, and :math:`H = \\sigma L`. The error :math:`e = x - \\hat x`
then obeys, exactly, :math:`\\epsilon_{k+1} = F \\epsilon_k + \\pi(w_k + \\Gamma u_{a,k}) - L n_k`
with :math:`\\epsilon = \\pi e`, :math:`F = \\Phi_\\pi - L C_\\pi`, and :math:`r_{0,k} = C_\\pi \\epsilon_k + n_k`.

**Local UIO** (eq. ``obs_decent`` at the samples): the cluster's sampled model
:math:`x^i_{k+1} = A^i_d x^i_k + E_d d_k + \\dots` with :math:`E_d = [\\tfrac{h^2}{2} S_{\\partial}^T; h S_{\\partial}^T]`
(the neighbours' sampled positions are held by the boundary agents' controllers: an unknown
input that is constant over the period, so the decoupling is exact). With
:math:`H = E_d (C E_d)^+` (exact), :math:`T = I - H C`, a Kalman gain :math:`K_1` for
:math:`(T A^i_d, C)`, :math:`F = T A^i_d - K_1 C`, :math:`K = K_1 + F H`:
:math:`z_{k+1} = F z_k + K y_k`, :math:`\\hat x = z + H y`, :math:`r = (I - C H) y - C z`. With
:math:`\\tilde e = T x^i - z`: :math:`\\tilde e_{k+1} = F \\tilde e_k + T(w^i_k + \\Gamma^i u_{a,k}) - K n_k`,
:math:`r_k = C \\tilde e_k + (I - C H) n_k`.

Every matrix is an exact rational (``fmpq_mat``): the gains are the binary floating-point
numbers the design returns, taken exactly, and everything built from them is computed over
Q, so the error equations above hold exactly for the deployed detector. Stability of ``F`` is
certified separately (:mod:`glocal_verify.numerics.certified_rows`).
"""

from __future__ import annotations

from dataclasses import dataclass
from fractions import Fraction
from typing import Any, Sequence

import flint
import numpy as np
import scipy.linalg

from glocal_verify.analysis.sampled.loop import implementation_of, sampled_matrices_exact
from glocal_verify.errors import NotApplicableError
from glocal_verify.model import LocalObserver, System
from glocal_verify.numerics.exact import columns as exact_columns
from glocal_verify.spec.types import NORMAL_MODE, ImplementationSpec, Label

__all__ = [
    "SampledObserver",
    "to_exact",
    "to_float",
    "consensus_quotient",
    "design_sampled_central",
    "SampledClusterModel",
    "DecouplingError",
    "sampled_cluster_model",
    "design_sampled_uio",
    "sampled_observers",
]


def to_exact(X: np.ndarray) -> flint.fmpq_mat:
    """A float array as the exact rational matrix of its binary values."""
    X = np.atleast_2d(np.asarray(X, dtype=float))
    m, n = X.shape
    return flint.fmpq_mat(m, n, [flint.fmpq(*Fraction(float(x)).as_integer_ratio()) for x in X.ravel()])


def to_float(M: Any) -> np.ndarray:
    """An ``fmpq_mat`` (or ``arb_mat``, midpoints) as floats (each entry rounded once)."""
    m, n = M.nrows(), M.ncols()
    if isinstance(M, flint.arb_mat):
        return np.array([[float(M[i, j].mid()) for j in range(n)] for i in range(m)]).reshape(m, n)
    return np.array([[float(M[i, j]) for j in range(n)] for i in range(m)]).reshape(m, n)


def _eye(n: int) -> flint.fmpq_mat:
    M = flint.fmpq_mat(n, n)
    for i in range(n):
        M[i, i] = 1
    return M



def _rows(M: flint.fmpq_mat, idx: Sequence[int]) -> flint.fmpq_mat:
    out = flint.fmpq_mat(len(idx), M.ncols())
    for r, i in enumerate(idx):
        for j in range(M.ncols()):
            out[r, j] = M[i, j]
    return out


@dataclass(frozen=True, slots=True)
class SampledObserver:
    """A detector of the sampled implementation: how it runs and its exact error equation.

    Implementation (what a simulation runs): :math:`z_{k+1} = F_o z_k + G_o y_k`,
    :math:`r_k = R_y y_k - R_z z_k`, :math:`y_k = C x_k + n_k` (its own channels).
    Error equation (what the certified bounds use):
    :math:`\\epsilon_{k+1} = F \\epsilon_k + G_w w_k + G_u u_k - K_n n_k`,
    :math:`r_k = C_e \\epsilon_k + D_n n_k`, :math:`\\epsilon_0 = P_x x_0` (observers from 0)
    or :math:`P_e e_0 + P_n n_0` (a box of initial estimation errors ``e_0``), where ``w`` is
    the plant's sampled disturbance (2N) and ``u`` the held acceleration input of every agent
    (N, the attack's channels among them).

    Attributes
    ----------
    name, kind : str
        ``"central"`` or ``"<cluster>@<centre>"``; ``"central"`` / ``"local"``.
    channels : tuple of str
        Its measured channels (``"x:<label>"``, ``"v:<label>"``), rows of ``C``.
    C : fmpq_mat
        Measurement map on the plant state (p x 2N).
    Fo, Go, Ry, Rz : fmpq_mat
        The implementation.
    F, Gw, Gu, Kn, Ce, Dn, Px, Pe, Pn : fmpq_mat
        The error equation (``Pe`` maps the observer's initial error box: 2N columns for the
        central observer, the cluster's 2 n_i for a UIO).
    estimate_rows : tuple of int
        Plant coordinates the observer estimates (all 2N, or its cluster's).
    cluster : str or None
    center : label or None
    notes : tuple of str
    """

    name: str
    kind: str
    channels: tuple[str, ...]
    C: Any
    Fo: Any
    Go: Any
    Ry: Any
    Rz: Any
    F: Any
    Gw: Any
    Gu: Any
    Kn: Any
    Ce: Any
    Dn: Any
    Px: Any
    Pe: Any
    Pn: Any
    estimate_rows: tuple[int, ...]
    cluster: str | None = None
    center: Label | None = None
    notes: tuple[str, ...] = ()

    @property
    def order(self) -> int:
        """Dimension of the implementation's state z."""
        return int(self.Fo.nrows())

    def floats(self) -> dict[str, np.ndarray]:
        """Every matrix as floats (for simulation)."""
        return {k: to_float(getattr(self, k)) for k in ("C", "Fo", "Go", "Ry", "Rz", "F", "Gw", "Gu", "Kn", "Ce", "Dn", "Px", "Pe", "Pn")}


def consensus_quotient(system: System, mode: str = NORMAL_MODE) -> tuple[flint.fmpq_mat, flint.fmpq_mat, tuple[int, ...]]:
    """``(pi, sigma, representatives)``: the quotient by ``[1_c; 0]`` of every component of
    ``mode`` without a position monitor (module docstring); identity when there is none."""
    n = system.n
    mx = set(system.monitored_positions)
    reps: list[int] = []
    rep_of: dict[int, int] = {}
    for comp in system.components(mode):
        if any(a in mx for a in comp):
            continue
        idx = system.idx(comp)
        reps.append(idx[0])
        for i in idx:
            rep_of[i] = idx[0]
    keep = [i for i in range(2 * n) if i not in set(reps)]
    pi = flint.fmpq_mat(len(keep), 2 * n)
    sigma = flint.fmpq_mat(2 * n, len(keep))
    for r, i in enumerate(keep):
        pi[r, i] = 1
        sigma[i, r] = 1
        if i < n and i in rep_of:
            pi[r, rep_of[i]] = -1
    return pi, sigma, tuple(reps)


def _kalman(A: np.ndarray, C: np.ndarray) -> np.ndarray:
    """Predictor gain ``A P C^T (C P C^T + I)^{-1}`` of the discrete Riccati equation (unit covariances)."""
    p = C.shape[0]
    if p == 0:
        return np.zeros((A.shape[0], 0))
    P = scipy.linalg.solve_discrete_are(A.T, C.T, np.eye(A.shape[0]), np.eye(p))
    S = C @ P @ C.T + np.eye(p)
    return np.asarray(scipy.linalg.solve(S, (A @ P @ C.T).T, assume_a="pos").T)


def _global_C(system: System, positions: Sequence[Label], velocities: Sequence[Label]) -> tuple[flint.fmpq_mat, tuple[str, ...]]:
    n = system.n
    px, pv = system.idx(positions), system.idx(velocities)
    C = flint.fmpq_mat(len(px) + len(pv), 2 * n)
    for r, i in enumerate(px):
        C[r, i] = 1
    for r, i in enumerate(pv):
        C[len(px) + r, n + i] = 1
    return C, tuple(f"x:{a}" for a in positions) + tuple(f"v:{a}" for a in velocities)


def design_sampled_central(system: System, implementation: ImplementationSpec | None = None) -> SampledObserver:
    """The central observer of the sampled implementation (module docstring).

    Raises
    ------
    NotApplicableError
        For the continuous loop (its model is transcendental), when nothing is measured
        globally, or when the discrete Riccati equation has no stabilising solution.
    """
    impl = implementation_of(system, implementation)
    if impl.controller != "sampled":
        raise NotApplicableError("the detectors' exact model needs a sampled controller (implementation.controller = 'sampled')")
    n = system.n
    C, ch = _global_C(system, system.monitored_positions, system.monitored_velocities)
    if C.nrows() == 0:
        raise NotApplicableError("nothing is measured globally: the central observer has no residual")
    Phi, Gam = sampled_matrices_exact(system, NORMAL_MODE, impl)
    pi, sigma, reps = consensus_quotient(system)
    Pq, Cq = pi * Phi * sigma, C * sigma
    try:
        L = _kalman(to_float(Pq), to_float(Cq))
    except (np.linalg.LinAlgError, ValueError) as exc:
        raise NotApplicableError(f"no stabilising discrete Riccati solution for the central observer ({exc})") from None
    Lq = to_exact(L)
    H = sigma * Lq
    p = C.nrows()
    F = Pq - Lq * Cq
    notes = (f"quotient by the consensus of {len(reps)} component(s) without a position monitor",) if reps else ()
    return SampledObserver(
        "central",
        "central",
        ch,
        C,
        Phi - H * C,
        H,
        _eye(p),
        C,
        F,
        pi,
        pi * Gam,
        Lq,
        Cq,
        _eye(p),
        pi,
        pi,
        flint.fmpq_mat(F.nrows(), p),
        tuple(range(2 * n)),
        notes=notes,
    )


@dataclass(frozen=True, slots=True)
class SampledClusterModel:
    """The exact sampled model of one local observer's cluster (module docstring).

    Attributes
    ----------
    name : str
    rows : tuple of int
        Plant coordinates of the cluster (positions, then velocities).
    A, E, C : fmpq_mat
        ``A^i_d`` (the cluster's block of Phi_1), ``E_d`` and the observer's measurement map.
    H, T, Abar : fmpq_mat
        ``H = E_d (C E_d)^+``, ``T = I - H C`` and ``T A_d``.
    C_global : fmpq_mat
        The measurement map on the whole plant state.
    channels : tuple of str
    """

    name: str
    rows: tuple[int, ...]
    A: Any
    E: Any
    C: Any
    H: Any
    T: Any
    Abar: Any
    C_global: Any
    channels: tuple[str, ...]


class DecouplingError(NotApplicableError):
    """``rank(C E_d) < rank(E_d)``: no UIO decouples the neighbours (an exact, combinatorial fact)."""


def sampled_cluster_model(
    system: System, observer: LocalObserver, implementation: ImplementationSpec | None = None, *, mode: str = NORMAL_MODE
) -> SampledClusterModel:
    """The exact sampled model of a local observer's cluster in ``mode`` and its decoupling (module docstring).

    In a mode that adds an inter-cluster link at an agent without outside neighbour, ``E_d``
    has a column more than in the normal mode, and ``H`` differs.

    Raises
    ------
    NotApplicableError
        For the continuous loop.
    DecouplingError
        When ``rank(C E_d) < rank(E_d)``.
    """
    impl = implementation_of(system, implementation)
    if impl.controller != "sampled":
        raise NotApplicableError("a sampled UIO needs a sampled controller: with a continuous loop the neighbours' states vary inside a period")
    cl = system.cluster(observer.cluster)
    nodes = list(cl.nodes)
    k = len(nodes)
    n = system.n
    gidx = system.idx(nodes)
    rows = gidx + [n + i for i in gidx]
    Phi, _ = sampled_matrices_exact(system, mode, impl)
    # the cluster's block of Phi_q: its rows and columns (the principal block keeps the degrees)
    A = exact_columns(_rows(Phi, rows), rows)
    model = system.cluster_model(observer.cluster, mode)
    bidx = [nodes.index(b) for b in model.boundary]
    h = impl.period
    E = flint.fmpq_mat(2 * k, len(bidx))
    for c, i in enumerate(bidx):
        E[i, c] = flint.fmpq(*(h * h / 2).as_integer_ratio())
        E[k + i, c] = flint.fmpq(*h.as_integer_ratio())
    Cg, ch = _global_C(system, observer.positions, observer.velocities)
    C = exact_columns(Cg, rows)
    p = C.nrows()
    name = f"{observer.cluster}@{observer.center}"
    if E.ncols():
        CE = C * E
        if CE.rank() < E.rank():
            raise DecouplingError(f"{name}: rank(C E_d) = {CE.rank()} < rank(E_d) = {E.rank()} (a boundary agent's velocity is not measured)")
        H = E * (CE.transpose() * CE).inv() * CE.transpose()
    else:
        H = flint.fmpq_mat(2 * k, p)
    T = _eye(2 * k) - H * C
    return SampledClusterModel(name, tuple(rows), A, E, C, H, T, T * A, Cg, ch)


def design_sampled_uio(
    system: System, observer: LocalObserver, implementation: ImplementationSpec | None = None, *, mode: str = NORMAL_MODE
) -> SampledObserver:
    """The local UIO of the sampled implementation (module docstring), designed for ``mode``
    (default the normal mode: what runs before any switch).

    Raises
    ------
    NotApplicableError
        For the continuous loop (the neighbours' states vary inside a period: no sampled UIO
        decouples them), when ``rank(C E_d) < rank(E_d)`` (:class:`DecouplingError`), or when
        ``(T A_d, C)`` is not detectable (no stabilising Riccati solution).
    """
    impl = implementation_of(system, implementation)
    m = sampled_cluster_model(system, observer, impl, mode=mode)
    name, rows, A, C, H, T, Abar, Cg, ch = m.name, list(m.rows), m.A, m.C, m.H, m.T, m.Abar, m.C_global, m.channels
    k = len(rows) // 2
    n = system.n
    p = C.nrows()
    _, Gam = sampled_matrices_exact(system, mode, impl)
    try:
        K1 = to_exact(_kalman(to_float(Abar), to_float(C)))
    except (np.linalg.LinAlgError, ValueError) as exc:
        raise NotApplicableError(f"{name}: (T A_d, C) is not detectable ({exc})") from None
    F = Abar - K1 * C
    K = K1 + F * H
    S = flint.fmpq_mat(2 * k, 2 * n)
    for r, i in enumerate(rows):
        S[r, i] = 1
    Gu = T * _rows(Gam, rows)
    return SampledObserver(
        name,
        "local",
        ch,
        Cg,
        F,
        K,
        _eye(p) - C * H,
        C,
        F,
        T * S,
        Gu,
        K,
        C,
        _eye(p) - C * H,
        T * S,
        _eye(2 * k),
        H,
        tuple(rows),
        observer.cluster,
        observer.center,
    )


def sampled_observers(system: System, implementation: ImplementationSpec | None = None) -> tuple[tuple[SampledObserver, ...], tuple[str, ...]]:
    """The central observer and every local UIO of the spec that can be built, with notes on those that cannot."""
    obs: list[SampledObserver] = []
    notes: list[str] = []
    try:
        obs.append(design_sampled_central(system, implementation))
    except NotApplicableError as exc:
        notes.append(f"central: {exc}")
    for lo in system.observers():
        try:
            obs.append(design_sampled_uio(system, lo, implementation))
        except NotApplicableError as exc:
            notes.append(str(exc))
    return tuple(obs), tuple(notes)
