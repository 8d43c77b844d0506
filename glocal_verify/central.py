"""The centralised observer of eq. ``obs_cent`` and the ``central.observer`` check.

The paper asks for one gain H with ``A_sigma - H C`` Hurwitz in every mode. When Lemma III.1's
privacy holds, ``[1; 0]`` lies in ``ker C`` and ``A_q [1; 0] = 0``, so ``(A_q - H C)[1; 0] = 0`` for
every H: 0 is an eigenvalue in every mode and the requirement is infeasible (a
:class:`~glocal_verify.results.Finding`). What can be designed is a gain that makes
``A_1 - H C`` stable on the observable part, leaving the unobservable eigenvalues fixed.

Design in modal coordinates (scalable)
--------------------------------------
The state space splits orthogonally, per eigen-group ``E_mu`` of L_1, into the A_1-invariant
spaces ``E_mu (x) R^2``; inside each, the unobservable part ``N_mu`` (``W_mu x W_mu``, or
``W^x_0 x W_0`` for ``mu = 0``) and its orthogonal complement ``O_mu`` (the observable part of
the group). In the orthonormal basis ``[O_s, O_f, N]`` -- designed groups, the other observable
groups, the unobservable subspace -- and with a gain ``H = O_s H_s`` that injects only into the
designed groups,

.. math::

    T^\\top (A_1 - H C) T = \\begin{bmatrix} A_s - H_s C_s & -H_s C_f & 0 \\\\
                                          0 & A_f & 0 \\\\
                                          * & * & A_u \\end{bmatrix},

so the spectrum is ``eig(A_s - H_s C_s) ∪ eig(A_f) ∪ eig(A_u)``. ``A_f`` is stable whenever it
holds no ``mu = 0`` part (``Re lam < 0`` for ``mu > 0``, ``alpha, gamma > 0``), so only the
slowest groups -- and the ``mu = 0`` group, whose observable part carries the eigenvalues 0 and
``-gamma`` -- need a gain. The designed block has at most ``max_design`` states (default 100:
the whole observable part of systems up to about 50 agents).

The gain of the designed block is by default the steady-state Kalman-Bucy gain
``H_s = P C_s^T`` with ``A_s P + P A_s^T - P C_s^T C_s P + I = 0`` (unit process and measurement
noise intensities; ``scipy.linalg.solve_continuous_are``): it exists whenever
``(A_s, C_s)`` is detectable (it is observable by construction), never places poles with
arbitrary accuracy demands, and keeps the gain moderate, whereas pole placement with few
outputs on a large block is severely ill-conditioned. Given ``poles``, the block is chosen to
have exactly ``len(poles)`` states and ``scipy.signal.place_poles`` places them.

Complexity: the cached ``eigh`` of L_1 (O(N^3)), O(N k^2) per eigen-group, O(N n_s p) for
``H`` and O(n_s^3) for the Riccati equation; no 2N x 2N matrix is formed. 2000 agents with 10
monitors take a few seconds, dominated by ``eigh``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from fractions import Fraction
from typing import Any, Sequence

import flint
import numpy as np
import scipy.linalg
import scipy.signal

from .linalg import DEFAULT_TOLERANCE, Decision, Tolerance
from .model import System
from .observability import (
    EigenGroupPart,
    Subspace,
    _exact_A,
    _exact_C,
    _exact_N,
    modal_decomposition,
    unobservable_subspace,
)
from .registry import CheckContext, checker, finding_rule, result
from .results import ConditionResult, Finding, Status
from .spec import NORMAL_MODE

__all__ = [
    "CentralObserver",
    "design_central_observer",
    "check_central_observer",
    "hurwitz_infeasible_finding",
    "routh_hurwitz",
]

DEFAULT_MAX_DESIGN = 100


@dataclass(frozen=True, slots=True)
class CentralObserver:
    """A centralised observer gain for the normal mode and its spectrum.

    Attributes
    ----------
    H : ndarray
        ``2N x p`` gain (p = number of rows of C).
    eigenvalues : ndarray
        All 2N eigenvalues of ``A_1 - H C`` (from the block-triangular modal form).
    fixed_eigenvalues : ndarray
        Eigenvalues of A_1 on the unobservable subspace: no H moves them.
    observable_eigenvalues : ndarray
        Eigenvalues of ``A_1 - H C`` on the observable part (``eigenvalues`` minus the fixed ones).
    stability_margin : float
        ``-max Re`` of ``observable_eigenvalues`` (``inf`` when the observable part is empty).
    designed_states : int
        Size ``n_s`` of the block that received a gain.
    observable_states : int
        Dimension of the observable part (2N - dim N).
    method : str
        ``"riccati"``, ``"place_poles"`` or ``"none"`` (no output or nothing to design).
    unobservable : Subspace
        The unobservable subspace of ``(A_1, C)`` used for the decomposition.
    mode : str
        The mode the observer is designed for (the normal mode by default).
    """

    H: np.ndarray
    eigenvalues: np.ndarray
    fixed_eigenvalues: np.ndarray
    observable_eigenvalues: np.ndarray
    stability_margin: float
    designed_states: int
    observable_states: int
    method: str
    unobservable: Subspace
    mode: str = NORMAL_MODE


@dataclass(frozen=True, slots=True)
class _Block:
    basis: np.ndarray  # 2N x d orthonormal (observable complement of one group)
    A: np.ndarray  # d x d compression of A_1
    C: np.ndarray  # p x d
    fixed: np.ndarray  # eigenvalues of A on the group's unobservable part
    rate: float  # decay rate of the group's observable part (-max Re eig(A))
    zero: bool


def _complement(E: np.ndarray, W: np.ndarray) -> np.ndarray:
    """Orthonormal basis of E ⊖ span(W) (W inside span(E), both orthonormal)."""
    k = E.shape[1]
    r = W.shape[1]
    if r == 0:
        return E
    if r == k:
        return E[:, :0]
    G = E.T @ W  # k x r coordinates of W in E
    Q, _ = np.linalg.qr(G, mode="complete")
    return E @ Q[:, r:]


def _lam(mu: float, alpha: float, gamma: float) -> tuple[complex, complex]:
    d = gamma * gamma - 4.0 * alpha * mu
    if d >= 0:
        r = math.sqrt(d)
        # stable formula for the root near 0
        lp = -2.0 * alpha * mu / (gamma + r) if (gamma + r) > 0 else 0.0
        lm = (-gamma - r) / 2.0
        return complex(lp), complex(lm)
    r = math.sqrt(-d)
    return complex(-gamma / 2.0, r / 2.0), complex(-gamma / 2.0, -r / 2.0)


def _blocks(system: System, mode: str, tol: Tolerance, C: np.ndarray) -> list[_Block]:
    md = modal_decomposition(system, mode, tol)
    n = system.n
    a, g = system.alpha, system.gamma
    out = []
    for grp in md.groups:
        out.append(_group_block(grp, n, a, g, C))
    return out


def _group_block(grp: EigenGroupPart, n: int, a: float, g: float, C: np.ndarray) -> _Block:
    mu = grp.value
    if grp.zero is Decision.ZERO:
        Qx = _complement(grp.E, grp.Wx)
        Qv = _complement(grp.E, grp.W)
        dx, dv = Qx.shape[1], Qv.shape[1]
        basis = np.zeros((2 * n, dx + dv))
        basis[:n, :dx] = Qx
        basis[n:, dx:] = Qv
        A = np.zeros((dx + dv, dx + dv))
        A[:dx, dx:] = Qx.T @ Qv
        A[dx:, dx:] = -g * np.eye(dv)
        fixed = np.array([0.0] * grp.Wx.shape[1] + [-g] * grp.W.shape[1], dtype=complex)
        rate = 0.0 if dx else (g if dv else math.inf)
        return _Block(basis, A, C @ basis, fixed, rate, True)
    Q = _complement(grp.E, grp.W)
    d = Q.shape[1]
    basis = np.zeros((2 * n, 2 * d))
    basis[:n, :d] = Q
    basis[n:, d:] = Q
    A = np.zeros((2 * d, 2 * d))
    A[:d, d:] = np.eye(d)
    A[d:, :d] = -a * mu * np.eye(d)
    A[d:, d:] = -g * np.eye(d)
    lp, lm = _lam(mu, a, g)
    r = grp.W.shape[1]
    fixed = np.array([lp] * r + [lm] * r, dtype=complex)
    rate = -max(lp.real, lm.real) if d else math.inf
    return _Block(basis, A, C @ basis, fixed, rate, False)


def design_central_observer(
    system: System,
    poles: Sequence[complex] | None = None,
    tol: Tolerance = DEFAULT_TOLERANCE,
    *,
    mode: str = NORMAL_MODE,
    max_design: int = DEFAULT_MAX_DESIGN,
) -> CentralObserver:
    """Gain H of the centralised observer (eq. ``obs_cent``) for ``A_1``, stable on the observable part.

    See the module docstring for the modal decomposition. The designed block holds the
    observable part of the ``mu = 0`` group (which contains the eigenvalue 0 when a position is
    monitored and ``-gamma``) and then the observable parts of the slowest groups (smallest
    decay rate ``-Re lam_+(mu)``), whole groups only, up to ``max_design`` states.

    Parameters
    ----------
    system : System
        The multi-agent system.
    poles : sequence of complex, optional
        Desired observer poles for the designed block (closed under conjugation). The block is
        then the smallest prefix of groups, in the order above, with exactly ``len(poles)``
        states (``ValueError`` naming the admissible sizes if there is none) and
        ``scipy.signal.place_poles`` places them. Default: the Riccati (Kalman-Bucy) gain with
        unit noise intensities.
    tol : Tolerance
        Tolerance of the modal decomposition (:func:`~glocal_verify.observability.unobservable_subspace`).
    mode : str
        The mode the observer is built for (the paper: the normal mode).
    max_design : int
        Largest designed block for the Riccati design.

    Returns
    -------
    CentralObserver
    """
    C = system.C()
    p = C.shape[0]
    n = system.n
    blocks = _blocks(system, mode, tol, C)
    N = unobservable_subspace(system, mode, tol)
    a, g = system.alpha, system.gamma
    obs = [b for b in blocks if b.A.shape[0] > 0]
    obs.sort(key=lambda b: (not b.zero, b.rate))
    fixed = np.concatenate([b.fixed for b in blocks]) if blocks else np.zeros(0, dtype=complex)
    n_obs = sum(b.A.shape[0] for b in obs)
    if poles is not None:
        want = len(poles)
        sizes = np.cumsum([b.A.shape[0] for b in obs]).tolist()
        if want not in sizes:
            raise ValueError(
                f"poles: the observable part splits into blocks of cumulative sizes {sizes[:12]}"
                f"{' ...' if len(sizes) > 12 else ''}; give a number of poles equal to one of them"
            )
        k = sizes.index(want) + 1
    else:
        k = 0
        total = 0
        for b in obs:
            if b.zero or total + b.A.shape[0] <= max_design:
                total += b.A.shape[0]
                k += 1
            else:
                break
    design = obs[:k] if p else []
    rest = obs[k:] if p else obs
    H = np.zeros((2 * n, p))
    method = "none"
    if design:
        As = scipy.linalg.block_diag(*[b.A for b in design])
        Cs = np.hstack([b.C for b in design])
        Os = np.hstack([b.basis for b in design])
        if poles is not None:
            res = scipy.signal.place_poles(As.T, Cs.T, np.asarray(poles))
            Hs = np.asarray(res.gain_matrix).T
            method = "place_poles"
        else:
            P = scipy.linalg.solve_continuous_are(As.T, Cs.T, np.eye(As.shape[0]), np.eye(p))
            Hs = P @ Cs.T
            method = "riccati"
        H = Os @ Hs
        eig_s = np.linalg.eigvals(As - Hs @ Cs).astype(complex)
    else:
        eig_s = np.zeros(0, dtype=complex)
    eig_f = [np.linalg.eigvals(b.A).astype(complex) for b in rest]
    obs_eigs = np.concatenate([eig_s, *eig_f]) if (len(eig_s) or eig_f) else np.zeros(0, dtype=complex)
    margin = -float(np.max(obs_eigs.real)) if len(obs_eigs) else math.inf
    eigs = np.concatenate([obs_eigs, fixed])
    H.setflags(write=False)
    return CentralObserver(
        H=H,
        eigenvalues=eigs,
        fixed_eigenvalues=fixed,
        observable_eigenvalues=obs_eigs,
        stability_margin=margin,
        designed_states=int(sum(b.A.shape[0] for b in design)),
        observable_states=int(n_obs),
        method=method,
        unobservable=N,
        mode=mode,
    )


# --------------------------------------------------------------------------------------------
# exact verification of a designed gain


def routh_hurwitz(coeffs: Sequence[Fraction]) -> bool:
    """Exact Routh-Hurwitz test: are all roots of the real polynomial in the open left half-plane?

    ``coeffs`` are rational, highest degree first. A polynomial is Hurwitz iff every entry of
    the first column of its Routh array is nonzero and has the sign of the leading coefficient;
    a zero entry already implies a root with ``Re >= 0``, so no epsilon trick is needed.

    Parameters
    ----------
    coeffs : sequence of Fraction
        Coefficients ``a_n, ..., a_0`` with ``a_n != 0``.
    """
    c = [Fraction(x) for x in coeffs]
    while c and c[0] == 0:
        c.pop(0)
    if not c:
        return False
    if len(c) == 1:
        return True
    sign = 1 if c[0] > 0 else -1
    c = [sign * x for x in c]
    if any(x <= 0 for x in c):
        return False
    r0 = c[0::2]
    r1 = c[1::2]
    while r1:
        if r1[0] <= 0:
            return False
        r1p = r1 + [Fraction(0)] * (len(r0) - len(r1))
        nxt = [(r1p[0] * r0[j + 1] - r0[0] * r1p[j + 1]) / r1p[0] for j in range(len(r0) - 1)]
        r0, r1 = r1, nxt
        while r1 and len(r1) > 1 and r1[-1] == 0:
            r1.pop()
        if r1 and all(x == 0 for x in r1):
            return False
    return r0[0] > 0


def _exact_observable_hurwitz(system: System, obsv: CentralObserver) -> tuple[bool, str]:
    """Exactly: is the observable part of A_1 - H C Hurwitz, for H rounded to its binary rationals?"""
    n2 = 2 * system.n
    A = _exact_A(system, obsv.mode)
    C = _exact_C(system)
    p = C.nrows()
    Hq = flint.fmpq_mat(n2, p, [flint.fmpq(*Fraction(float(x)).as_integer_ratio()) for x in obsv.H.ravel()])
    M = A - Hq * C if p else A
    chi = M.charpoly()
    X = _exact_N(system, obsv.mode)
    if X.ncols():
        # A X = X B: B = (X^T X)^{-1} X^T A X, the restriction of A (= A - HC) to N
        XT = X.transpose()
        B = (XT * X).inv() * (XT * A * X)
        chi_u = B.charpoly()
        q, r = divmod(chi, chi_u)
        if not r.is_zero():
            return False, "internal: the unobservable characteristic polynomial does not divide"
    else:
        q = chi
    coeffs = [Fraction(int(x.p), int(x.q)) for x in reversed(q.coeffs())]
    ok = routh_hurwitz(coeffs)
    return ok, f"observable characteristic polynomial of degree {q.degree()} {'is' if ok else 'is not'} Hurwitz (Routh)"


# --------------------------------------------------------------------------------------------
# checker and finding


def _cplx(z: complex) -> list[float] | float:
    z = complex(z)
    return float(z.real) if z.imag == 0 else [float(z.real), float(z.imag)]


@checker("central.observer")
def check_central_observer(system: System, ctx: CheckContext) -> list[ConditionResult]:
    """Centralised observer (eq. ``obs_cent``): ``A_1 - H C`` is stable on the observable part.

    .. math:: \\max \\operatorname{Re} \\lambda\\big((A_1 - H C)|_{\\mathbb R^{2N} / \\mathcal N(A_1, C)}\\big) < 0

    with H from :func:`design_central_observer` (Riccati gain; ``options["central_poles"]`` for
    pole placement). The fixed eigenvalues (A_1 on the unobservable subspace) are reported,
    not judged. Scope: global (the gain is designed for the normal mode).

    Numeric: ``m = max Re`` of the observable eigenvalues; holds iff ``m < 0`` and
    ``|m| > rtol * band * ||A_1||_2``, fails iff ``m >= 0`` or ``|m| <= rtol * ||A_1||_2``
    (not stable by a margin), undecided in between (``||A_1||_2`` is the largest norm of the
    2 x 2 modal blocks) or when the unobservable subspace itself is undecided (then the split
    into observable and fixed eigenvalues is). Exact: the gain is rounded to its binary rationals; the characteristic
    polynomial of ``A_1 - H C`` over Q divided by that of A_1 on the rational unobservable
    subspace is tested with the exact Routh-Hurwitz criterion (:func:`routh_hurwitz`).

    Margin
        The stability margin ``-max Re`` on the observable part (floating point).
    Witness
        ``design`` (method, designed and observable states, ``||H||``), the slowest observable
        eigenvalues, the fixed eigenvalues, and per mode ``||(A_q - H C)[1; 0]||`` when
        ``[1; 0] in ker C`` (a zero in every mode: see the finding).
    """
    poles = ctx.options.get("central_poles")
    obsv = design_central_observer(system, poles=poles, tol=ctx.tol)
    n = system.n
    w, _ = system.eigh(obsv.mode)
    scale = max(
        (float(np.linalg.norm([[0.0, 1.0], [-system.alpha * mu, -system.gamma]], 2)) for mu in (w[0], w[-1])),
        default=1.0,
    )
    order = np.argsort(-obsv.observable_eigenvalues.real)
    slow = [_cplx(z) for z in obsv.observable_eigenvalues[order][:6]]
    witness: dict[str, Any] = {
        "design": {
            "method": obsv.method,
            "designed_states": obsv.designed_states,
            "observable_states": obsv.observable_states,
            "unobservable_states": obsv.unobservable.dim,
            "gain_norm": float(np.linalg.norm(obsv.H, 2)) if obsv.H.size else 0.0,
        },
        "slowest_observable_eigenvalues": slow,
        "fixed_eigenvalues": [_cplx(z) for z in obsv.fixed_eigenvalues[:12]],
        "fixed_count": int(len(obsv.fixed_eigenvalues)),
    }
    if not system.monitored_positions:
        e = np.zeros(2 * n)
        e[:n] = 1.0 / math.sqrt(n)
        He = obsv.H @ (system.C() @ e)
        witness["consensus_null_residual"] = {
            q: float(np.linalg.norm(np.concatenate([He[:n], -system.alpha * (system.laplacian(q) @ e[:n]) - He[n:]])))
            for q in system.modes
        }
    m = -obsv.stability_margin if math.isfinite(obsv.stability_margin) else -math.inf
    if ctx.exact:
        ok, why = _exact_observable_hurwitz(system, obsv)
        status = Status.HOLDS if ok else Status.FAILS
        witness["exact"] = why
    elif not math.isfinite(m):
        status = Status.HOLDS
        witness["note"] = "the observable part is empty"
    else:
        d = ctx.tol.decide(m, scale)
        if d is Decision.NONZERO:
            status = Status.HOLDS if m < 0 else Status.FAILS
        elif d is Decision.ZERO:
            status = Status.FAILS
        else:
            status = Status.UNDECIDED
        if not obsv.unobservable.decided and status is Status.HOLDS:
            # the split into observable and fixed eigenvalues is itself undecided
            status = Status.UNDECIDED
            witness["note"] = "the unobservable subspace of (A_1, C) is undecided at this tolerance"
    return [result("central.observer", ctx, status, margin=obsv.stability_margin, witness=witness)]


@finding_rule
def hurwitz_infeasible_finding(system: System, results: Sequence[ConditionResult]) -> list[Finding]:
    """eq. ``obs_cent``: "A_sigma - H C Hurwitz in all modes" is infeasible when privacy holds.

    With ``M_x`` empty, ``C [1; 0] = 0`` and ``A_q [1; 0] = [0; -alpha L_q 1] = 0``, so
    ``(A_q - H C)[1; 0] = 0`` for every H and every mode q: 0 is always an eigenvalue. The rule
    fires when ``central.observer`` was checked on such a system; its data are the per-mode norms
    ``||A_q [1; 0]||`` (exactly 0: Laplacian rows sum to zero).
    """
    if not any(r.id == "central.observer" for r in results) or system.monitored_positions:
        return []
    n = system.n
    e = np.ones(n) / math.sqrt(n)
    data = {q: float(np.linalg.norm(system.alpha * (system.laplacian(q) @ e))) for q in system.modes}
    return [
        Finding(
            "central.hurwitz-infeasible",
            "No observer gain makes A_sigma - H C Hurwitz when Lemma III.1's privacy holds",
            "The paper asks an LMI for a constant H with (A_sigma - H C) Hurwitz in all modes. With no position "
            "monitored, [1; 0] is in ker C and A_q [1; 0] = 0, so (A_q - H C)[1; 0] = 0 for every H: 0 is an "
            "eigenvalue in every mode. The toolkit designs H stable on the observable part and reports the fixed "
            "eigenvalues. Minimal example: two agents, one edge, agent 2's velocity monitored.",
            "eq. obs_cent with Lemma III.1",
            {"A_q_times_consensus_norm": data, "C_times_consensus": 0},
        )
    ]
