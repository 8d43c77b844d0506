"""Structure of the cluster pencil of Proposition III.2 (iii): zero forcing and the reduced pencil.

The pencil of eq. ``pencil_uio`` for a cluster P_i with n agents, Laplacian block
L = L[P_i, P_i], suspected set S, boundary dP_i (S ∩ dP_i = ∅; otherwise (iii) fails
structurally), measured positions M_x and velocities M_v is

.. math::

    P(\\lambda) = \\begin{bmatrix} \\lambda I - A^i & -B^i & E^i \\\\ C_{loc} & 0 & 0
    \\end{bmatrix} \\in \\mathbb C^{(2n + p) \\times (2n + |S| + |\\partial P_i|)},\\qquad
    A^i = \\begin{bmatrix} 0 & I \\\\ -\\alpha L & -\\gamma I \\end{bmatrix}.

**Reduction.** Write a kernel vector as [p; v; u_B; u_E]. The position rows read v = lam p.
With s = lam^2 + gamma lam and xi = p the velocity rows read

.. math:: ((s I + \\alpha L)\\, \\xi)_k = [k \\in S]\\, u_{B,k} - [k \\in \\partial P_i]\\, u_{E,k},

and the output rows xi_{M_x} = 0, lam xi_{M_v} = 0. Every input agent k in I = S ∪ dP_i owns
exactly one input column (a unit column at its velocity row), so u is *determined* by xi
(u_B = ((s I + alpha L) xi)_S, u_E = -((s I + alpha L) xi)_{dP_i}) and imposes nothing; the
rows R = P_i \\ I must vanish. For lam != 0 the outputs say xi_M = 0 with M = M_x ∪ M_v, so

.. math::

    \\ker P(\\lambda) \\cong \\ker Q(s),\\qquad Q(s) = (s I + \\alpha L)[R, U],\\quad
    U = P_i \\setminus M,\\quad s = \\lambda^2 + \\gamma \\lambda \\qquad (\\lambda \\ne 0),

the isomorphism being the lift xi -> [xi; lam xi; u_B(xi); u_E(xi)] (:func:`lift`). At lam = 0
only xi_{M_x} = 0 is imposed, so ker P(0) ≅ ker Q_0 with Q_0 = (alpha L)[R, P_i \\ M_x]; when
M_v ⊆ M_x this is Q(0) again. Consequences:

* *normal rank*: dim ker P(lam) = dim ker Q(s(lam)) for lam != 0 and lam -> s(lam) maps the
  punctured plane onto C, so P has full normal column rank iff Q does, and in general
  nrank P = (2n + |S| + |dP_i|) - (|U| - nrank Q);
* *zeros*: lam != 0 is a zero of P iff s(lam) is a zero of Q (two lam per s,
  lam = (-gamma ± sqrt(gamma^2 + 4 s)) / 2, one double lam = -gamma / 2 at s = -gamma^2 / 4);
  lam = 0 is a zero iff Q_0 loses column rank;
* when M_v ⊆ M_x the row and column operations above are unimodular over C[lam]
  (v -> v - lam p, elimination of the unit input columns and of the measured columns), so
  P(lam) is equivalent to diag(I, Q(lam^2 + gamma lam)): the zero polynomial of P is that of
  Q composed with lam^2 + gamma lam (used by the exact path).

Q(s) is the Rosenbrock pencil [[s I - A_r, -B_r], [C_r, D_r]] of a system with the states
RU = R ∩ U, inputs US = U ∩ I, outputs RM = R ∩ M (:func:`reduced_pencil`): n-sized instead of
2n-sized. Without inputs (every suspected agent measured, or none suspected) A_r = -alpha L_UU
is symmetric and the zeros are the unobservable eigenvalues of (L_UU, L_MU), found from one
symmetric eigen-decomposition (:func:`symmetric_zeros`). For the exact analysis, which needs D = 0, Q is embedded in the D = 0 system with
states (xi_RU, xi_US) and input w (rows s xi_US - w = 0): the column operation
w -> w - s xi_US shows that its pencil is equivalent to diag(-I, Q(s)), so kernels, normal rank
deficiency and zero polynomial are those of Q (:func:`reduced_system_exact`).

**Zero forcing** (:func:`zero_forcing_closure`). Call an agent *known* when xi_k = 0 is
established: initially the measured ones. A known agent r ∉ I whose row of (s I + alpha L) has
exactly one unknown neighbour k gives alpha L_{rk} xi_k = 0 with L_{rk} = -w_{rk} != 0, so k
becomes known. If every agent becomes known, Q(s) has full column rank for *every* complex s,
whatever the weights: order U by the step at which each agent was forced and take the forcing
rows in the same order; that square submatrix of Q(s) is lower triangular (a forcing row has,
besides its forced column, only columns forced earlier) with constant diagonal entries
-alpha w_{r_t k_t} != 0, so det = prod(-alpha w) != 0 for every s. Only the sparsity pattern is
used (weights are positive rationals, so the proof is exact in exact mode too). With measured
sets M (lam != 0) and M_x (lam = 0) this proves (iii) for every lam.

**Verification of a numeric zero.** A direction of Q at s_k is lifted to v of the full pencil
and checked by the backward error

.. math:: \\eta(\\lambda, v) = \\frac{\\|P(\\lambda) v\\|}{\\|P(\\lambda)\\|_2 \\|v\\|}
          \\ \\ge\\ \\frac{\\sigma_{\\min}(P(\\lambda))}{\\|P(\\lambda)\\|_2}

(the perturbation -P v v^H / ||v||^2 makes v a kernel vector). ||P||_2 is replaced by a lower
bound (largest column norm, improved by power iteration), which can only increase eta: eta
zero at ``rtol`` proves that P(lambda) is within relative distance ``rtol`` of singular, the
same decision the dense path makes from sigma_min, at the cost of matrix-vector products
(:func:`backward_error`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from fractions import Fraction
from typing import Any, Iterable, Protocol, Sequence

import numpy as np
import scipy.linalg
import scipy.sparse

from glocal_verify.model import ClusterModel
from glocal_verify.numerics.minors import RATIONAL_ZERO
from glocal_verify.numerics.rounding import EPS
from glocal_verify.numerics.tolerance import (
    DEFAULT_TOLERANCE,
    Decision,
    Tolerance,
    numeric_rank,
)
from glocal_verify.results import Status

__all__ = [
    "intra_neighbours",
    "zero_forcing_steps",
    "zero_forcing_closure",
    "ReducedPencil",
    "reduced_pencil",
    "reduced_pencil_holds",
    "SymmetricZero",
    "symmetric_zeros",
    "reduced_system_exact",
    "lambdas_of_s",
    "lift",
    "backward_error",
    "norm2_lower",
    "near_null_vector",
    "relative_sigma_min",
    "KernelEnclosure",
    "krawczyk_kernel",
]

# --------------------------------------------------------------------------------------------
# zero forcing


def intra_neighbours(L: np.ndarray | Sequence[Sequence[Fraction]]) -> list[list[int]]:
    """Neighbours inside the cluster: the nonzero off-diagonal entries of each row of L.

    Parameters
    ----------
    L : ndarray or rows of Fraction
        Laplacian block L[P_i, P_i] (float, or exact rows for exact mode).
    """
    if isinstance(L, np.ndarray):
        nz = L != 0.0
        np.fill_diagonal(nz, False)
        rows, cols = np.nonzero(nz)  # row-major: each row's columns ascending, rows in order
        return [c.tolist() for c in np.split(cols, np.cumsum(np.bincount(rows, minlength=L.shape[0]))[:-1])] if L.shape[0] else []
    return [[j for j, x in enumerate(row) if x and j != i] for i, row in enumerate(L)]  # zero Fractions are falsy


def zero_forcing_steps(nbrs: Sequence[Sequence[int]], known: Iterable[int], inputs: Iterable[int]) -> list[tuple[int, int]]:
    """The forcing steps (forcer r, forced k), in order (module docstring).

    A known agent r outside ``inputs`` with exactly one unknown neighbour k forces it;
    repeated until nothing changes.

    Parameters
    ----------
    nbrs : sequence of sequences of int
        Neighbours (cluster indices) of each agent inside the cluster.
    known : iterable of int
        Agents with xi = 0 from the start (the measured ones).
    inputs : iterable of int
        Agents whose velocity row carries an unknown input (suspected or boundary): their rows
        impose nothing, so they never force.
    """
    K = set(known)
    inp = set(inputs)
    steps: list[tuple[int, int]] = []
    active = [r for r in K if r not in inp]
    while active:
        nxt: list[int] = []
        for r in active:
            unk = [k for k in nbrs[r] if k not in K]
            if len(unk) == 1:
                k = unk[0]
                K.add(k)
                steps.append((r, k))
                if k not in inp:
                    nxt.append(k)
                # the neighbours of k may now have a single unknown neighbour
                nxt.extend(j for j in nbrs[k] if j in K and j not in inp)
        active = list(dict.fromkeys(nxt))
    return steps


def zero_forcing_closure(nbrs: Sequence[Sequence[int]], known: Iterable[int], inputs: Iterable[int]) -> set[int]:
    """Agents forced to xi = 0 (indices), the known ones included (see :func:`zero_forcing_steps`).

    If the closure is every agent, Q(s) has full column rank for every complex s (module
    docstring: a triangular maximal minor with constant nonzero diagonal).

    Parameters
    ----------
    nbrs : sequence of sequences of int
        Neighbours (cluster indices) of each agent inside the cluster.
    known : iterable of int
        Measured agents.
    inputs : iterable of int
        Agents whose velocity row carries an unknown input (suspected or boundary).
    """
    K = set(known)
    return K | {k for _, k in zero_forcing_steps(nbrs, K, inputs)}


# --------------------------------------------------------------------------------------------
# reduced pencil (numeric)


@dataclass(frozen=True, slots=True)
class ReducedPencil:
    """Q(s) = (s I + alpha L)[R, U] as the Rosenbrock pencil [[s I - A, -B], [C, D]].

    Attributes
    ----------
    rows : tuple of int
        R = P_i \\ I in the order [RU, RM] (cluster indices).
    cols : tuple of int
        U = P_i \\ M in the order [RU, US].
    n_states : int
        |RU|: the first ``n_states`` rows and columns carry s.
    A, B, C, D : ndarray
        -alpha L[RU, RU], -alpha L[RU, US], alpha L[RM, RU], alpha L[RM, US].
    """

    rows: tuple[int, ...]
    cols: tuple[int, ...]
    n_states: int
    A: np.ndarray
    B: np.ndarray
    C: np.ndarray
    D: np.ndarray

    def matrix(self, s: complex) -> np.ndarray:
        """Q(s) (rows ordered as :attr:`rows`, columns as :attr:`cols`).

        Parameters
        ----------
        s : complex
        """
        k = self.n_states
        Q = np.zeros((len(self.rows), len(self.cols)), dtype=complex)
        Q[:k, :k] = s * np.eye(k) - self.A
        Q[:k, k:] = -self.B
        Q[k:, :k] = self.C
        Q[k:, k:] = self.D
        return Q


def reduced_pencil(L: np.ndarray, alpha: float, inputs: Iterable[int], measured: Iterable[int]) -> ReducedPencil:
    """Build Q(s) = (s I + alpha L)[R, U] with R = P_i \\ I, U = P_i \\ M (module docstring).

    Parameters
    ----------
    L : ndarray
        Laplacian block L[P_i, P_i].
    alpha : float
    inputs : iterable of int
        Cluster indices of I = S ∪ dP_i.
    measured : iterable of int
        Cluster indices of M (positions and velocities; M_x alone for lam = 0).
    """
    n = L.shape[0]
    I = set(inputs)
    M = set(measured)
    RU = [k for k in range(n) if k not in I and k not in M]
    RM = [k for k in range(n) if k not in I and k in M]
    US = [k for k in range(n) if k in I and k not in M]
    aL = alpha * np.asarray(L, dtype=float)
    return ReducedPencil(
        tuple(RU + RM),
        tuple(RU + US),
        len(RU),
        -aL[np.ix_(RU, RU)],
        -aL[np.ix_(RU, US)],
        aL[np.ix_(RM, RU)],
        aL[np.ix_(RM, US)],
    )


def reduced_pencil_holds(cm: ClusterModel, alpha: float, inputs: Sequence[int], measured: Sequence[int], tol: Tolerance = DEFAULT_TOLERANCE) -> Status:
    """Decide (iii) (for lam != 0) on the reduced pencil Q(s) of :func:`reduced_pencil`.

    HOLDS when Q(s) has full column rank for every complex s: full normal column rank and no
    finite zero by :func:`glocal_verify.numerics.pencil.analyze_pencil` (its tolerance rule), after a
    quick rejection at a fixed generic point (a certain rank drop there is a rank drop for
    every s). Used by the observer placement search; :func:`glocal_verify.conditions.local_pencil.pencil_verdict`
    reports zeros and directions from the same pencil.

    Parameters
    ----------
    cm : ClusterModel
    alpha : float
    inputs : sequence of int
        Cluster indices of I = S ∪ dP_i (S ∩ dP_i = ∅).
    measured : sequence of int
        Cluster indices of M.
    tol : Tolerance
    """
    n = len(cm.nodes)
    M = set(measured)
    if len(M) >= n:
        return Status.HOLDS
    rp = reduced_pencil(cm.L, alpha, inputs, measured)
    if len(rp.rows) < len(rp.cols):
        return Status.FAILS
    if rp.n_states == 0:
        info = numeric_rank(rp.D, tol)
        if not info.decided:
            return Status.UNDECIDED
        return Status.HOLDS if info.rank == len(rp.cols) else Status.FAILS
    aL = alpha * cm.L
    s0 = complex(0.6180339887, 1.3247179572) * max(1.0, float(np.sqrt(np.max(np.abs(aL))))) if aL.size else 1.0
    sv = np.linalg.svd(rp.matrix(s0), compute_uv=False)
    if tol.decide(sv[-1], sv[0]) is Decision.ZERO:
        return Status.FAILS
    from glocal_verify.numerics.pencil import analyze_pencil

    pa = analyze_pencil(rp.A, rp.B, rp.C, rp.D, tol=tol)
    if not pa.decided:
        return Status.UNDECIDED
    return Status.HOLDS if (pa.full_normal_column_rank and not pa.zeros) else Status.FAILS


@dataclass(frozen=True, slots=True)
class SymmetricZero:
    """A zero s of Q(s) found by :func:`symmetric_zeros`, with a direction on ``cols``.

    Attributes
    ----------
    value : complex
        The zero s (real: s = -alpha mu).
    multiplicity : int
        Merged multiplicity as reported by the small analysis.
    direction : ndarray
        xi on the columns U of Q (unit norm).
    certain : bool
        ||alpha L_MU xi|| is zero at ``rtol`` (not merely inside the undecided band).
    """

    value: complex
    multiplicity: int
    direction: np.ndarray
    certain: bool = True


def symmetric_zeros(rp: ReducedPencil, tol: Tolerance = DEFAULT_TOLERANCE) -> tuple[list[SymmetricZero], bool]:
    """Zeros of Q(s) when it has no input columns (no unmeasured suspected agent), by symmetry.

    Then U ⊆ R and Q(s) = [[s I + alpha L_UU], [alpha L_MU]] (M = R ∩ M): full normal column
    rank, and ker Q(s) != 0 iff s = -alpha mu for an eigenvalue mu of the symmetric L_UU whose
    eigenspace holds a w with L_MU w = 0 (an unobservable mode of (L_UU, L_MU)). One ``eigh``
    of alpha L_UU; eigenvalues closer than rtol * band times the scale are grouped (numerically
    equal). A group is separated from the others by at least that gap, so its computed invariant
    subspace W_g is accurate to about eps / (rtol * band) ~ 2e-10 < rtol, and an unobservable
    eigenvector of the group gives ||alpha L_MU W_g v|| below ``rtol`` times the scale: it
    cannot be missed. In a group,
    the directions W_g v with alpha L_MU W_g v not certainly nonzero (singular values against
    the scale of the whole pencil, ``tol``) hold every unobservable eigenvector of the group;
    the Rayleigh quotient of L_UU on them gives the candidate zeros and their directions. A
    group with no such direction has no zero, so "no candidate at all" proves that Q(s) has
    full column rank for every s; candidates are flagged ``certain`` when alpha L_MU xi is zero
    at ``rtol`` (weakly observed modes far from the measured agents land in the undecided
    band); every candidate is a claim only, verified by the caller on
    the full pencil (a group of distinct eigenvalues can produce a candidate that is not an
    eigenvector: it does not verify, and the verdict is undecided). This avoids the deflation
    of a large pencil with few outputs (the observability of a large graph from a few agents is
    numerically delicate).

    Parameters
    ----------
    rp : ReducedPencil
        A reduced pencil with no input columns (``rp.B`` has no columns).
    tol : Tolerance

    Returns
    -------
    (list of SymmetricZero, decided)
        The candidate zeros (each with a direction, to be lifted and verified on the full
        pencil) and whether every rank decision was decided.
    """
    if rp.B.shape[1] != 0:
        raise ValueError("symmetric_zeros needs a reduced pencil without input columns")
    k = rp.n_states
    if k == 0:
        return [], True
    S = -(rp.A + rp.A.T) / 2.0
    mu, W = np.linalg.eigh(S)
    C = rp.C
    scale = max(float(np.max(np.abs(mu))) + (float(np.linalg.norm(C, 2)) if C.size else 0.0), 1e-300)
    tau = tol.upper * scale
    groups: list[list[int]] = [[0]]
    for i in range(1, k):
        if mu[i] - mu[i - 1] > tau:
            groups.append([i])
        else:
            groups[-1].append(i)
    out: list[SymmetricZero] = []
    decided = True
    for g in groups:
        Wg = W[:, g]
        m = len(g)
        if C.shape[0] == 0:
            N = np.eye(m)
        else:
            _, sv, Vh = np.linalg.svd(C @ Wg, full_matrices=True)
            full = np.zeros(m)
            full[: min(len(sv), m)] = sv[:m]
            hi = int(np.sum(full > tol.rtol * scale))
            lo = int(np.sum(full > tol.upper * scale))
            decided &= hi == lo
            N = Vh[lo:].conj().T
        if N.shape[1] == 0:
            continue
        theta, V = np.linalg.eigh(N.T @ (mu[g][:, None] * N))
        dirs = Wg @ (N @ V)
        j = 0
        while j < len(theta):  # equal Rayleigh values: one multiple zero
            e = j
            while e + 1 < len(theta) and theta[e + 1] - theta[j] <= tol.upper * scale:
                e += 1
            v = dirs[:, j] / max(float(np.linalg.norm(dirs[:, j])), 1e-300)
            certain = C.shape[0] == 0 or float(np.linalg.norm(C @ v)) <= tol.rtol * scale
            out.append(SymmetricZero(complex(-float(np.mean(theta[j : e + 1]))), e - j + 1, v, certain))
            j = e + 1
    return out, decided


# --------------------------------------------------------------------------------------------
# reduced pencil (exact)


def reduced_system_exact(
    L: Sequence[Sequence[Fraction]], alpha: Fraction, inputs: Iterable[int], measured: Iterable[int]
) -> tuple[list[list[Fraction]], list[list[Fraction]], list[list[Fraction]], tuple[int, ...], tuple[int, ...], int]:
    """The D = 0 embedding of Q(s) over Q (module docstring).

    States (xi_RU, xi_US), input w, outputs RM:

    .. math::

        A = \\begin{bmatrix} -\\alpha L_{RU,RU} & -\\alpha L_{RU,US} \\\\ 0 & 0 \\end{bmatrix},\\quad
        B = \\begin{bmatrix} 0 \\\\ I \\end{bmatrix},\\quad
        C = \\begin{bmatrix} \\alpha L_{RM,RU} & \\alpha L_{RM,US} \\end{bmatrix}.

    Its pencil is equivalent to diag(-I, Q(s)): same kernels (xi = the states), normal rank
    deficiency and zero polynomial.

    Parameters
    ----------
    L : rows of Fraction
        Exact Laplacian block.
    alpha : Fraction
    inputs : iterable of int
        Cluster indices of I.
    measured : iterable of int
        Cluster indices of M.

    Returns
    -------
    (A, B, C, rows, cols, n_states)
        ``rows`` = [RU, RM], ``cols`` = [RU, US] (cluster indices), ``n_states`` = |RU|.
    """
    n = len(L)
    I = set(inputs)
    M = set(measured)
    RU = [k for k in range(n) if k not in I and k not in M]
    RM = [k for k in range(n) if k not in I and k in M]
    US = [k for k in range(n) if k in I and k not in M]
    cols = RU + US
    z = Fraction(0)
    A = [[-alpha * Fraction(L[i][j]) for j in cols] for i in RU] + [[z] * len(cols) for _ in US]
    B = [[z] * len(US) for _ in RU] + [[Fraction(int(a == b)) for b in range(len(US))] for a in range(len(US))]
    C = [[alpha * Fraction(L[i][j]) for j in cols] for i in RM]
    return A, B, C, tuple(RU + RM), tuple(cols), len(RU)


# --------------------------------------------------------------------------------------------
# lifting and verification


def lambdas_of_s(s: complex, gamma: float) -> list[complex]:
    """The roots lam of lam^2 + gamma lam = s: (-gamma ± sqrt(gamma^2 + 4 s)) / 2 (equal at
    s = -gamma^2 / 4).

    Parameters
    ----------
    s : complex
    gamma : float
    """
    r = np.sqrt(complex(gamma * gamma + 4.0 * s))
    return [complex((-gamma + r) / 2.0), complex((-gamma - r) / 2.0)]


def lift(
    L: np.ndarray, alpha: float, gamma: float, lam: complex, xi: np.ndarray, suspected: Sequence[int], boundary: Sequence[int]
) -> np.ndarray:
    """The full-pencil vector [xi; lam xi; u_B; u_E] of a position direction xi (module docstring).

    u_B = ((s I + alpha L) xi)_S and u_E = -((s I + alpha L) xi)_{dP_i}, s = lam^2 + gamma lam,
    in the column order of eq. ``pencil_uio`` ([x, u_B, u_E], suspected and boundary agents in
    the given order).

    Parameters
    ----------
    L : ndarray
        Laplacian block.
    alpha, gamma : float
    lam : complex
    xi : ndarray
        Positions (length n, zero on the measured agents).
    suspected, boundary : sequences of int
        Cluster indices of S and dP_i.
    """
    xi = np.asarray(xi, dtype=complex)
    s = lam * lam + gamma * lam
    r = s * xi + alpha * (L @ xi)
    return np.concatenate([xi, lam * xi, r[list(suspected)], -r[list(boundary)]])


def norm2_lower(P: Any, steps: int = 8) -> float:
    """A lower bound of ||P||_2: the largest column norm, improved by power iteration on P^H P
    (every iterate gives ||P x|| / ||x|| <= ||P||_2).

    Parameters
    ----------
    P : ndarray or scipy.sparse matrix
    steps : int
        Power iterations.
    """
    if P.shape[0] == 0 or P.shape[1] == 0:
        return 0.0
    if scipy.sparse.issparse(P):
        cn = np.sqrt(np.asarray(abs(P).power(2).sum(axis=0)).ravel())
    else:
        cn = np.linalg.norm(P, axis=0)
    j = int(np.argmax(cn))
    best = float(cn[j])
    if best == 0.0:
        return 0.0
    PH = P.conj().T
    e = np.zeros(P.shape[1], dtype=P.dtype)
    e[j] = 1.0
    x = PH @ (P @ e)
    for _ in range(steps):
        nx = float(np.linalg.norm(x))
        if nx == 0.0:
            break
        x = x / nx
        y = P @ x
        best = max(best, float(np.linalg.norm(y)))
        x = PH @ y
    return best


def backward_error(P: Any, v: np.ndarray) -> float:
    """||P v|| / (||P||_2 ||v||) with ||P||_2 replaced by :func:`norm2_lower`: an upper bound
    of the relative backward error, hence of sigma_min(P) / ||P||_2 (module docstring).

    Parameters
    ----------
    P : ndarray or scipy.sparse matrix
    v : ndarray
    """
    nv = float(np.linalg.norm(v))
    nP = norm2_lower(P)
    if nv == 0.0:
        return math.inf
    if nP == 0.0:
        return 0.0
    return float(np.linalg.norm(P @ v)) / (nP * nv)


def near_null_vector(Q: np.ndarray, iterations: int = 4) -> np.ndarray:
    """A unit vector v minimising ||Q v|| approximately (Q tall or square).

    QR of Q, then inverse iteration on R^H R (two triangular solves per step, exact zero
    pivots replaced by eps ||R||). Only a candidate: callers verify it (:func:`backward_error`).

    Parameters
    ----------
    Q : ndarray
    iterations : int
    """
    m, k = Q.shape
    if k == 0:
        return np.zeros(0, dtype=complex)
    if m < k:
        _, _, Vh = np.linalg.svd(Q, full_matrices=True)
        return np.asarray(Vh[-1].conj())
    R = scipy.linalg.qr(Q, mode="r")[0][:k, :k]
    d = np.abs(np.diag(R))
    rng = np.random.default_rng(12345)
    x = np.asarray(rng.standard_normal(k) + 1j * rng.standard_normal(k), dtype=complex)
    x = x / np.linalg.norm(x)
    big = float(np.max(d))
    if big == 0.0:  # Q = 0 (up to its zero rows): every vector is a null vector
        return x
    R = R.copy()
    small = np.flatnonzero(d < EPS * big)
    R[small, small] = EPS * big
    for _ in range(iterations):
        y = scipy.linalg.solve_triangular(R, x, trans="C", check_finite=False)
        z = scipy.linalg.solve_triangular(R, y, check_finite=False)
        nz = float(np.linalg.norm(z))
        if not math.isfinite(nz) or nz == 0.0:
            break
        x = z / nz
    return np.asarray(x)


def relative_sigma_min(Q: np.ndarray) -> float:
    """sigma_min / sigma_max of a tall Q (0 when Q is wide, 1 when it has no columns).

    Parameters
    ----------
    Q : ndarray
    """
    if Q.shape[1] == 0:
        return 1.0
    if Q.shape[0] < Q.shape[1]:
        return 0.0
    s = np.linalg.svd(Q, compute_uv=False)
    return float(s[-1] / s[0]) if s[0] > 0 else 0.0


@dataclass(frozen=True, slots=True)
class KernelEnclosure:
    """A proved zero of a linear pencil: P0 + lam P1 has the kernel vector v at lam, both in balls.

    Attributes
    ----------
    lam : acb
        Certified enclosure (python-flint ball) of the zero.
    vector : list of acb
        Enclosures of the kernel vector (entries outside ``support`` are exactly 0; the entry
        ``normalised`` is exactly 1).
    support : tuple of int
        Columns of the nonzero entries.
    normalised : int
    """

    lam: Any
    vector: list[Any]
    support: tuple[int, ...]
    normalised: int

    def nonzero(self, columns: Iterable[int]) -> bool:
        """Some entry among ``columns`` is certainly nonzero (its ball excludes 0)."""
        return any(not self.vector[j].contains(0) for j in columns)


class RationalRow(Protocol):
    """A row of exact entries read by index (a list of Fraction, or entries computed on access)."""

    def __len__(self) -> int: ...

    def __getitem__(self, j: int) -> Fraction: ...


class RationalRows(Protocol):
    """Rows of exact entries read by index (a list of lists of Fraction, or a lazy matrix)."""

    def __len__(self) -> int: ...

    def __getitem__(self, i: int) -> RationalRow: ...


def krawczyk_kernel(
    P0: RationalRows,
    P1: RationalRows,
    lam: complex,
    v: np.ndarray,
    prec: int = 128,
    nonzero: np.ndarray | None = None,
) -> KernelEnclosure | None:
    """Prove, by the Krawczyk test in ball arithmetic, that P(lam) = P0 + lam P1 (exact
    rational rows) has a kernel vector near the float candidate (lam, v); None if the test fails.

    The candidate fixes a support S (entries of v / max|v| above 1e-13) and the rows R of P
    with an exact nonzero in S; every other row vanishes on vectors supported on S, exactly.
    With v_k = 1 (largest entry) the unknowns (v_{S \\ k}, lam) and the |R| equations
    P[R, S](lam) v_S = 0 form a square system when |R| = |S|. After a few Newton steps in
    double precision, with Y ~ J(x~)^{-1} and a box X = x~ + r, the Krawczyk operator

    .. math:: K(X) = \tilde x - Y f(\tilde x) + (I - Y J(X))(X - \tilde x)

    is evaluated in python-flint ``acb`` arithmetic at ``prec`` bits; K(X) inside the interior
    of X proves a unique solution in X (Krawczyk 1969, Moore): an exact zero of the pencil,
    with a certified enclosure of lam and of the vector. A tall pencil whose candidate does not
    give a square restricted system is not certified.

    Parameters
    ----------
    P0, P1 : rows of Fraction (:class:`RationalRows`)
        The pencil P(lam) = P0 + lam P1; only the entries of the candidate's rows and support
        are read when ``nonzero`` is given.
    lam : complex
        Candidate zero.
    v : ndarray
        Candidate kernel vector.
    prec : int
        Working precision in bits.
    nonzero : ndarray of bool, optional
        The exact support of P0 or P1 (entry (i, j) True when P0[i][j] or P1[i][j] is nonzero),
        when the caller tests several candidates on one pencil; default: read from the rows.
    """
    import flint

    v = np.asarray(v, dtype=complex)
    ncol = len(P0[0]) if P0 else 0
    if v.size != ncol or ncol == 0 or not np.all(np.isfinite(v)) or not np.isfinite(lam):
        return None
    k = int(np.argmax(np.abs(v)))
    if v[k] == 0:
        return None
    v = v / v[k]
    S = [j for j in range(ncol) if abs(v[j]) > 1e-13]
    if nonzero is not None:
        R = np.flatnonzero(np.any(nonzero[:, S], axis=1)).tolist()
    else:
        R = [i for i in range(len(P0)) if any(P0[i][j] != 0 or P1[i][j] != 0 for j in S)]
    if len(R) != len(S):
        return None
    free = [j for j in S if j != k]
    # the exact entries of P[R, S], read once (lazy rows hand over the block without a call per row)
    E0, E1 = ((M.block(R, S) if hasattr(M, "block") else [[M[i][j] for j in S] for i in R]) for M in (P0, P1))
    Z = RATIONAL_ZERO  # lazy rows return it for their zeros: recognised by identity, not compared
    A0 = np.array([[0.0 if x is Z else float(x) for x in row] for row in E0], dtype=complex).reshape(len(R), len(S))
    A1 = np.array([[0.0 if x is Z else float(x) for x in row] for row in E1], dtype=complex).reshape(len(R), len(S))
    # per row, the columns where P0 or P1 is exactly nonzero: the ball sums below skip exact
    # zeros (adding an exact zero ball changes nothing, so the enclosures are the same)
    live = [
        [c for c in range(len(S)) if not (e0[c] is Z or e0[c] == 0) or not (e1[c] is Z or e1[c] == 0)]
        for e0, e1 in zip(E0, E1)
    ]
    fi = [S.index(j) for j in free]
    x = np.concatenate([v[free], [complex(lam)]])

    def vec(xx: np.ndarray) -> np.ndarray:
        w = np.ones(len(S), dtype=complex)
        w[fi] = xx[:-1]
        return w

    def jac(xx: np.ndarray) -> np.ndarray:
        Pl = A0 + xx[-1] * A1
        return np.column_stack([Pl[:, fi], A1 @ vec(xx)]) if fi else (A1 @ vec(xx)).reshape(-1, 1)

    try:
        for _ in range(6):
            step = np.linalg.solve(jac(x), (A0 + x[-1] * A1) @ vec(x))
            x = x - step
            if np.linalg.norm(step) <= 1e-15 * (1 + np.linalg.norm(x)):
                break
        Y = np.linalg.inv(jac(x))
    except np.linalg.LinAlgError:
        return None
    if not np.all(np.isfinite(Y)):
        return None
    old = flint.ctx.prec
    try:
        flint.ctx.prec = prec
        n = len(x)

        balls: dict[tuple[int, int], Any] = {}  # the entries repeat (zeros, weights): one exact ball each

        zero_ball = flint.acb(0)

        def q(a: Fraction) -> Any:
            if a is Z:
                return zero_ball
            key = (a.numerator, a.denominator)  # hashes faster than the Fraction
            b = balls.get(key)
            if b is None:
                b = balls[key] = flint.acb(flint.arb(flint.fmpq(*key)))
            return b

        B0 = [[q(x) for x in row] for row in E0]
        B1 = [[q(x) for x in row] for row in E1]
        xt = [flint.acb(complex(c)) for c in x]
        r = max(1e-9 * (1.0 + float(np.max(np.abs(x)))), 1e3 * float(np.max(np.abs(Y @ ((A0 + x[-1] * A1) @ vec(x))))))
        ball = flint.acb(flint.arb(0, r), flint.arb(0, r))
        X = [c + ball for c in xt]

        def f_at(z: list[Any]) -> list[Any]:
            w = [flint.acb(1)] * len(S)
            for t, col in enumerate(fi):
                w[col] = z[t]
            return [sum((B0[i][c] + z[-1] * B1[i][c]) * w[c] for c in live[i]) for i in range(len(R))]

        def j_at(z: list[Any]) -> list[list[Any]]:
            w = [flint.acb(1)] * len(S)
            for t, col in enumerate(fi):
                w[col] = z[t]
            rows = []
            for i in range(len(R)):
                row = [B0[i][c] + z[-1] * B1[i][c] for c in fi]
                row.append(sum(B1[i][c] * w[c] for c in live[i]))
                rows.append(row)
            return rows

        # K(X) = x~ - Y f(x~) + (I - Y J(X)) (X - x~), the products in ball matrix arithmetic
        Ya = flint.acb_mat([[flint.acb(complex(Y[a, b])) for b in range(n)] for a in range(n)])
        fx = flint.acb_mat(n, 1, f_at(xt))
        JX = flint.acb_mat(j_at(X))
        dX = flint.acb_mat(n, 1, [X[c] - xt[c] for c in range(n)])
        Kv = flint.acb_mat(n, 1, xt) - Ya * fx + (flint.acb_mat(n, n, [flint.acb(int(a == c)) for a in range(n) for c in range(n)]) - Ya * JX) * dX
        Kx = [Kv[a, 0] for a in range(n)]
        if not all(X[a].contains_interior(Kx[a]) for a in range(n)):
            return None
        w = [flint.acb(0)] * ncol
        w[k] = flint.acb(1)
        for t, col in enumerate(free):
            w[col] = Kx[t]
        return KernelEnclosure(Kx[-1], w, tuple(S), k)
    finally:
        flint.ctx.prec = old
