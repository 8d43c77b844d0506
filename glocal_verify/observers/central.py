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

Injection design (large observable parts, provably stable)
----------------------------------------------------------
Above ``central_certify_max_states`` observable states (:mod:`glocal_verify.config`), where no
dense certificate of a Riccati gain is affordable, the default design is the *stiffness
injection* ``H = [0; k S_{M_x}^T]`` on the position rows of C (``k = alpha``) and 0 on the
velocity rows, so that

.. math:: A_1 - H C = \\begin{bmatrix} 0 & I \\\\ -K & -\\gamma I \\end{bmatrix},
          \\qquad K = \\alpha L_1 + k S_{M_x}^\\top S_{M_x} \\succeq 0 .

Its stability on the observable part is a theorem, not a floating-point claim: an eigenvalue
lam with eigenvector ``[x; lam x]`` (``|x| = 1``) solves ``lam^2 + gamma lam + x^* K x = 0``, so
``Re lam < 0`` unless ``K x = 0``, and then lam = 0 (or ``-gamma``); the eigenvectors of 0 are
``[x; 0]`` with ``x in ker K = ker L_1 ∩ ker S_{M_x}``, which lie in ker C and are
A_1-invariant (unobservable), and 0 has no Jordan chain (``(A_1 - H C)[y; w] = [x; 0]`` forces
``gamma x = -K y``, hence ``gamma |x|^2 = -x^T K y = 0``). So every eigenvalue of the
observable quotient has ``Re < 0``, for every symmetric ``L_1 >= 0`` and ``alpha, gamma, k > 0``
(the float ``k`` is an exact binary rational > 0). Its eigenvalues are the roots of
``lam^2 + gamma lam + kappa`` over the eigenvalues kappa of K (one N-sized ``eigh``, or none
without position monitor: then ``H = 0`` and K = alpha L_1, whose spectrum is the cached
one). The convergence is the network's own on its slowest modes: slower than a Riccati gain,
but certain at any size.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import scipy.linalg

from glocal_verify import config
from glocal_verify.analysis.unobservable.modal import EigenGroupPart, form_bases, modal_decomposition
from glocal_verify.analysis.unobservable.subspace import (
    certified_unobservable,
    unobservable_subspace,
)
from glocal_verify.analysis.laplacian.transfer import laplacian_transfer
from glocal_verify.model import System
from glocal_verify.numerics.rounding import EPS, product_rounding
from glocal_verify.numerics.subspace import Subspace
from glocal_verify.numerics.threads import single_threaded
from glocal_verify.numerics.tolerance import DEFAULT_TOLERANCE, Decision, Tolerance
from glocal_verify.numerics.zero_polynomial import poly_det
from glocal_verify.spec.types import NORMAL_MODE

__all__ = [
    "CentralObserver",
    "StabilityCertificate",
    "certify_observable_stability",
    "design_central_observer",
    "observer_charpoly_exact",
]


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

    def __repr__(self) -> str:
        return (
            f"CentralObserver(mode {self.mode}, H {self.H.shape[0]}x{self.H.shape[1]}, {self.method} on {self.designed_states} "
            f"of {self.observable_states} observable states, stability margin {self.stability_margin:.3g}, "
            f"{len(self.fixed_eigenvalues)} fixed eigenvalues)"
        )


@dataclass(frozen=True, slots=True)
class _Block:
    """The observable complement of one eigen-group, basis diag(Qx, Qv) (2N x d, orthonormal).

    The bases are formed only for the blocks the design uses (:meth:`bases`): most groups
    contribute their eigenvalues alone, which need the dimensions only.
    """

    group: EigenGroupPart
    A: np.ndarray  # d x d compression of A_1
    fixed: np.ndarray  # eigenvalues of A on the group's unobservable part
    rate: float  # decay rate of the group's observable part (-max Re eig(A))
    zero: bool

    def bases(self) -> tuple[np.ndarray, np.ndarray]:
        """(Qx, Qv): N x dx position part and N x dv velocity part."""
        g = self.group
        if self.zero:
            return _complement(g.E, g.Wx), _complement(g.E, g.W)
        Q = _complement(g.E, g.W)
        return Q, Q

    def basis(self) -> np.ndarray:
        """[[Qx, 0], [0, Qv]]."""
        Qx, Qv = self.bases()
        n, dx, dv = Qx.shape[0], Qx.shape[1], Qv.shape[1]
        out = np.zeros((2 * n, dx + dv))
        out[:n, :dx] = Qx
        out[n:, dx:] = Qv
        return out

    def output(self, C: np.ndarray) -> np.ndarray:
        """C diag(Qx, Qv) (p x d), without the 2N-long basis."""
        Qx, Qv = self.bases()
        n = Qx.shape[0]
        return np.hstack([C[:, :n] @ Qx, C[:, n:] @ Qv])


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


def _blocks(system: System, mode: str, tol: Tolerance) -> list[_Block]:
    md = modal_decomposition(system, mode, tol)
    return [_group_block(grp, system.alpha, system.gamma) for grp in md.groups]


def _group_block(grp: EigenGroupPart, a: float, g: float) -> _Block:
    mu = grp.value
    k = len(grp.indices)
    if grp.zero is Decision.ZERO:
        blk = _Block(grp, np.zeros((0, 0)), np.zeros(0, dtype=complex), 0.0, True)
        Qx, Qv = blk.bases()  # the kernel of L: its basis is the exact component indicators
        dx, dv = Qx.shape[1], Qv.shape[1]
        A = np.zeros((dx + dv, dx + dv))
        A[:dx, dx:] = Qx.T @ Qv
        A[dx:, dx:] = -g * np.eye(dv)
        fixed = np.array([0.0] * grp.dim_Wx + [-g] * grp.dim_W, dtype=complex)
        rate = 0.0 if dx else (g if dv else math.inf)
        return _Block(grp, A, fixed, rate, True)
    d = k - grp.dim_W
    A = np.zeros((2 * d, 2 * d))
    A[:d, d:] = np.eye(d)
    A[d:, :d] = -a * mu * np.eye(d)
    A[d:, d:] = -g * np.eye(d)
    lp, lm = _lam(mu, a, g)
    r = grp.dim_W
    fixed = np.array([lp] * r + [lm] * r, dtype=complex)
    rate = -max(lp.real, lm.real) if d else math.inf
    return _Block(grp, A, fixed, rate, False)


@single_threaded
def design_central_observer(
    system: System,
    poles: Sequence[complex] | None = None,
    tol: Tolerance = DEFAULT_TOLERANCE,
    *,
    mode: str = NORMAL_MODE,
    max_design: int | None = None,
    method: str = "auto",
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
        Tolerance of the modal decomposition (:func:`~glocal_verify.analysis.unobservable.subspace.unobservable_subspace`).
    mode : str
        The mode the observer is built for (the paper: the normal mode).
    max_design : int, optional
        Largest designed block for the Riccati design (default: the tunable
        ``central_max_design`` of :mod:`glocal_verify.config`, 100).
    method : str
        ``"auto"`` (default): pole placement when ``poles`` are given, else the Riccati gain
        while the observable part has at most ``central_certify_max_states`` states and the
        stiffness injection above (module docstring, "Injection design");
        ``"riccati"`` or ``"injection"`` to force one.

    Returns
    -------
    CentralObserver
    """
    if method not in ("auto", "riccati", "injection"):
        raise ValueError(f"method: expected 'auto', 'riccati' or 'injection', got {method!r}")
    if max_design is None:
        max_design = int(config.get("central_max_design"))
    C = system.C()
    p = C.shape[0]
    n = system.n
    blocks = _blocks(system, mode, tol)
    N = unobservable_subspace(system, mode, tol)
    obs = [b for b in blocks if b.A.shape[0] > 0]
    obs.sort(key=lambda b: (not b.zero, b.rate))
    fixed = np.concatenate([b.fixed for b in blocks]) if blocks else np.zeros(0, dtype=complex)
    n_obs = sum(b.A.shape[0] for b in obs)
    if poles is None and (method == "injection" or (method == "auto" and n_obs > int(config.get("central_certify_max_states")))):
        return _injection_design(system, mode, blocks, obs, fixed, n_obs, N)
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
        form_bases(system.spectrum(mode), [b.group for b in design])  # one pass over a factored basis
        As = scipy.linalg.block_diag(*[b.A for b in design])
        Cs = np.hstack([b.output(C) for b in design])
        Os = np.hstack([b.basis() for b in design])
        if poles is not None:
            from scipy.signal import (
                place_poles,  # lazily: importing scipy.signal costs seconds
            )

            res = place_poles(As.T, Cs.T, np.asarray(poles))
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


def _injection_design(
    system: System, mode: str, blocks: Sequence[_Block], obs: Sequence[_Block], fixed: np.ndarray, n_obs: int, N: Subspace
) -> CentralObserver:
    """The stiffness injection ``H = [0; alpha S_{M_x}^T]`` (module docstring, "Injection design")."""
    n = system.n
    a, g = system.alpha, system.gamma
    px = system.idx(system.monitored_positions)
    H = np.zeros((2 * n, len(px) + len(system.monitored_velocities)))
    for r, i in enumerate(px):
        H[n + i, r] = a
    if not px:
        # H = 0: the observable eigenvalues are those of the modal blocks
        obs_eigs = np.concatenate([np.linalg.eigvals(b.A).astype(complex) for b in obs]) if obs else np.zeros(0, dtype=complex)
    else:
        K = a * system.laplacian_sparse(mode).toarray()
        K[px, px] += a
        kappa = np.linalg.eigvalsh(K)
        # an unobservable group keeps kappa = alpha mu on W (S_{M_x} W = 0): drop that many
        # nearest values per group (both roots fixed); for mu = 0 the root 0 is fixed on W^x_0,
        # the root -gamma only on W_0 (the others' velocity is measured: observable)
        keep = np.ones(len(kappa), dtype=bool)
        extra: list[complex] = []
        for b in blocks:
            r = b.group.dim_Wx if b.zero else b.group.dim_W
            if r:
                near = np.argsort(np.abs(kappa - a * b.group.value) + np.where(keep, 0.0, np.inf))[:r]
                keep[near] = False
            if b.zero:
                extra += [complex(-g)] * (b.group.dim_Wx - b.group.dim_W)
        roots = [_lam(float(k) / a, a, g) for k in kappa[keep]]
        obs_eigs = np.array([z for pair in roots for z in pair] + extra, dtype=complex)
    margin = -float(np.max(obs_eigs.real)) if len(obs_eigs) else math.inf
    H.setflags(write=False)
    return CentralObserver(
        H=H,
        eigenvalues=np.concatenate([obs_eigs, fixed]),
        fixed_eigenvalues=fixed,
        observable_eigenvalues=obs_eigs,
        stability_margin=margin,
        designed_states=0,
        observable_states=int(n_obs),
        method="injection",
        unobservable=N,
        mode=mode,
    )


# --------------------------------------------------------------------------------------------
# exact verification of a designed gain


def observer_charpoly_exact(system: System, H: Any, mode: str = NORMAL_MODE) -> Any:
    r"""det(sI - (A_q - H C)) over Q through the modal structure, without the 2N x 2N matrix.

    .. math::

        \det(sI - A + HC) = \det(sI - A)\,\det\big(I_p + C (sI - A)^{-1} H\big),\qquad
        (sI - A)^{-1} = \begin{bmatrix} (s + \gamma) K^{-1} & K^{-1} \\ t K^{-1} - I & s K^{-1} \end{bmatrix}

    with t = s^2 + gamma s and K = t I + alpha L_q (matrix determinant lemma; the lower left
    block is -alpha L K^{-1} = t K^{-1} - I), so det(sI - A) = d(t) = det(tI + alpha L_q) and
    only the rows of K^{-1} at the monitored agents enter: d(t) K^{-1} S^T = adj(K) S^T, the N
    x |M| transfer numerators in t (Faddeev-LeVerrier over Q). With Y = d (I + C (sI - A)^{-1}
    H), a p x p polynomial matrix, the result is det(Y) / d^(p - 1), an exact division. Cost:
    the N-sized numerators and a p x p determinant, instead of a 2N x 2N rational
    characteristic polynomial. Tests compare it with ``charpoly`` of the dense matrix.

    Parameters
    ----------
    system : System
    H : fmpq_mat
        The 2N x p gain, exact (rows: positions then velocities of the states; columns: the
        rows of C, position monitors first).
    mode : str
        The mode q of A_q.
    """
    import flint

    n = system.n
    pos = system.idx(system.monitored_positions)
    vel = system.idx(system.monitored_velocities)
    rows = pos + vel
    p = len(rows)
    agents = sorted(set(rows))
    d_t, Nm = laplacian_transfer(system, agents, mode)
    col = {a: k for k, a in enumerate(agents)}
    gq = flint.fmpq(system.gamma_q.numerator, system.gamma_q.denominator)
    sx = flint.fmpq_poly([0, 1])
    t_of_s = flint.fmpq_poly([0, gq, 1])
    d = d_t(t_of_s)
    if p == 0:
        return d
    Nx = [[sum((Nm[i][col[r]] * H[i, c] for i in range(n) if not H[i, c] == 0), flint.fmpq_poly(0)) for c in range(p)] for r in agents]
    Nv = [[sum((Nm[i][col[r]] * H[n + i, c] for i in range(n) if not H[n + i, c] == 0), flint.fmpq_poly(0)) for c in range(p)] for r in agents]
    Y: list[list[Any]] = []
    for k, r in enumerate(rows):
        a = col[r]
        if k < len(pos):  # d e_r^T [(s + gamma) K^-1 H_x + K^-1 H_v]
            entries = [(sx + gq) * Nx[a][c](t_of_s) + Nv[a][c](t_of_s) for c in range(p)]
        else:  # d e_r^T [(t K^-1 - I) H_x + s K^-1 H_v]
            entries = [t_of_s * Nx[a][c](t_of_s) - d * H[r, c] + sx * Nv[a][c](t_of_s) for c in range(p)]
        Y.append([e + (d if c == k else 0) for c, e in enumerate(entries)])
    num = poly_det(Y)
    if p == 1:
        return num
    q, rem = divmod(num, d ** (p - 1))
    if not rem.is_zero():  # pragma: no cover - the matrix determinant lemma
        raise ArithmeticError("det(Y) is not divisible by d^(p-1); please report")
    return q


# --------------------------------------------------------------------------------------------
# certified stability of the observable part (floating point with a rigorous bound)


@dataclass(frozen=True, slots=True)
class StabilityCertificate:
    """Outcome of :func:`certify_observable_stability`.

    Attributes
    ----------
    decision : str
        ``"stable"``, ``"unstable"`` or ``"undecided"``.
    max_real : float
        Largest real part of the computed observable eigenvalues.
    radius : float
        Bauer-Fike radius: every exact observable eigenvalue lies within it of a computed one.
    note : str
        Why it is undecided ('' otherwise).
    """

    decision: str
    max_real: float
    radius: float
    note: str


@single_threaded
def certify_observable_stability(system: System, obsv: CentralObserver) -> StabilityCertificate:
    """Is ``A_1 - H C`` (exact A_1, the float gain H) Hurwitz on ``R^2N / N(A_1, C)``? Certified.

    Needs a proven unobservable subspace with an exact rational basis (``W^x_0 x W_0`` and the
    exactly verified parts ``W x W`` of
    :func:`~glocal_verify.analysis.unobservable.subspace.certified_unobservable`, decided); N is
    ``(A_1 - H C)``-invariant (it is A_1-invariant and in ker C), so the observable eigenvalues
    are those of ``M_o = Q^T (A_1 - H C) Q`` for an orthonormal basis Q of ``N^perp``. With the
    computed ``M_o = V diag(lam) V^{-1} + R V^{-1}`` (``R`` the eigen-residual), the exact
    quotient is ``V diag(lam) V^{-1} + G`` with

    .. math:: \\|G\\|_2 \\le \\|R\\|_F / \\sigma_{\\min}(V) + E,

    ``E`` bounding the rounding of A_1 (``u ||A||_F`` per rounded entry, plus ``alpha`` times
    the input error of L), of the products ``Q^T M Q`` (``4 (2N) eps ||M||_F``) and the
    non-orthonormality of Q (``2 eta ||M||_F``). By Bauer-Fike every exact observable
    eigenvalue lies within ``r = kappa(V) ||G||`` of a computed one (``kappa`` with
    ``sigma_min(V)`` lowered by its own SVD backward error ``10 (2N) eps ||V||``). Stable iff
    ``max Re lam + r < 0``; unstable iff a disc isolated from all others (hence holding exactly
    one eigenvalue) lies in ``Re > 0``; undecided otherwise, or when N is not proven, or when
    the observable part exceeds ``central_certify_max_states`` (:mod:`glocal_verify.config`) states (dense certificate).

    Parameters
    ----------
    system : System
        The multi-agent system.
    obsv : CentralObserver
        The designed observer (its mode and gain).
    """
    cu = certified_unobservable(system, obsv.mode)
    if not cu.decided:
        return StabilityCertificate("undecided", math.nan, math.inf, "the unobservable subspace of (A_1, C) is not proven: " + cu.note)
    n = system.n
    k = 2 * n - cu.dim_lower
    if k == 0:
        return StabilityCertificate("stable", -math.inf, 0.0, "")
    if k > config.get("central_certify_max_states"):
        return StabilityCertificate(
            "undecided", math.nan, math.inf, f"the observable part has {k} states, more than the dense certificate handles ({config.get('central_certify_max_states')})"
        )
    Nb = np.array([[float(x) for x in b] for b in cu.exact_basis]).T if cu.exact_basis else np.zeros((2 * n, 0))
    if Nb.shape[1]:
        Nb = Nb / np.linalg.norm(Nb, axis=0)
        Qf, _ = np.linalg.qr(np.hstack([Nb, np.eye(2 * n)]))
        Q = Qf[:, Nb.shape[1] : 2 * n]
    else:
        Q = np.eye(2 * n)
    A = system.A(obsv.mode)
    C = system.C()
    M = A - obsv.H @ C if C.shape[0] else A
    fro = float(np.linalg.norm(M, "fro"))
    L_err = system.spectrum(obsv.mode).input_error
    u = EPS / 2
    # loss of orthonormality of Q and of orthogonality to Nb, the rounding of both products included
    eta = (
        (float(np.linalg.norm(Q.T @ Q - np.eye(k), "fro")) + float(np.linalg.norm(Q.T @ Nb, "fro"))) * (1 + 4 * k * EPS)
        + product_rounding(Q, Q, shifted=True)
        + product_rounding(Q, Nb)
    )
    E = u * fro * 2 + system.alpha * L_err * (1 + u) + 4 * (2 * n) * EPS * fro + 2 * eta * fro
    Mo = Q.T @ M @ Q
    lam, V = np.linalg.eig(Mo)
    R = Mo @ V - V * lam[None, :]
    sv = np.linalg.svd(V, compute_uv=False)
    smin = float(sv[-1]) - 10 * k * EPS * float(sv[0])
    if not smin > 0:
        return StabilityCertificate("undecided", float(np.max(lam.real)), math.inf, "the computed eigenvectors of the observable part are numerically dependent (defective or nearly so)")
    rround = 4 * k * EPS * (float(np.linalg.norm(Mo, "fro")) + float(np.max(np.abs(lam)))) * float(np.linalg.norm(V, "fro"))
    G = (float(np.linalg.norm(R, "fro")) + rround) / smin + E
    r = float(sv[0]) / smin * G * (1 + 4 * k * EPS)
    mr = float(np.max(lam.real))
    if mr + r < 0:
        return StabilityCertificate("stable", mr, r, "")
    for i, z in enumerate(lam):
        if z.real - r > 0 and all(abs(z - y) > 2 * r for j, y in enumerate(lam) if j != i):
            return StabilityCertificate("unstable", mr, r, "")
    return StabilityCertificate(
        "undecided", mr, r, f"the slowest observable eigenvalue has Re = {mr:.3g}, within the Bauer-Fike radius {r:.3g} of the imaginary axis"
    )
