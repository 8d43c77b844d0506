"""Remark III.3.1 (``rmk:Safe_topology_switching``): does a safe-mode switch touch the attack?

After the switch to mode q the centralized observer's error dynamics (eq. ``obs_cent_error``)
are driven by the discrepancy (A_q - A_1) x = [0; -alpha dL_q x] with dL_q = L_q - L_1. With
x = x_bar + x~ (attack-free part plus the attack's part, Proposition II.4), dL_q x_bar tends
to dL_q (consensus) = 0, so what matters is dL_q applied to the states the attack moves.

ZDA: the attacker chooses the direction
    At the exponent lambda0 of the attack, with s = lambda0^2 + gamma lambda0, the stealthy
    directions are the kernel Z of the N-sized system of ``stealthy.zda``
    (:mod:`glocal_verify.stealthy`)

    .. math::

        (sI + \\alpha L_1)\\,\\xi = S_F^\\top u_0,\\qquad S_{M_x}\\xi = 0,\\qquad
        \\lambda_0 \\ne 0 \\Rightarrow S_{M_v}\\xi = 0,

    x~(t) = [xi; lambda0 xi] e^{lambda0 t}. When Z has dimension > 1 (always when the system
    is not left-invertible) the attacker picks the direction, so the switch is *avoidable*
    iff some (xi, u0) in Z has

    .. math:: \\Delta L_q\\, \\xi = 0, \\qquad u_0 \\ne 0 .

    Then (sI + alpha L_q) xi = (sI + alpha L_1) xi = S_F^T u0, i.e. x0 = [xi; lambda0 xi] is a
    zero direction of (A_q, B, C) too: the attack survives the switch and the discrepancy it
    causes is zero (bounded and vanishing residual). If *every* stealthy direction at lambda0
    is touched, the residual follows e^{lambda0 t} (unbounded for Re lambda0 > 0, unless the
    discrepancy hides in an unobservable eigenspace of L_q -- see ``switching.detects``).
    Checking one chosen direction, as an earlier version did, is unsound both ways round: a
    touched witness does not mean the attacker cannot avoid the switch.

    The decision is the kernel of the stacked N-sized system

    .. math::

        \\begin{bmatrix} sI + \\alpha L_1 & -S_F^\\top \\\\ S_{\\mathrm{out}} & 0 \\\\
        \\Delta L_q[D, :] & 0 \\end{bmatrix}
        \\begin{bmatrix} \\xi \\\\ u_0 \\end{bmatrix} = 0

    (S_out = S_{M_x} for lambda0 = 0, S_M otherwise; only the rows D of the switching
    components, the other rows of dL_q are zero): avoidable iff its u0-part is nonzero.
    lambda0 is the spec's ``attack.lambda0`` when a stealthy ZDA exists there, else the
    exponent of ``stealthy.zda``'s witness direction (fastest-growing zero, or lambda0 = 1 when
    the system is not left-invertible and no zero is unstable) -- the same rule as
    :func:`glocal_verify.stealthy.zda_analysis`. The verdict concerns that lambda0 only.

covert attack
    x~ stays in the attack-reachable subspace, inside span{e_j : j connected to F} for
    positions (and velocities); the switch touches it iff a switched link has an endpoint
    connected to F. This coordinate subspace contains the reachable subspace of (A_1, B), so
    "does not touch" (holds) is sound; "touches" (fails) is an over-approximation: the
    attacker's u_a may keep x~ in a smaller subspace that the switch does not touch.

The paper never defines X_q in eq. ``unsafe_set`` (X_q ∩ Z = ∅), and the two places that use
it disagree: the remark says the discrepancy is "bounded and vanishing if" eq. ``unsafe_set``
holds, while Section IV says "only case 2 meets (unsafe_set) ... the global residual for case
1 is bounded and vanishing ... while that of case 2 is unbounded" -- and case 2 is the switch
that touches the attacked agents. Reading the remark, X_q ∩ Z = ∅ means "the switch does not
touch the attack"; reading Section IV it means the opposite. The verdict of
``switching.safe`` follows the remark: **holds := the switch does not touch the attack**
(an avoiding stealthy direction exists); both readings are spelled out in every witness, and
a report-level finding states the contradiction.

Numeric path (modal, N-sized, cheap for large N)
    In the modal coordinates of L_1 = U diag(mu) U^T, with d_k = s + alpha mu_k, the first
    block reads d_k eta_k = (U_F^T u0)_k (xi = U eta). Modes with |d_k| > 1 are eliminated
    exactly, eta_k = (U_F^T u0)_k / d_k; the others stay unknowns with their exact rows, so
    the reduced matrix

    .. math::

        S = \\begin{bmatrix} D_J & -U_{F,J}^\\top \\\\ U_{\\mathrm{out},J} &
        U_{\\mathrm{out},f} D_f^{-1} U_{F,f}^\\top \\end{bmatrix}

    has the same kernel as the stacked system's first two blocks. Dividing each eliminated row
    by |d_k| (a row scaling: same kernel) gives a reference matrix with O(1) entries whose
    singular values are within a factor 3 of those of S; the rank of S is decided with
    :class:`~glocal_verify.linalg.Tolerance` against max(1, ||S||_2): singular values
    <= rtol * scale span the certain kernel Z_c, those <= rtol * band * scale the possible
    kernel Z_p. Within Z (basis orthonormalised in xi, so ||xi|| = 1 for unit coefficients)
    the switch condition dL_q xi = 0 is decided on the singular values of
    dL_q[D, D] X[D] / ||dL_q||_2 (scale 1), and the input part ||u0|| against
    ||[x0; u0]|| = sqrt((1 + |lambda0|^2) + ||u0||^2) -- the rule ``stealthy.zda`` uses.
    ``holds``: the chosen direction of ``stealthy.zda`` is certainly untouched, or the certain
    avoiding subspace carries a certainly nonzero input and that direction verifies on the
    full pencil (residual as in :mod:`glocal_verify.stealthy`) with dL_q xi = 0 at the
    tolerance. ``fails``: the chosen direction is certainly touched and no direction of the
    possible avoiding subspace of Z_p carries an input that is not certainly zero. Otherwise
    ``undecided``. Cost: the symmetric eigendecomposition of L_1 (cached), one SVD of size
    (|J| + p) x (|J| + |F|) with |J| the modes with |s + alpha mu_k| <= 1, O(N^2 dim Z).

Exact path
    Rational lambda0: the kernel of the stacked system over Q (:func:`glocal_verify.exact.
    nullspace`, flint). Irrational or complex lambda0 (minimal polynomial g of degree > 1):
    the kernel over the number field Q[x]/(g) (:func:`glocal_verify.pencil.kernel_over_field`,
    Gaussian elimination with entries reduced mod g -- g is irreducible, so Q[x]/(g) is a
    field and the answer holds at every root of g). The u0-rank of the kernel decides; no
    numeric shortcut and never ``undecided``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from fractions import Fraction
from typing import Any, Sequence

import flint
import numpy as np

from . import exact as ex
from . import pencil as pn
from .linalg import DEFAULT_TOLERANCE, Decision, Tolerance
from .model import System
from .registry import CheckContext, checker, finding_rule, result
from .results import ConditionResult, Finding, Status
from .spec import Label
from .stealthy import (
    GROWTH_DECAYING,
    GROWTH_PERSISTENT,
    GROWTH_UNBOUNDED,
    ExactZdaZero,
    ZdaDirection,
    ZdaZero,
    _exact_zero,
    _fq,
    _Modal,
    _moved,
    _normalize,
    _q_matrix,
    _vec,
    reachable_agents,
    zda_analysis,
    zda_analysis_exact,
)

__all__ = ["Avoidance", "avoidance", "avoidance_exact", "check_safe", "delta_norm", "remark_contradiction"]

PRED_BOUNDED_VANISHING = "bounded-vanishing"
PRED_UNBOUNDED = "unbounded"
PRED_BOUNDED = "bounded"

#: modes with |s + alpha mu_k| above this are eliminated in the numeric reduction (see the module docstring)
_NEAR = 1.0

MARGIN_SCALE = (
    "holds: ||dL_q xi|| / (||dL_q||_2 ||xi||) of the avoiding direction (0 exactly, rounding level numerically); "
    "fails: the smallest ||dL_q xi|| / (||dL_q||_2 ||xi||) over the stealthy directions at lambda0, modulo the "
    "input-free ones (u0 = 0, which an attacker may add at no cost) -- in [0, 1], 0 iff avoidable"
)


def _delta_block(system: System, mode: str) -> tuple[list[int], np.ndarray]:
    """Indices D of the switching components and dL_q[D, D] (dL_q is zero outside D x D)."""
    labs = [lab for comp in system.switching_components(mode) for lab in comp]
    idx = system.idx(labs)
    pos = {i: k for k, i in enumerate(idx)}
    blk = np.zeros((len(idx), len(idx)))
    for u, v, dw in system.switching_links(mode):
        a, b = pos[system.index[u]], pos[system.index[v]]
        w = float(dw)
        blk[a, b] -= w
        blk[b, a] -= w
        blk[a, a] += w
        blk[b, b] += w
    return idx, blk


def _block_norm(blk: np.ndarray) -> float:
    if blk.size == 0:
        return 0.0
    return float(np.max(np.abs(np.linalg.eigvalsh(blk)), initial=0.0))


def delta_norm(system: System, mode: str) -> float:
    """||dL_q||_2, computed on the switching components D_c (dL_q is zero elsewhere).

    Parameters
    ----------
    system : System
        The system.
    mode : str
        A safe mode.
    """
    return _block_norm(_delta_block(system, mode)[1])


# ------------------------------------------------------------------------------------------
# records


@dataclass(frozen=True, slots=True)
class Avoidance:
    """Can a stealthy ZDA at lambda0 avoid the switch to ``mode``? (Remark III.3.1)

    Attributes
    ----------
    mode : str
        The safe mode q.
    status : Status
        ``HOLDS``: an avoiding direction exists (the switch does not touch the attack);
        ``FAILS``: every stealthy direction at lambda0 is touched; ``UNDECIDED`` (numeric only).
    lambda0 : complex
        The exponent (see the module docstring for how it is chosen).
    growth : str
        Growth class of lambda0 (``unbounded`` / ``persistent`` / ``decaying`` / ``undecided``).
    chosen : ZdaDirection
        The witness direction of ``stealthy.zda``.
    chosen_source : str
        Why ``stealthy.zda`` chose it.
    chosen_touched : bool or None
        dL_q xi != 0 for the chosen direction (None: undecided).
    chosen_touched_agents : tuple of labels
        Rows of dL_q xi (chosen direction) that are nonzero.
    direction : ZdaDirection or None
        On ``HOLDS`` the avoiding direction: the chosen one when it is untouched, else a
        vector of the avoiding subspace with the largest input part.
    direction_source : str
        ``stealthy.zda`` or ``kernel of the stacked system``.
    dimension : int or None
        Rank of the u0-part of the avoiding subspace {(xi, u0) in Z : dL_q xi = 0} (the
        number of independent inputs an avoiding attacker has). Numeric: the count of
        certainly nonzero singular values (a lower bound; at least 1 on ``HOLDS``); 0 on
        ``FAILS``; None when undecided.
    margin : float
        See ``MARGIN_SCALE``.
    dl_residual : float
        ||dL_q xi|| / (||dL_q||_2 ||xi||) of ``direction`` (on ``HOLDS``).
    exact_xi, exact_u0 : tuple of Fraction or None
        The avoiding direction over Q (exact path, rational lambda0), xi scaled to max |xi_k| = 1.
    notes : tuple of str
    """

    mode: str
    status: Status
    lambda0: complex
    growth: str
    chosen: ZdaDirection
    chosen_source: str
    chosen_touched: bool | None
    chosen_touched_agents: tuple[Label, ...]
    direction: ZdaDirection | None
    direction_source: str
    dimension: int | None
    margin: float
    dl_residual: float = math.nan
    exact_xi: tuple[Fraction, ...] | None = None
    exact_u0: tuple[Fraction, ...] | None = None
    notes: tuple[str, ...] = field(default_factory=tuple)


# ------------------------------------------------------------------------------------------
# numeric


@dataclass(frozen=True, slots=True)
class _Basis:
    """A basis of (part of) Z: modal coordinates eta (xi = U eta), xi and u0 (columns)."""

    eta: np.ndarray
    x: np.ndarray
    u: np.ndarray


def _right_svd(M: np.ndarray, ncols: int) -> tuple[np.ndarray, np.ndarray]:
    """Singular values padded with zeros to ``ncols`` (descending) and all right singular vectors."""
    if M.shape[0] == 0 or ncols == 0:
        return np.zeros(ncols), np.eye(ncols, dtype=M.dtype if M.size else float)
    _, sv, Vh = np.linalg.svd(M, full_matrices=True)
    return np.concatenate([sv, np.zeros(ncols - len(sv))]), Vh.conj().T


def _stealthy_bases(md: _Modal, lam: complex) -> tuple[_Basis, _Basis]:
    """Certain and possible bases of Z at ``lam`` from the reduced modal matrix S."""
    N, m = md.N, len(md.F)
    s = lam * lam + md.gamma * lam
    d: np.ndarray = s + md.alpha * md.mu
    real = lam.imag == 0.0
    if real:
        d = d.real
    dtype = float if real else complex
    rows_out = md.Mx if lam == 0 else md.M
    near = np.abs(d) <= _NEAR
    J, far = np.flatnonzero(near), np.flatnonzero(~near)
    nJ, p = len(J), len(rows_out)
    UF = md.U[md.F, :]
    UO = md.U[rows_out, :]
    S = np.zeros((nJ + p, nJ + m), dtype=dtype)
    S[:nJ, :nJ] = np.diag(d[J])
    S[:nJ, nJ:] = -UF[:, J].T
    S[nJ:, :nJ] = UO[:, J]
    if len(far):
        S[nJ:, nJ:] = (UO[:, far] / d[far]) @ UF[:, far].T
    ncols = nJ + m
    sv, V = _right_svd(S, ncols)
    scale = max(1.0, float(sv[0]) if ncols else 0.0)
    cert = int(np.sum(sv > md.tol.upper * scale))
    maybe = int(np.sum(sv > md.tol.rtol * scale))

    def basis(Vk: np.ndarray) -> _Basis:
        k = Vk.shape[1]
        eta = np.zeros((N, k), dtype=dtype)
        uu = Vk[nJ:].astype(dtype)
        eta[J] = Vk[:nJ]
        if len(far):
            eta[far] = (UF[:, far].T @ uu) / d[far][:, None]
        x = md.U @ eta if real else md.U @ eta.real + 1j * (md.U @ eta.imag)
        return _Basis(eta, x, uu)

    return basis(V[:, maybe:]), basis(V[:, cert:])


@dataclass(frozen=True, slots=True)
class _Split:
    """Z in xi-orthonormal coordinates: xi = Xo c, u0 = B c, eta = E c; A c = dL_q xi / ||dL_q||."""

    Xo: np.ndarray
    B: np.ndarray
    E: np.ndarray | None
    A: np.ndarray


def _split(basis_x: np.ndarray, basis_u: np.ndarray, basis_eta: np.ndarray | None, dl_idx: Sequence[int], dl_blk: np.ndarray, dl_norm: float) -> _Split:
    k = basis_x.shape[1]
    if k == 0:
        z = np.zeros((0, 0))
        return _Split(np.zeros((basis_x.shape[0], 0)), np.zeros((basis_u.shape[0], 0)), None if basis_eta is None else np.zeros((basis_x.shape[0], 0)), z)
    Ux, Sx, Vxh = np.linalg.svd(basis_x, full_matrices=False)
    keep = Sx > 1e-300  # xi = 0 forces u0 = 0 (S_F^T is injective): X is injective on Z
    W = Vxh.conj().T[:, keep] / Sx[keep]
    Xo = Ux[:, keep]
    A = dl_blk @ Xo[list(dl_idx), :] / dl_norm if dl_norm > 0 else np.zeros((0, Xo.shape[1]), dtype=Xo.dtype)
    return _Split(Xo, basis_u @ W, None if basis_eta is None else basis_eta @ W, A)


def _input_decisions(sv: np.ndarray, lam: complex, tol: Tolerance) -> list[Decision]:
    """||u0|| against ||[x0; u0]|| for unit xi (``stealthy.zda``'s rule)."""
    x2 = 1.0 + abs(lam) ** 2
    return [tol.decide(float(v), math.sqrt(x2 + float(v) ** 2)) for v in sv]


def _avoiding(sp: _Split, lam: complex, tol: Tolerance, cut: float) -> tuple[np.ndarray | None, int, bool]:
    """(best coefficient vector, certain u0-rank, some input not certainly zero) of the
    avoiding subspace {c : singular values of A <= cut} of ``sp``."""
    r = sp.Xo.shape[1]
    if r == 0:
        return None, 0, False
    sa, Va = _right_svd(sp.A, r)
    K = Va[:, sa <= cut]
    if K.shape[1] == 0 or sp.B.shape[0] == 0:
        return None, 0, False
    _, su, Vuh = np.linalg.svd(sp.B @ K, full_matrices=False)
    dec = _input_decisions(su, lam, tol)
    dim = sum(1 for x in dec if x is Decision.NONZERO)
    some = any(x is not Decision.ZERO for x in dec)
    best = K @ Vuh[0].conj() if len(su) else None
    return best, dim, some


def _fails_margin(sp: _Split, lam: complex, tol: Tolerance) -> float | None:
    """min ||P A c|| over unit c orthogonal to the input-free directions (see ``MARGIN_SCALE``):
    P projects out A(input-free directions). None when Z carries no input at all."""
    r = sp.Xo.shape[1]
    if r == 0:
        return None
    sb, Vb = _right_svd(sp.B, r)
    free = np.array([x is Decision.ZERO for x in _input_decisions(sb, lam, tol)], dtype=bool)
    N0, Vr = Vb[:, free], Vb[:, ~free]
    if Vr.shape[1] == 0:
        return None
    AV = sp.A @ Vr
    if N0.shape[1] and sp.A.shape[0]:
        U0, s0, _ = np.linalg.svd(sp.A @ N0, full_matrices=False)
        Q0 = U0[:, s0 > tol.rtol]
        AV = AV - Q0 @ (Q0.conj().T @ AV)
    sp_, _ = _right_svd(AV, Vr.shape[1])
    return float(sp_[-1])


def _touched(system: System, dl_idx: Sequence[int], dl_blk: np.ndarray, dl_norm: float, xi: np.ndarray, tol: Tolerance) -> tuple[Decision, float, list[Label]]:
    """Decision on ||dL_q xi|| vs ||dL_q||_2 ||xi||, the ratio, and the nonzero rows."""
    dLxi = dl_blk @ xi[list(dl_idx)]
    nrm = dl_norm * float(np.linalg.norm(xi))
    val = float(np.linalg.norm(dLxi))
    rows = [system.labels[i] for i, v in zip(dl_idx, dLxi) if tol.decide(abs(v), nrm) is Decision.NONZERO]
    rows.sort(key=system.index.__getitem__)
    return tol.decide(val, nrm), (val / nrm if nrm > 0 else 0.0), rows


def _numeric_mode(system: System, mode: str, md: _Modal, z: ZdaZero, source: str, bases: tuple[_Basis, _Basis]) -> Avoidance:
    tol = md.tol
    lam = z.value
    chosen = z.direction()
    dl_idx, dl_blk = _delta_block(system, mode)
    dl_norm = _block_norm(dl_blk)
    dec_c, ratio_c, rows_c = _touched(system, dl_idx, dl_blk, dl_norm, chosen.xi, tol)
    chosen_touched = None if dec_c is Decision.UNDECIDED else dec_c is Decision.NONZERO
    zc, zp = bases
    sc = _split(zc.x, zc.u, zc.eta, dl_idx, dl_blk, dl_norm)
    best, dim_c, _ = _avoiding(sc, lam, tol, tol.rtol)
    notes: list[str] = []
    common: dict[str, Any] = dict(
        mode=mode, lambda0=lam, growth=z.growth, chosen=chosen, chosen_source=source, chosen_touched=chosen_touched, chosen_touched_agents=tuple(rows_c)
    )
    if dec_c is Decision.ZERO:
        return Avoidance(
            status=Status.HOLDS, direction=chosen, direction_source="stealthy.zda", dimension=max(1, dim_c), margin=ratio_c, dl_residual=ratio_c, **common
        )
    if best is not None and dim_c >= 1 and sc.E is not None:
        eta = sc.E @ best
        u = sc.B @ best
        xi, u2, res, dres, du = md.verify(lam, eta, u)
        dd, ratio, _ = _touched(system, dl_idx, dl_blk, dl_norm, xi, tol)
        if dres is Decision.ZERO and du is Decision.NONZERO and dd is Decision.ZERO:
            xi_n, u_n = _normalize(xi, u2)
            d = ZdaDirection(lam, xi_n, u_n, np.concatenate([xi_n, lam * xi_n]), res)
            return Avoidance(
                status=Status.HOLDS, direction=d, direction_source="kernel of the stacked system", dimension=dim_c, margin=ratio, dl_residual=ratio, **common
            )
        notes.append(f"avoiding candidate failed verification (pencil residual {res:.3g}: {dres.value}, input {du.value}, dL_q xi {dd.value})")
    sp = _split(zp.x, zp.u, None, dl_idx, dl_blk, dl_norm)
    _, _, some = _avoiding(sp, lam, tol, tol.upper)
    if dec_c is Decision.NONZERO and not some:
        fm = _fails_margin(sp, lam, tol)
        return Avoidance(status=Status.FAILS, direction=None, direction_source="", dimension=0, margin=ratio_c if fm is None else fm, **common)
    if some:
        notes.append("an avoiding direction with an input may exist (possible kernel) but is not certain at the tolerance")
    if dec_c is Decision.UNDECIDED:
        notes.append("whether dL_q xi = 0 for the chosen direction is undecided")
    return Avoidance(status=Status.UNDECIDED, direction=None, direction_source="", dimension=None, margin=ratio_c, notes=tuple(notes), **common)


def avoidance(system: System, mode: str, tol: Tolerance = DEFAULT_TOLERANCE, *, lambda0: complex | float | Sequence[float] | None = None) -> Avoidance | None:
    """Numeric decision of ``switching.safe`` for a ZDA at lambda0 and the switch to ``mode``.

    .. math::

        \\exists\\, (\\xi, u_0):\\ (sI + \\alpha L_1)\\xi = S_F^\\top u_0,\\ S_{\\mathrm{out}}\\xi = 0,\\
        \\Delta L_q \\xi = 0,\\ u_0 \\ne 0

    Parameters
    ----------
    system : System
        The system; F is its ``attack.actuators``.
    mode : str
        A safe mode q.
    tol : Tolerance
        Tolerance (rules in the module docstring).
    lambda0 : complex, float or [re, im], optional
        Overrides the spec's ``attack.lambda0`` (the exponent rule of ``stealthy.zda`` applies).

    Returns
    -------
    Avoidance or None
        None when ``stealthy.zda`` has no witness direction (no stealthy ZDA, or undecided).
    """
    za = zda_analysis(system, tol, lambda0=lambda0)
    if za.direction is None:
        return None
    md = _Modal(system, za.actuators, tol)
    return _numeric_mode(system, mode, md, za.direction, za.direction_source, _stealthy_bases(md, za.direction.value))


# ------------------------------------------------------------------------------------------
# exact


def _rational_rows(system: System, F: Sequence[int], lam: Fraction, dL: Sequence[Sequence[Fraction]], dl_idx: Sequence[int]) -> tuple[list[list[Fraction]], list[list[Fraction]]]:
    """Over Q: the rows [sI + alpha L_1, -S_F^T], [S_out, 0] and the rows [dL_q[D, :], 0]."""
    N, m = system.n, len(F)
    L = system.laplacian_exact()
    a, s = system.alpha_q, lam * lam + system.gamma_q * lam
    rows: list[list[Fraction]] = []
    for i in range(N):
        rows.append([a * L[i][j] + (s if i == j else 0) for j in range(N)] + [Fraction(-1 if F[k] == i else 0) for k in range(m)])
    out = system.idx(system.monitored_positions) if lam == 0 else system.idx(system.monitored)
    for r in out:
        rows.append([Fraction(int(j == r)) for j in range(N + m)])
    return rows, [list(dL[i]) + [Fraction(0)] * m for i in dl_idx]


def _normalize_exact(v: Sequence[Fraction], N: int) -> tuple[tuple[Fraction, ...], tuple[Fraction, ...]]:
    k = max(range(N), key=lambda i: abs(v[i]))
    c = v[k]
    return tuple(x / c for x in v[:N]), tuple(x / c for x in v[N:])


def _exact_mode(system: System, mode: str, d: ExactZdaZero, source: str, F: Sequence[int], tol: Tolerance) -> Avoidance:
    N, m = system.n, len(F)
    g = d.field
    dL = system.delta_laplacian_exact(mode)
    dl_idx, dl_blk = _delta_block(system, mode)
    dl_norm = _block_norm(dl_blk)
    touched: list[Label] = []
    for i in sorted(dl_idx):  # (dL_q xi)_i in Q[x]/(g), exactly; rows outside D are zero
        acc = flint.fmpq_poly(0)
        for j, v in enumerate(d.xi_field):
            if dL[i][j] != 0:
                acc = acc + v * _fq(dL[i][j])
        if not (acc % g).is_zero():
            touched.append(system.labels[i])
    chosen = d.direction()
    exact_xi: tuple[Fraction, ...] | None = None
    exact_u0: tuple[Fraction, ...] | None = None
    avoid_dir: ZdaDirection | None = None
    Zcols: list[np.ndarray]
    if d.rational is not None:
        rows, dl_rows = _rational_rows(system, F, d.rational, dL, dl_idx)
        K = ex.nullspace(rows + dl_rows, N + m)
        urows_q = [v[N:] for v in K]
        dim = ex.rank(urows_q, m) if urows_q else 0
        pick_q = next((v for v in K if any(x != 0 for x in v[N:])), None)
        if pick_q is not None:
            exact_xi, exact_u0 = _normalize_exact(pick_q, N)
            xi = np.array([float(x) for x in exact_xi])
            u = np.array([float(x) for x in exact_u0])
            avoid_dir = ZdaDirection(chosen.lambda0, xi, u, np.concatenate([xi, chosen.lambda0 * xi]), 0.0)

        def z_basis() -> list[np.ndarray]:
            return [np.array([float(x) for x in v], dtype=complex) for v in ex.nullspace(rows, N + m)]

    else:  # irrational or complex lambda0: the number field Q[x]/(g)
        x = flint.fmpq_poly([0, 1])
        s_poly = x * x + _fq(system.gamma_q) * x
        Q = _q_matrix(system, F, system.idx(system.monitored), s_poly)
        zero = flint.fmpq_poly(0)
        dl_p = [[flint.fmpq_poly(_fq(dL[i][j])) for j in range(N)] + [zero] * m for i in dl_idx]
        Kf = pn.kernel_over_field(Q + dl_p, g, N + m).basis
        urows_f = [list(v[N:]) for v in Kf]
        dim = pn.rank_over_field(urows_f, g, m) if urows_f else 0
        pick_f = next((v for v in Kf if any(not e.is_zero() for e in v[N:])), None)
        if pick_f is not None:
            avoid_dir = _exact_zero(system, g, pick_f, d.value, d.real_sign, True, 1, m).direction()

        def z_basis() -> list[np.ndarray]:
            return pn.kernel_over_field(Q, g, N + m).evaluate(d.value)

    if touched == [] and dim == 0:  # pragma: no cover - a theorem, kept as a self-check
        raise AssertionError("the chosen ZDA direction avoids the switch but the stacked kernel has no input; please report")
    common: dict[str, Any] = dict(
        mode=mode,
        lambda0=d.value,
        growth=d.growth,
        chosen=chosen,
        chosen_source=source,
        chosen_touched=bool(touched),
        chosen_touched_agents=tuple(touched),
        dimension=dim,
    )
    if not touched:
        return Avoidance(status=Status.HOLDS, direction=chosen, direction_source="stealthy.zda", margin=0.0, dl_residual=0.0, **common)
    if dim > 0:
        assert avoid_dir is not None
        return Avoidance(
            status=Status.HOLDS,
            direction=avoid_dir,
            direction_source="kernel of the stacked system",
            margin=0.0,
            dl_residual=0.0,
            exact_xi=exact_xi,
            exact_u0=exact_u0,
            **common,
        )
    cols = z_basis()
    X = np.array(cols).T if cols else np.zeros((N + m, 0))
    sp = _split(X[:N], X[N:], None, dl_idx, dl_blk, dl_norm)
    fm = _fails_margin(sp, d.value, tol)
    if fm is None:
        fm = _touched(system, dl_idx, dl_blk, dl_norm, chosen.xi, tol)[1]
    return Avoidance(status=Status.FAILS, direction=None, direction_source="", margin=fm, **common)


def avoidance_exact(system: System, mode: str, *, lambda0: complex | float | Sequence[float] | None = None, tol: Tolerance = DEFAULT_TOLERANCE) -> Avoidance | None:
    """Exact decision of ``switching.safe`` (rational weights and gains; never undecided).

    Parameters
    ----------
    system : System
        The system; F is its ``attack.actuators``.
    mode : str
        A safe mode q.
    lambda0 : complex, float or [re, im], optional
        Overrides the spec's ``attack.lambda0`` (read as an exact binary rational).
    tol : Tolerance
        Used only for the (informative) margin on ``FAILS``.

    Returns
    -------
    Avoidance or None
        None when no stealthy ZDA exists.
    """
    ea = zda_analysis_exact(system, lambda0=lambda0)
    if ea.direction is None:
        return None
    return _exact_mode(system, mode, ea.direction, ea.direction_source, system.idx(ea.actuators), tol)


# ------------------------------------------------------------------------------------------
# checker


def _readings(touches: bool | None, predicted: str) -> tuple[dict[str, Any], dict[str, Any]]:
    remark = {
        "meaning": "X_q ∩ Z = ∅ read as: the switch does not touch the states Z the attack moves (dL_q Z = 0)",
        "condition_holds": None if touches is None else (not touches),
        "predicts": PRED_BOUNDED_VANISHING if touches is False else f"no guarantee ({predicted})",
    }
    section_iv = {
        "meaning": "Section IV: 'only case 2 meets (unsafe_set)', and case 2 is the switch that touches the attacked agents",
        "condition_holds": touches,
        "predicts": (
            "unbounded residual (as case 2)" if touches else "bounded and vanishing residual (as case 1)"
        )
        if touches is not None
        else "undecided",
    }
    return remark, section_iv


def _links_json(system: System, mode: str) -> list[list[Any]]:
    return [[u, v, float(dw)] for u, v, dw in system.switching_links(mode)]


def _predict(touches: bool, growth: str) -> str:
    if not touches:
        return PRED_BOUNDED_VANISHING
    if growth == GROWTH_UNBOUNDED:
        return PRED_UNBOUNDED
    if growth == GROWTH_DECAYING:
        return PRED_BOUNDED_VANISHING
    return PRED_BOUNDED


def _direction_json(system: System, F: Sequence[Label], d: ZdaDirection, tol: Tolerance) -> dict[str, Any]:
    return {
        "lambda0": [d.lambda0.real, d.lambda0.imag],
        "xi": _vec(system, d.xi, system.labels, tol),
        "u0": _vec(system, d.u0, F, tol, support_only=False),
        "moved": _moved(system, d.xi, tol),
    }


def _avoidance_result(system: System, ctx: CheckContext, F: Sequence[Label], av: Avoidance, extra: dict[str, Any] | None = None) -> ConditionResult:
    tol = ctx.tol
    touches = None if av.status is Status.UNDECIDED else av.status is Status.FAILS
    chosen = _direction_json(system, F, av.chosen, tol)
    chosen.update(source=av.chosen_source, touched=av.chosen_touched, touched_agents=list(av.chosen_touched_agents))
    w: dict[str, Any] = {
        "attack_kind": "zda",
        "switching_links": _links_json(system, av.mode),
        "lambda0": [av.lambda0.real, av.lambda0.imag],
        "lambda0_rule": "the spec's attack.lambda0 when a stealthy ZDA exists there, else the exponent of stealthy.zda's direction; the verdict concerns this lambda0 only",
        "growth": av.growth,
        "touches_attack": touches,
        "avoidable": None if touches is None else not touches,
        "avoiding_dimension": av.dimension,
        "chosen_direction": chosen,
        "margin_scale": MARGIN_SCALE,
    }
    if av.status is Status.HOLDS:
        assert av.direction is not None
        ad = _direction_json(system, F, av.direction, tol)
        ad.update(source=av.direction_source, dL_residual=av.dl_residual, pencil_residual=av.direction.residual)
        if av.exact_xi is not None and av.exact_u0 is not None:
            ad["xi_exact"] = {lab: str(x) for lab, x in zip(system.labels, av.exact_xi) if x != 0}
            ad["u0_exact"] = {lab: str(x) for lab, x in zip(F, av.exact_u0)}
        w["avoiding_direction"] = ad
        w["moved_by_attack"] = ad["moved"]
        w["touched_agents"] = []
        w["predicted_residual"] = PRED_BOUNDED_VANISHING
    elif av.status is Status.FAILS:
        w["moved_by_attack"] = chosen["moved"]
        w["touched_agents"] = list(av.chosen_touched_agents)
        w["predicted_residual"] = _predict(True, av.growth)
    else:
        w["moved_by_attack"] = chosen["moved"]
        w["touched_agents"] = list(av.chosen_touched_agents)
        w["predicted_residual"] = "undecided"
    remark, sec4 = _readings(touches, w["predicted_residual"])
    w["reading_remark"], w["reading_section_iv"] = remark, sec4
    if av.notes:
        w["notes"] = list(av.notes)
    w.update(extra or {})
    return result("switching.safe", ctx, av.status, scope={"mode": av.mode}, margin=av.margin, witness=w)


def _zda_results(system: System, ctx: CheckContext) -> list[ConditionResult]:
    lam_opt = ctx.options.get("lambda0")
    out: list[ConditionResult] = []
    if ctx.exact:
        ea = zda_analysis_exact(system, lambda0=lam_opt)
        exists, decided = ea.exists, True
        F = ea.actuators
    else:
        za = zda_analysis(system, ctx.tol, lambda0=lam_opt)
        exists, decided = za.exists, za.decided
        F = za.actuators
    if not exists:
        for mode in system.safe_modes:
            status = Status.HOLDS if decided else Status.UNDECIDED
            remark, sec4 = _readings(False if decided else None, PRED_BOUNDED)
            base: dict[str, Any] = {
                "attack_kind": "zda",
                "switching_links": _links_json(system, mode),
                "touches_attack": False if decided else None,
                "avoidable": True if decided else None,
                "note": "no stealthy ZDA for this attack (stealthy.zda fails): Z = {0}, nothing to touch",
                "predicted_residual": PRED_BOUNDED_VANISHING,
                "reading_remark": remark,
                "reading_section_iv": sec4,
            }
            out.append(result("switching.safe", ctx, status, scope={"mode": mode}, margin=0.0, witness=base))
        return out
    if ctx.exact:
        d_ex = ea.direction
        assert d_ex is not None
        for mode in system.safe_modes:
            av = _exact_mode(system, mode, d_ex, ea.direction_source, system.idx(F), ctx.tol)
            lam_ex = str(d_ex.rational) if d_ex.rational is not None else d_ex.factor
            out.append(_avoidance_result(system, ctx, F, av, {"lambda0_exact": lam_ex}))
        return out
    d_num = za.direction
    assert d_num is not None
    md = _Modal(system, F, ctx.tol)
    bases = _stealthy_bases(md, d_num.value)  # Z does not depend on the mode
    for mode in system.safe_modes:
        out.append(_avoidance_result(system, ctx, F, _numeric_mode(system, mode, md, d_num, za.direction_source, bases)))
    return out


def _covert_results(system: System, ctx: CheckContext) -> list[ConditionResult]:
    attack = system.spec.attack
    assert attack is not None
    R = set(reachable_agents(system))
    out: list[ConditionResult] = []
    lam = attack.lambda0
    if attack.signal == "exponential" and lam is not None:
        growth = GROWTH_UNBOUNDED if lam.real > 0 else (GROWTH_PERSISTENT if lam.real == 0 else GROWTH_DECAYING)
    else:
        growth = GROWTH_PERSISTENT  # bounded (step, sine or unspecified) input
    for mode in system.safe_modes:
        links = system.switching_links(mode)
        touching = [[u, v, float(dw)] for u, v, dw in links if u in R or v in R]
        touches = bool(touching)
        predicted = _predict(touches, growth)
        remark, sec4 = _readings(touches, predicted)
        witness: dict[str, Any] = {
            "attack_kind": "covert",
            "touches_attack": touches,
            "reachable_agents": sorted(R, key=system.index.__getitem__),
            "switching_links": _links_json(system, mode),
            "links_touching": touching,
            "predicted_residual": predicted,
            "prediction_assumes": "the covert input of the spec (attack.signal/lambda0); a bounded input when unspecified",
            "soundness": "coordinate over-approximation of the reachable subspace: 'does not touch' is sound, 'touches' may be conservative",
            "reading_remark": remark,
            "reading_section_iv": sec4,
        }
        status = Status.FAILS if touches else Status.HOLDS
        out.append(
            result("switching.safe", ctx, status, scope={"mode": mode}, margin=float(len(touching)), witness=witness, numeric_decision=False)
        )
    return out


@checker("switching.safe")
def check_safe(system: System, ctx: CheckContext) -> list[ConditionResult]:
    """Remark III.3.1, eq. ``unsafe_set``: the safe-mode switch does not touch the attack.

    .. math::

        \\text{ZDA: } \\exists\\,(\\xi, u_0):\\ (sI + \\alpha L_1)\\xi = S_F^\\top u_0,\\
        S_{\\mathrm{out}}\\xi = 0,\\ \\Delta L_q\\, \\xi = 0,\\ u_0 \\ne 0;
        \\qquad
        \\text{covert: } \\Delta L_q\\, e_j = 0 \\ \\ \\forall j \\text{ connected to } F

    with s = lambda0^2 + gamma lambda0 at the attack's lambda0 (the spec's ``attack.lambda0``
    when a stealthy ZDA exists there, else the exponent of ``stealthy.zda``'s witness
    direction; option ``lambda0`` overrides the spec) and S_out = S_{M_x} for lambda0 = 0,
    S_M otherwise. ``holds`` := the switch does not touch the attack, i.e. some stealthy
    direction at lambda0 avoids it (the attacker chooses the direction, so one touched
    direction is not enough) -- the remark's reading of eq. ``unsafe_set`` (see the module
    docstring for the Section IV reading, which is the opposite; the witness reports both).
    ``fails`` := every stealthy direction at lambda0 is touched. Scope: every safe mode.
    Needs an attack in the spec (no result otherwise). When no stealthy ZDA exists, Z = {0}
    and the verdict holds vacuously.

    Tolerance (ZDA, numeric): rank decisions of the reduced modal matrix against
    max(1, ||S||_2), of dL_q on the xi-orthonormal basis of Z against ||dL_q||_2, inputs
    against ||[x0; u0]|| (module docstring); an avoiding witness is verified on the full
    pencil. Exact: kernel over Q (rational lambda0) or over Q[x]/(g), g the minimal
    polynomial of lambda0; never undecided. Covert: combinatorial (links of the spec), no
    tolerance; "does not touch" is sound, "touches" an over-approximation.

    Margin
        ZDA (``MARGIN_SCALE``): on ``holds`` ||dL_q xi|| / (||dL_q||_2 ||xi||) of the avoiding
        direction (0 exactly; rounding level numerically); on ``fails`` the smallest
        ||dL_q xi|| / (||dL_q||_2 ||xi||) over the stealthy directions at lambda0 modulo the
        input-free ones (for a simple zero of a left-invertible system: that of the unique
        direction), in (0, 1]; on ``undecided`` that of the chosen direction. Covert: the
        number of switched links that touch agents connected to F.
    Witness
        ``touches_attack`` (= not ``avoidable``), ``avoidable``, ``avoiding_dimension`` (rank
        of the u0-part of the avoiding subspace; 0 on ``fails``), ``lambda0``, ``growth``,
        ``chosen_direction`` (``stealthy.zda``'s direction with ``touched`` and
        ``touched_agents``), on ``holds`` ``avoiding_direction`` (lambda0, xi and u0 by
        label, moved agents, residuals; ``xi_exact``/``u0_exact`` over Q), ``moved_by_attack``
        and ``touched_agents`` of the direction the verdict is about, ``switching_links``,
        ``predicted_residual`` (``bounded-vanishing`` | ``unbounded`` | ``bounded``),
        ``reading_remark`` and ``reading_section_iv`` (what each reading of eq.
        ``unsafe_set`` says and predicts).
    """
    attack = system.spec.attack
    if attack is None or not system.safe_modes:
        return []
    if attack.kind == "covert":
        return _covert_results(system, ctx)
    return _zda_results(system, ctx)


@finding_rule
def remark_contradiction(system: System, results: Sequence[ConditionResult]) -> list[Finding]:
    """Remark III.3.1 and Section IV read eq. ``unsafe_set`` in opposite ways."""
    if system.spec.attack is None or not system.safe_modes:
        return []
    per_mode: dict[str, Any] = {}
    for r in results:
        if r.id == "switching.safe":
            per_mode[str(r.scope.get("mode"))] = {
                "touches_attack": r.witness.get("touches_attack"),
                "predicted_residual": r.witness.get("predicted_residual"),
            }
    detail = (
        "Remark III.3.1 says the discrepancy (A_q - A_1) x is 'bounded and vanishing if' X_q ∩ Z = ∅ "
        "(eq. unsafe_set), but never defines X_q. Section IV says 'only case 2 meets (unsafe_set)' and "
        "that case 2 (the switch touching the attacked agents 3, 4) gives the unbounded residual while "
        "case 1 (not touching) gives the bounded, vanishing one. Under the remark's reading eq. unsafe_set "
        "means 'the switch does not touch the attack' and predicts a bounded residual; under Section IV's "
        "it means the opposite. switching.safe follows the remark (holds = does not touch) and reports "
        "both readings; the algebra (dL_q x~ = 0 makes the discrepancy vanish) supports the remark's "
        "prediction and Section IV's simulation outcome, but not Section IV's wording."
    )
    if per_mode:
        detail += " On this system: " + "; ".join(
            f"{m}: touches={v['touches_attack']}, predicted residual {v['predicted_residual']}" for m, v in per_mode.items()
        ) + "."
    return [
        Finding(
            "remark-iii31.unsafe-set",
            "Remark III.3.1 and Section IV contradict each other about eq. unsafe_set",
            detail,
            "Remark III.3.1, eq. unsafe_set; Section IV",
            {"modes": per_mode},
        )
    ]
