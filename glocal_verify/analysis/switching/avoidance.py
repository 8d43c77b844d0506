"""Does a safe mode touch the attack? The analysis behind Remark III.3.1.

At the attack's exponent lambda0 the attacker may choose any direction of the stealthy kernel
Z; the switch to mode q is avoidable iff some direction in Z has ``dL_q xi = 0``.
:func:`avoidance` decides it numerically, :func:`avoidance_exact` over Q or a number field.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping, MutableMapping
from dataclasses import dataclass, field
from fractions import Fraction
from typing import Any, Sequence

import flint
import numpy as np

from glocal_verify import config
from glocal_verify.analysis.switching.touch import Avoidance, block_norm, delta_block
from glocal_verify.analysis.switching.zero_touch import touch_at_zero
from glocal_verify.analysis.stealthy.zda import (
    ZdaDirection,
    ZdaZero,
    ModalPencil,
    normalize_direction,
    zda_analysis,
)
from glocal_verify.analysis.stealthy.zda_certificate import exact_q_rows, u_direction_certificate
from glocal_verify.analysis.stealthy.zda_exact import (
    ExactZdaZero,
    _exact_zero,
    _fq,
    _q_matrix,
    transfer_kernel,
    zda_analysis_exact,
)
from glocal_verify.derived import Kind
from glocal_verify.model import System
from glocal_verify.numerics import exact as ex
from glocal_verify.numerics.exact_subspace import rational_kernel_vector
from glocal_verify.numerics.pencil_exact import (
    RootEnclosures,
    eval_at_root,
    kernel_over_field,
    rank_over_field,
)
from glocal_verify.numerics.tolerance import DEFAULT_TOLERANCE, Decision, Tolerance
from glocal_verify.results import Status
from glocal_verify.spec.types import NORMAL_MODE, Label

__all__ = [
    "AvoidanceVerdict",
    "NO_ZDA_PREMISE",
    "decide_avoidance",
    "avoidance",
    "avoidance_exact",
    "avoidance_certificate",
    "avoiding_subspace",
    "direction_touch",
    "DirectionTouch",
    "separator_avoidance",
    "exact_mode_avoidance",
    "numeric_mode_avoidance",
    "stealthy_bases",
    "split_basis",
    "StealthyBasis",
    "SplitBasis",
]

#: derived results this module keeps on the system (glocal_verify.derived)
_ENCLOSED_KIND: Kind[Any] = Kind("separator-enclosure", __name__, "Any")

#: modes with |s + alpha mu_k| above this are eliminated in the numeric reduction (see the module docstring)
_NEAR = 1.0


# ------------------------------------------------------------------------------------------
# numeric


@dataclass(frozen=True, slots=True)
class StealthyBasis:
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


def stealthy_bases(md: ModalPencil, lam: complex) -> tuple[StealthyBasis, StealthyBasis]:
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
    UF = md.UF
    UO = md.UMx if lam == 0 else md.UM
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

    def basis(Vk: np.ndarray) -> StealthyBasis:
        k = Vk.shape[1]
        eta = np.zeros((N, k), dtype=dtype)
        uu = Vk[nJ:].astype(dtype)
        eta[J] = Vk[:nJ]
        if len(far):
            eta[far] = (UF[:, far].T @ uu) / d[far][:, None]
        x = md.sp.apply(eta)  # real and imaginary parts apart (no complex copy of U)
        return StealthyBasis(eta, x, uu)

    return basis(V[:, maybe:]), basis(V[:, cert:])


@dataclass(frozen=True, slots=True)
class SplitBasis:
    """Z in xi-orthonormal coordinates: xi = Xo c, u0 = B c, eta = E c; A c = dL_q xi / ||dL_q||."""

    Xo: np.ndarray
    B: np.ndarray
    E: np.ndarray | None
    A: np.ndarray


def split_basis(basis_x: np.ndarray, basis_u: np.ndarray, basis_eta: np.ndarray | None, dl_idx: Sequence[int], dl_blk: np.ndarray, dl_norm: float) -> SplitBasis:
    k = basis_x.shape[1]
    if k == 0:
        z = np.zeros((0, 0))
        return SplitBasis(np.zeros((basis_x.shape[0], 0)), np.zeros((basis_u.shape[0], 0)), None if basis_eta is None else np.zeros((basis_x.shape[0], 0)), z)
    Ux, Sx, Vxh = np.linalg.svd(basis_x, full_matrices=False)
    keep = Sx > 1e-300  # xi = 0 forces u0 = 0 (S_F^T is injective): X is injective on Z
    W = Vxh.conj().T[:, keep] / Sx[keep]
    Xo = Ux[:, keep]
    A = dl_blk @ Xo[list(dl_idx), :] / dl_norm if dl_norm > 0 else np.zeros((0, Xo.shape[1]), dtype=Xo.dtype)
    return SplitBasis(Xo, basis_u @ W, None if basis_eta is None else basis_eta @ W, A)


def _input_decisions(sv: np.ndarray, lam: complex, tol: Tolerance) -> list[Decision]:
    """||u0|| against ||[x0; u0]|| for unit xi (``stealthy.zda``'s rule)."""
    x2 = 1.0 + abs(lam) ** 2
    return [tol.decide(float(v), math.sqrt(x2 + float(v) ** 2)) for v in sv]


def avoiding_subspace(A: np.ndarray, B: np.ndarray, cut: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The touch test of ``switching.avoids-attack`` on a basis of the stealthy kernel (its one home).

    With xi = X c (X xi-orthonormal), u0 = B c and A c = dL_q xi / ||dL_q|| (a
    :class:`SplitBasis`), the directions that avoid the switch are those c whose touch
    ||A c|| is at most ``cut``: K spans the right singular vectors of A with singular values
    <= ``cut`` (the exact avoiding subspace when ``cut`` is 0 and A exact). Returns K and the
    singular values and right singular vectors (rows) of B K, the inputs an avoiding attacker
    has: every direction with an input is touched iff they vanish. The rule
    (:func:`numeric_mode_avoidance`, through :func:`decide_avoidance`) decides them with its
    tolerance; the safe-mode design's screen calls this function with its own threshold.

    Parameters
    ----------
    A : ndarray (rows x r)
    B : ndarray (m x r)
    cut : float
    """
    r = A.shape[1] if A.ndim == 2 else 0
    r = max(r, B.shape[1] if B.ndim == 2 else 0)
    if r == 0:
        return np.zeros((0, 0)), np.zeros(0), np.zeros((0, 0))
    sa, Va = _right_svd(A, r)
    K = Va[:, sa <= cut]
    if K.shape[1] == 0 or B.shape[0] == 0:
        return K, np.zeros(0), np.zeros((0, K.shape[1]))
    _, su, Vuh = np.linalg.svd(B @ K, full_matrices=False)
    return K, su, Vuh


def _avoiding(sp: SplitBasis, lam: complex, tol: Tolerance, cut: float) -> tuple[np.ndarray | None, int, bool]:
    """(best coefficient vector, certain u0-rank, some input not certainly zero) of the
    avoiding subspace {c : singular values of A <= cut} of ``sp`` (:func:`avoiding_subspace`)."""
    if sp.Xo.shape[1] == 0:
        return None, 0, False
    K, su, Vuh = avoiding_subspace(sp.A, sp.B, cut)
    if K.shape[1] == 0 or sp.B.shape[0] == 0:
        return None, 0, False
    dec = _input_decisions(su, lam, tol)
    dim = sum(1 for x in dec if x is Decision.NONZERO)
    some = any(x is not Decision.ZERO for x in dec)
    best = K @ Vuh[0].conj() if len(su) else None
    return best, dim, some


def _fails_margin(sp: SplitBasis, lam: complex, tol: Tolerance) -> float | None:
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


@dataclass(frozen=True, slots=True)
class DirectionTouch:
    """Does the switch to a mode touch one given direction xi? (:func:`direction_touch`)

    Attributes
    ----------
    decision : Decision
        ``NONZERO``: dL_q xi != 0 (touched); ``ZERO``: untouched; ``UNDECIDED`` within the tolerance band.
    ratio : float
        ||dL_q xi|| / (||dL_q||_2 ||xi||).
    agents : tuple of labels
        The rows of dL_q xi decided nonzero.
    """

    decision: Decision
    ratio: float
    agents: tuple[Label, ...]

    @property
    def touched(self) -> bool | None:
        """True: touched; False: untouched; None: undecided."""
        return None if self.decision is Decision.UNDECIDED else self.decision is Decision.NONZERO


def direction_touch(system: System, mode: str, xi: np.ndarray, tol: Tolerance = DEFAULT_TOLERANCE) -> DirectionTouch:
    """The rule's touch test of one direction: ||dL_q xi|| against ||dL_q||_2 ||xi|| with the tolerance.

    What :func:`numeric_mode_avoidance` decides for the chosen direction of ``stealthy.zda``;
    a simulated attack's direction (``switching.detects``, the case study) is judged by the
    same function.

    Parameters
    ----------
    system : System
    mode : str
        A safe mode q.
    xi : ndarray
        A direction (N entries, complex allowed).
    tol : Tolerance
    """
    dl_idx, dl_blk = delta_block(system, mode)
    d, ratio, rows = _touched(system, dl_idx, dl_blk, block_norm(dl_blk), np.asarray(xi), tol)
    return DirectionTouch(d, ratio, tuple(rows))


def _touched(system: System, dl_idx: Sequence[int], dl_blk: np.ndarray, dl_norm: float, xi: np.ndarray, tol: Tolerance) -> tuple[Decision, float, list[Label]]:
    """Decision on ||dL_q xi|| vs ||dL_q||_2 ||xi||, the ratio, and the nonzero rows."""
    dLxi = dl_blk @ xi[list(dl_idx)]
    nrm = dl_norm * float(np.linalg.norm(xi))
    val = float(np.linalg.norm(dLxi))
    rows = [system.labels[i] for i, v in zip(dl_idx, dLxi) if tol.decide(abs(v), nrm) is Decision.NONZERO]
    rows.sort(key=system.index.__getitem__)
    return tol.decide(val, nrm), (val / nrm if nrm > 0 else 0.0), rows


def numeric_mode_avoidance(system: System, mode: str, md: ModalPencil, z: ZdaZero, source: str, bases: tuple[StealthyBasis, StealthyBasis]) -> Avoidance:
    tol = md.tol
    lam = z.value
    chosen = z.direction()
    dl_idx, dl_blk = delta_block(system, mode)
    dl_norm = block_norm(dl_blk)
    dec_c, ratio_c, rows_c = _touched(system, dl_idx, dl_blk, dl_norm, chosen.xi, tol)
    chosen_touched = None if dec_c is Decision.UNDECIDED else dec_c is Decision.NONZERO
    zc, zp = bases
    sc = split_basis(zc.x, zc.u, zc.eta, dl_idx, dl_blk, dl_norm)
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
            xi_n, u_n = normalize_direction(xi, u2)
            d = ZdaDirection(lam, xi_n, u_n, np.concatenate([xi_n, lam * xi_n]), res)
            return Avoidance(
                status=Status.HOLDS, direction=d, direction_source="kernel of the stacked system", dimension=dim_c, margin=ratio, dl_residual=ratio, **common
            )
        notes.append(f"avoiding candidate failed verification (pencil residual {res:.3g}: {dres.value}, input {du.value}, dL_q xi {dd.value})")
    sp = split_basis(zp.x, zp.u, None, dl_idx, dl_blk, dl_norm)
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
    """Numeric decision of ``switching.avoids-attack`` for a ZDA at lambda0 and the switch to ``mode``.

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
    md = ModalPencil(system, za.actuators, tol)
    return numeric_mode_avoidance(system, mode, md, za.direction, za.direction_source, stealthy_bases(md, za.direction.value))


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


def exact_mode_avoidance(system: System, mode: str, d: ExactZdaZero, source: str, F: Sequence[int], tol: Tolerance) -> Avoidance:
    N, m = system.n, len(F)
    g = d.field
    dL = system.delta_laplacian_exact(mode)
    dl_idx, dl_blk = delta_block(system, mode)
    dl_norm = block_norm(dl_blk)
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
        tk = transfer_kernel(system, F, g, s_poly, system.idx(system.monitored), [dL[i] for i in dl_idx])
        Kf = tuple(tk[0]) if tk is not None else kernel_over_field(Q + dl_p, g, N + m).basis
        urows_f = [list(v[N:]) for v in Kf]
        dim = rank_over_field(urows_f, g, m) if urows_f else 0
        pick_f = next((v for v in Kf if any(not e.is_zero() for e in v[N:])), None)
        if pick_f is not None:
            avoid_dir = _exact_zero(system, g, pick_f, d.value, d.real_sign, True, 1, m).direction()

        def z_basis() -> list[np.ndarray]:
            tz = transfer_kernel(system, F, g, s_poly, system.idx(system.monitored))
            if tz is None:
                return kernel_over_field(Q, g, N + m).evaluate(d.value)
            enc = RootEnclosures(g)
            return [eval_at_root(v, g, d.value, enc) for v in tz[0]]

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
        if d.rational is not None and d.xi_field and d.u0_field:
            r = _fq(d.rational)
            vals = [ex.to_fraction(flint.fmpq_poly(p)(r)) for p in (*d.xi_field, *d.u0_field)]
            exact_xi, exact_u0 = _normalize_exact(vals, N)
        return Avoidance(
            status=Status.HOLDS, direction=chosen, direction_source="stealthy.zda", margin=0.0, dl_residual=0.0, exact_xi=exact_xi, exact_u0=exact_u0, **common
        )
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
    sp = split_basis(X[:N], X[N:], None, dl_idx, dl_blk, dl_norm)
    fm = _fails_margin(sp, d.value, tol)
    if fm is None:
        fm = _touched(system, dl_idx, dl_blk, dl_norm, chosen.xi, tol)[1]
    return Avoidance(status=Status.FAILS, direction=None, direction_source="", margin=fm, **common)


def avoidance_exact(system: System, mode: str, *, lambda0: complex | float | Sequence[float] | None = None, tol: Tolerance = DEFAULT_TOLERANCE) -> Avoidance | None:
    """Exact decision of ``switching.avoids-attack`` (rational weights and gains; never undecided).

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
    return exact_mode_avoidance(system, mode, ea.direction, ea.direction_source, system.idx(ea.actuators), tol)


def separator_avoidance(system: System, mode: str, F: Sequence[int], lam: complex) -> str | None:
    """Prove that a stealthy direction at lambda0 avoids the switch to ``mode``, from a separator of F and the monitors, or return None.

    Let X (|X| < |F|) separate F from M = M_x ∪ M_v in G_1 and R be the agents reached from
    F \\ X without meeting X. A vector xi supported on R is a stealthy direction at s =
    lambda0^2 + gamma lambda0 when the rows (R ∪ X) \\ F of (s I + alpha L_1) xi vanish (the
    other rows do, R having no neighbour outside R ∪ X) and S_M xi = 0 (M meets R nowhere):
    |R| unknowns, at most |R| - |F| + |X| < |R| equations, so such a nonzero xi exists. Its
    input u0 = S_F (s I + alpha L_1) xi is nonzero: u0 = 0 would make (s I + alpha L_1[R, R]) xi_R
    = 0, impossible for s not real and <= 0 (L_1[R, R] is positive semidefinite; s = 0 needs
    every part of G_1[R] to have a link leaving R, which makes it definite). When no switching
    link of the mode has an end in R, dL_q xi = 0: the switch is avoided (exact, combinatorial;
    a unit-capacity maximum flow for X).

    Parameters
    ----------
    system : System
    mode : str
    F : sequence of int
        The attacked agents (indices).
    lam : complex
        lambda0.

    Returns
    -------
    str or None
        The proof, one line.
    """
    s0 = lam * lam + system.gamma * lam
    M = system.idx(system.monitored)
    if len(set(F)) < 2 or not M or (s0.imag == 0 and s0.real < 0):
        return None
    def enclosed() -> tuple[frozenset[int], frozenset[int], bool] | None:
        """(X, R, every part of G_1[R] has a link to X), or None when no separator smaller than |F| exists.

        X is a minimum vertex cut (a unit-capacity maximum flow on the vertex-split graph, the
        agents left of the saturated arcs v_in -> v_out reached in the residual graph)."""
        import scipy.sparse
        from scipy.sparse.csgraph import breadth_first_order, connected_components, maximum_flow

        n = system.n
        L = system.laplacian_sparse(NORMAL_MODE).tocoo()
        off = L.row != L.col
        u, v = L.row[off].astype(np.int64), L.col[off].astype(np.int64)
        src, snk = 2 * n, 2 * n + 1
        Fs, Ms = sorted(set(F)), sorted(set(M))
        big = n + 1
        rows = np.concatenate([np.arange(n), n + u, np.full(len(Fs), src), n + np.asarray(Ms, dtype=np.int64)])
        cols = np.concatenate([n + np.arange(n), v, np.asarray(Fs, dtype=np.int64), np.full(len(Ms), snk)])
        caps = np.concatenate([np.ones(n), np.full(len(u), big), np.full(len(Fs), big), np.full(len(Ms), big)]).astype(np.int32)
        cap = scipy.sparse.csr_matrix((caps, (rows, cols)), shape=(2 * n + 2, 2 * n + 2))
        cap.sum_duplicates()
        res = maximum_flow(cap, src, snk)
        if res.flow_value >= len(Fs):
            return None
        resid = (cap - res.flow).tocsr()
        resid.data = (resid.data > 0).astype(np.int8)
        resid.eliminate_zeros()
        reached = np.zeros(2 * n + 2, dtype=bool)
        reached[breadth_first_order(resid, src, directed=True, return_predecessors=False)] = True
        X = {int(x) for x in np.flatnonzero(reached[:n] & ~reached[n : 2 * n])}
        keep = np.array([i not in X for i in range(n)])
        A = scipy.sparse.csr_matrix((np.ones(len(u)), (u, v)), shape=(n, n))
        sub = A[keep][:, keep]
        ids = np.flatnonzero(keep)
        _, lab = connected_components(sub, directed=False)
        comp_of = dict(zip(ids.tolist(), lab.tolist()))
        mine = {comp_of[f] for f in Fs if f not in X}
        R = {int(i) for i, c in comp_of.items() if c in mine}
        if R & set(Ms):  # pragma: no cover - X separates F from M
            return None
        # every part of G_1[R] (one per component reached from F) has a link to X
        tied = all(any(int(w) in X for i in R if comp_of[i] == c for w in A.indices[A.indptr[i] : A.indptr[i + 1]]) for c in mine)
        return frozenset(X), frozenset(R), tied

    sep = _ENCLOSED_KIND.get(system, (tuple(sorted(set(F))),), enclosed)
    if sep is None:
        return None
    X, R, tied = sep
    if s0 == 0 and not tied:
        return None
    links = system.switching_links(mode)
    if any(system.index[u] in R or system.index[v] in R for u, v, _ in links):
        return None
    return (
        f"{len(X)} agent(s) {sorted(system.labels[x] for x in X)} separate the {len(set(F))} attacked agents from the monitors: a stealthy "
        f"direction with an input lives on the {len(R)} agents they enclose, where no switching link of {mode} ends, so dL_q xi = 0 (exact, from the graph)"
    )


def avoidance_certificate(
    system: System,
    mode: str,
    F: Sequence[int],
    lam: complex,
    status: Status,
    exact_lambda: bool,
    candidate: np.ndarray | None = None,
    why_not_exact: str = "",
) -> tuple[bool, float | None, str]:
    """Certify a numeric verdict of ``switching.avoids-attack`` at lambda0 for the exact system.

    With s0 = lambda0^2 + gamma lambda0, Q = [[s0 I + alpha L_1, -S_F^T], [S_out, 0]] and
    K = [Q; [dL_q, 0]] (exact rows), ``holds`` (an avoiding stealthy direction) means ker K
    holds a vector with u0 != 0, ``fails`` means ker Q does and ker K does not. Both are decided
    by :func:`~glocal_verify.analysis.stealthy.zda_certificate.u_direction_certificate` (Weyl lower bounds with the
    SVD backward error and the rounding of the rational data against structural upper bounds
    of the exact support). Only a real lambda0 that is exactly the requested rational (the
    spec's ``attack.lambda0`` or the ``lambda0`` option, read as an exact binary rational)
    can be certified this way; the exponent of an irrational zero cannot. A ``holds`` is also
    proved by the avoiding direction ``candidate`` = (xi, u0) when it rationalises to an exact
    kernel vector of K with u0 != 0 (:func:`~glocal_verify.numerics.exact_subspace.rational_kernel_vector`).
    A ``holds`` is first tried by :func:`separator_avoidance` (combinatorial, at every N).
    Returns (certified, error bound, note saying which bound failed or, when certified by the
    separator, the proof).

    Parameters
    ----------
    system : System
    mode : str
        The safe mode q.
    F : sequence of int
        Attacked agents (indices).
    lam : complex
        lambda0.
    status : Status
        The numeric verdict to certify (``HOLDS`` or ``FAILS``).
    exact_lambda : bool
        lambda0 is the requested exact value (not a computed zero).
    candidate : ndarray, optional
        The avoiding direction [xi; u0] of a numeric ``holds``.
    why_not_exact : str
        Why a computed lambda0 = 0 is not proven to be the rule's choice (the note of
        :func:`~glocal_verify.analysis.stealthy.zda_completeness.zero_set_completeness`), quoted in the note.
    """
    if not exact_lambda or lam.imag != 0:
        # a computed lambda0 is the fastest-growing zero found numerically: neither the zero nor
        # the choice (no faster zero was missed) has a floating-point proof
        if not exact_lambda and lam == 0:
            why = f" ({why_not_exact})" if why_not_exact else ""
            return False, None, (
                f"lambda0 = 0 was chosen as the fastest-growing zero of a numeric zero set that is not certified complete{why} "
                "(a faster zero may have been missed); give attack.lambda0 = 0 in the spec to certify the verdict at 0"
            )
        return False, None, (
            f"lambda0 = {lam:.6g} is a computed (irrational or complex) zero chosen as the fastest-growing one: "
            "neither its kernel nor the completeness of the zero set has a floating-point certificate"
        )
    if status is Status.HOLDS and (sep := separator_avoidance(system, mode, F, lam)) is not None:
        return True, None, sep
    if system.n > config.get("avoidance_dense_max_agents"):
        return False, None, (
            f"the certified rank bounds of [Q; dL_q] at lambda0 need SVDs of {system.n}-sized exact matrices, "
            f"not run above avoidance_dense_max_agents = {config.get('avoidance_dense_max_agents')} agents"
        )
    q = Fraction(lam.real)
    s0 = q * q + system.gamma_q * q
    out = system.idx(system.monitored_positions) if q == 0 else system.idx(system.monitored)
    N, m = system.n, len(F)
    dL = [row for row in system.delta_laplacian_exact(mode) if any(x != 0 for x in row)]
    rowsK, patK = exact_q_rows(system, F, out, s0, dL)
    k_dir, bk = u_direction_certificate(rowsK, patK, N, m)
    if status is Status.HOLDS:
        if k_dir is True:
            return True, bk, ""
        if candidate is not None:
            qv = rational_kernel_vector(rowsK, candidate)
            if qv is not None and any(x != 0 for x in qv[N:]):
                return True, None, ""
        return False, bk, f"the rank bounds of [Q; dL_q] at lambda0 (error bound {bk:.3g}) do not prove an avoiding direction with u0 != 0"
    rowsQ, patQ = exact_q_rows(system, F, out, s0)
    q_dir, bq = u_direction_certificate(rowsQ, patQ, N, m)
    bound = max(bk, bq)
    if q_dir is True and k_dir is False:
        return True, bound, ""
    return False, bound, (
        f"rank bounds (error bound {bound:.3g}): a stealthy direction at lambda0 is {'certain' if q_dir else 'not certain'}, "
        f"its absence from ker [Q; dL_q] is {'certain' if k_dir is False else 'not certain'}"
    )



# ------------------------------------------------------------------------------------------
# the rule of switching.avoids-attack (ZDA), for verify and the audit alike


@dataclass(frozen=True, slots=True)
class AvoidanceVerdict:
    """``switching.avoids-attack`` of one safe mode for a ZDA: the status and what proves it.

    Attributes
    ----------
    mode : str
    status : Status
        ``HOLDS``: some stealthy direction at lambda0 is untouched by the switch (the attack
        survives it); ``FAILS``: every one is touched; ``UNDECIDED``.
    avoidance : Avoidance or None
        The touch analysis (None when vacuous or when the ZDA status is undecided).
    premise : str or None
        Set when no stealthy ZDA exists: the verdict holds vacuously (nothing to avoid).
    exact : bool
        Decided over Q (the exact analysis, or the touch test at lambda0 = 0 over Q).
    certificate : mapping
        For a numeric analysis: ``certified``, ``error_bound``, ``by`` and ``note`` of
        :func:`avoidance_certificate`.
    note : str
        Why the verdict is undecided, or how it was decided.
    """

    mode: str
    status: Status
    avoidance: Avoidance | None
    premise: str | None = None
    exact: bool = False
    certificate: Mapping[str, Any] = field(default_factory=dict)
    note: str = ""

    @property
    def touches(self) -> bool | None:
        """True: every stealthy direction is touched; False: one avoids the switch (or none exists); None: undecided."""
        return None if self.status is Status.UNDECIDED else self.status is Status.FAILS


#: the attack's ZDA does not exist: the premise of the touch question is absent
NO_ZDA_PREMISE = "no stealthy ZDA exists for this attack (stealthy.zda fails): there is nothing for the switch to touch or avoid"


def _certify_numeric(system: System, F: Sequence[Label], av: Avoidance, exact_lambda: bool, why_not_exact: str = "") -> tuple[Avoidance, dict[str, Any]]:
    """The numeric ``av`` if :func:`avoidance_certificate` proves it for the exact system, else ``undecided``."""
    if av.status is Status.UNDECIDED:
        return av, {"certified": False, "error_bound": None, "note": "; ".join(av.notes) or "a rank decision fell in the tolerance band"}
    cand = None if av.direction is None else np.concatenate([av.direction.xi, av.direction.u0])
    ok, bound, note = avoidance_certificate(system, av.mode, system.idx(F), av.lambda0, av.status, exact_lambda, cand, why_not_exact)
    cert: dict[str, Any] = {"certified": ok, "error_bound": bound, "note": "" if ok else f"numeric {av.status.value} not certified: {note}"}
    if ok:
        cert["by"] = note or (
            "the avoiding direction rationalises to an exact kernel vector (checked over Q)"
            if bound is None
            else "Weyl lower bounds (SVD backward error and data rounding) against structural rank upper bounds at lambda0"
        )
        return av, cert
    return dataclasses.replace(av, status=Status.UNDECIDED, notes=(*av.notes, cert["note"])), cert


def decide_avoidance(
    system: System,
    mode: str,
    zda: Any,
    *,
    tol: Tolerance = DEFAULT_TOLERANCE,
    fallback: bool = False,
    memo: MutableMapping[Any, Any] | None = None,
    zero_first: bool = False,
) -> AvoidanceVerdict:
    """Decide ``switching.avoids-attack`` of ``mode`` for the ZDA verdict ``zda`` (the rule).

    The question concerns the witness exponent lambda0 of ``stealthy.zda``
    (:class:`~glocal_verify.analysis.stealthy.zda_verdict.ZdaVerdict`): no stealthy ZDA, ``holds``
    vacuously; an undecided ZDA status, ``undecided``. Otherwise, in order:

    1. the exact analysis (when ``zda`` is exact): the kernel of the stacked system over Q or
       the number field of lambda0 (:func:`exact_mode_avoidance`);
    2. the numeric touch test (:func:`numeric_mode_avoidance`), which counts only where
       :func:`avoidance_certificate` proves it at an exact lambda0 (``zda.lambda0_exact``:
       the requested exponent, a certified zero set -- for a computed lambda0 = 0, the
       completeness proof of :func:`~glocal_verify.analysis.stealthy.zda_completeness.zero_set_completeness`
       --, or lambda0 = 1 of a system proved not left-invertible);
    3. at an exact lambda0 = 0 (no monitored position, G_1 connected, |F| >= 2), the touch
       test over Q from the attack's potentials (:func:`~glocal_verify.analysis.switching.zero_touch.touch_at_zero`:
       a sparse modular solve, no N-sized dense work; above ``avoidance_dense_max_agents``
       step 2 is not certified and this step decides); at a computed lambda0 = 0 its answer
       is only a note;
    4. ``fallback``: an undecided verdict is re-decided from the exact ZDA analysis.

    Parameters
    ----------
    system : System
    mode : str
        A safe mode q.
    zda : ZdaVerdict
        The verdict of :func:`~glocal_verify.analysis.stealthy.zda_verdict.decide_zda` for the attack.
    tol : Tolerance
    fallback : bool
        Re-decide an undecided numeric verdict over Q.
    memo : mutable mapping, optional
        Shares the modal pencil and the stealthy bases between the modes of one attack set.
    zero_first : bool
        Many attack sets share the system (an audit): step 3 comes before step 2 (cheaper per
        set; the same status, both being proofs) and solves for the potentials with one
        inverse of the grounded Laplacian modulo a prime shared by every set.

    Returns
    -------
    AvoidanceVerdict
    """
    F = tuple(zda.actuators)
    if zda.status is Status.FAILS:
        return AvoidanceVerdict(mode, Status.HOLDS, None, premise=NO_ZDA_PREMISE, exact=zda.method == "exact")
    if zda.status is Status.UNDECIDED or zda.direction is None:
        why = "whether a stealthy ZDA exists is undecided (stealthy.zda)" if zda.status is Status.UNDECIDED else "stealthy.zda has no witness direction"
        return AvoidanceVerdict(mode, Status.UNDECIDED, None, note=why)
    Fi = system.idx(F)
    if zda.exact_analysis is not None:
        d_ex = zda.exact_analysis.direction
        assert d_ex is not None
        return AvoidanceVerdict(mode, (av := exact_mode_avoidance(system, mode, d_ex, zda.direction_source, Fi, tol)).status, av, exact=True)
    store: MutableMapping[Any, Any] = memo if memo is not None else {}
    d = zda.direction
    exact_lambda = bool(zda.lambda0_exact)

    def at_zero() -> AvoidanceVerdict | None:
        if exact_lambda and complex(d.value) == 0 and (av0 := touch_at_zero(system, mode, d, zda.direction_source, Fi, many=zero_first)) is not None:
            if av0.chosen_touched is None:  # several inputs: whether the chosen direction itself is touched, by the rule's direction test
                dt = direction_touch(system, mode, d.xi, tol)
                av0 = dataclasses.replace(av0, chosen_touched=dt.touched, chosen_touched_agents=dt.agents)
            return AvoidanceVerdict(mode, av0.status, av0, exact=True, certificate={"certified": True, "error_bound": None, "by": av0.notes[-1], "note": ""})
        return None

    if zero_first and (v0 := at_zero()) is not None:
        return v0
    key = ("avoidance-bases", F, complex(d.value))
    if key not in store:
        md = ModalPencil(system, F, tol)
        store[key] = (md, stealthy_bases(md, d.value))  # Z does not depend on the mode
    md, bases = store[key]
    why = zda.completeness.text if zda.completeness is not None and not zda.completeness.complete else ""
    av, cert = _certify_numeric(system, F, numeric_mode_avoidance(system, mode, md, d, zda.direction_source, bases), exact_lambda, why)
    if av.status is not Status.UNDECIDED:
        return AvoidanceVerdict(mode, av.status, av, certificate=cert)
    if not zero_first and (v0 := at_zero()) is not None:
        return v0
    if fallback:
        ea = store.get(("exact-zda", F))
        if ea is None:
            ea = store[("exact-zda", F)] = zda_analysis_exact(system, F, lambda0=zda.direction.value if zda.direction_source == "requested lambda0" else None)
        if ea.direction is not None:
            ex_av = exact_mode_avoidance(system, mode, ea.direction, ea.direction_source, Fi, tol)
            return AvoidanceVerdict(mode, ex_av.status, ex_av, exact=True, note=f"escalated to exact arithmetic: {cert.get('note', '')}")
    if complex(d.value) == 0 and system.n <= config.get("zero_touch_note_agents") and (ex0 := touch_at_zero(system, mode, d, zda.direction_source, Fi)) is not None:
        # the exponent itself is a computed fastest zero: say what Q says at 0, stay undecided
        what = "avoids the attack" if ex0.status is Status.HOLDS else "touches every stealthy direction"
        cert = {**cert, "note": f"{cert.get('note', '')}; over Q the switch {what} at lambda0 = 0 (attack.lambda0 = 0 in the spec makes this the verdict)"}
    return AvoidanceVerdict(mode, Status.UNDECIDED, av, certificate=cert, note=str(cert.get("note", "")))
