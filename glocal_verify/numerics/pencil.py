"""Rosenbrock system pencils: normal rank, invariant zeros and zeroing directions.

For a system (A, B, C, D) with n states, m inputs and p outputs the Rosenbrock pencil is

.. math::

    P(\\lambda) = \\begin{bmatrix} \\lambda I_n - A & -B \\\\ C & D \\end{bmatrix}
    \\in \\mathbb C^{(n+p) \\times (n+m)}

(Definition II.2, eq. ``inv_zeros``). Its *normal rank* is the rank at all but finitely many
lambda; it has full normal column rank (n + m) iff the system is left-invertible. A finite
*invariant zero* is a lambda where the rank drops below the normal rank, and a *zeroing
direction* at lambda is any nonzero (x, u) with P(lambda) [x; u] = 0. When the pencil does not
have full normal column rank, a zeroing direction exists at **every** lambda; that is the
information python-control's ``zeros()`` (SLICOT AB08ND) throws away, and the reason this
module reports the normal rank next to the zeros.

Numeric method (:func:`analyze_pencil`)
    1. *Balancing.* States, inputs and outputs are scaled by powers of two,
       (A, B, C, D) -> (T^-1 A T, T^-1 B Su, Sy C T, Sy D Su), so that the balanced pencil
       P_b(lambda) = diag(T^-1, Sy) P(lambda) diag(T, Su) has entries of magnitude close to 1:
       the exponents minimise the sum of squared log2-magnitudes of the nonzero entries (the
       diagonal of A, which no such scaling changes, left out), a weighted graph-Laplacian
       least-squares problem (Ward 1981's criterion for ``xGGBAL``, here with one scaling per
       state for rows and columns so that lambda I stays lambda I; in the spirit of SLICOT
       TB01ID and MatrixPencils.jl ``lsbalance!``). Multiplying by powers of two is exact in
       floating point, so P_b has exactly the rank of P at every lambda, the same zeros, and
       kernels ker P(lambda) = diag(T, Su) ker P_b(lambda). A diagonal state scaling of the
       data by powers of two only shifts the exponents, so the balanced data, and with it every
       decision below, is the same for the data and its rescalings.
    2. *Deflation* in the style of Emami-Naeini and Van Dooren (1982) on the balanced data:
       repeatedly compress the rows of D (SVD) and the columns of the remaining output rows
       (SVD, applied to A as a product of Householder reflectors), deflating the states that
       the outputs pin down, until D has full row rank; then do the same on the dual system,
       after which D is square and invertible. The finite zeros are then the eigenvalues of
       the Schur complement A - B D^{-1} C when cond(D) <= 1e4, else the QZ eigenvalues of the
       square regular pencil lambda E - M left by compressing [C D] to [0 R].
    3. *Bounds.* With nu = ||[A_b B_b; C_b D_b]||_2 (``scale``), eps the unit roundoff and d
       the row plus column count of the matrix at hand, each SVD or Householder step is taken
       to have a normwise backward error of at most ``c d eps nu``, c = 8 (LAPACK Users'
       Guide, section 4.9, and Higham, *Accuracy and Stability of Numerical Algorithms*, ch.
       19, with the modest polynomial p(d) taken as c d). Singular values ``<= rtol nu`` are
       set to zero; their sizes plus the rounding bound of every step performed accumulate
       into the backward error delta of the deflation: its result (normal rank, number and
       values of the regular part's eigenvalues) is exact for a system within delta of the
       balanced data. A kept singular value is *certainly* nonzero only when it exceeds
       ``rtol * band * nu + delta`` (Weyl: no perturbation of size delta removes it); one in
       between is undecided and makes the analysis ``decided = False``.
    4. *Verification* of every eigenvalue z on the full balanced pencil: sigma_r(P_b(z)) with r
       the normal rank is the distance (in the 2-norm of the data) from the balanced data to a
       system for which z is a rank drop, since lambda I is exact. z is a zero at the
       tolerance iff ``sigma_r + c d eps ||P_b(z)|| <= rtol nu`` (the second term bounds the
       error of that SVD); it is certainly not one when ``sigma_r - c d eps ||P_b(z)|| >
       rtol band nu``; else undecided. Eigenvalues closer than ``sqrt(rtol band) (1 + max
       |z_i|)`` form a cluster whose mean is taken as one multiple zero only if it verifies
       and its residual is no worse than its members' (up to the SVD bound); else each member
       stands alone.
    5. *Directions* come from exactly the kernel the verification certified: the right
       singular vectors of P_b(z) beyond index r - 1 (the kernel dimension the normal rank
       gives) and any further ones whose singular value is certainly zero; among them the
       vector with the largest (balanced) input part. Its residual ``||P_b(z) v_b||`` is
       checked against the same bound (else the zero is undecided), then it is mapped back,
       v = diag(T, Su) v_b, and normalised in the caller's coordinates.
    6. *Cross-check of the normal rank* at three fixed pseudo-random complex points of modulus
       in [0.5, 1.5] sqrt(max(1, max |(A_b)_ij|)) (far out, pencils of high relative degree
       look singular; near 0 the zeros of Laplacian dynamics sit): a point where sigma_{r+1}
       of P_b is certainly nonzero (above delta + the SVD bound), or three points where
       sigma_r is certainly zero, contradict the deflation and mark the analysis undecided.
    The observability matrix is never formed.

Exact method (:func:`analyze_pencil_exact`, D = 0 only)
    The geometric approach over Q (Trentelman, Stoorvogel & Hautus, ch. 7-8): V* = the largest
    (A, B)-invariant subspace in ker C by V_0 = ker C, V_{k+1} = ker C ∩ A^{-1}(V_k + Im B);
    R* = the largest controllability subspace in V* by R_0 = 0, R_{k+1} = V* ∩ (A R_k + Im B).
    The system is left-invertible iff B is injective and V* ∩ Im B = {0}; the invariant zeros
    are the eigenvalues of A + B F on V*/R* for a friend F of V* (the zero polynomial is the
    characteristic polynomial of that map, factored over Q). Ranks and kernels at an
    algebraic lambda0 are computed exactly in the field Q[x]/(f(x)) of its minimal
    polynomial f. Nothing in the exact path is ever undecided.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, Sequence

import numpy as np
import scipy.linalg

from glocal_verify.errors import ModelError
from glocal_verify.numerics.tolerance import DEFAULT_TOLERANCE, Decision, Tolerance

__all__ = [
    "Zero",
    "PencilAnalysis",
    "analyze_pencil",
    "direction_at",
    "pencil_matrix",
]

#: seed of the fixed pseudo-random points at which the normal rank is cross-checked
_NORMAL_RANK_SEED = 20211007
_NORMAL_RANK_POINTS = 3
#: below this condition number of the final square D, zeros come from eig(A - B D^{-1} C)
_STANDARD_EIG_COND = 1e4


# ------------------------------------------------------------------------------------------
# numeric


@dataclass(frozen=True, slots=True)
class Zero:
    """A finite invariant zero with its zeroing direction.

    Attributes
    ----------
    value : complex
        The zero lambda0.
    x, u : ndarray
        State and input parts of a zeroing direction, ``||[x; u]|| = 1``, phase chosen so the
        largest entry is real and positive. Among the (numerical) kernel vectors of
        P(lambda0) the one with the largest input part is taken, so ``u == 0`` means that the
        kernel at lambda0 holds no direction with a nonzero input (an unobservable mode).
        Empty arrays when the analysis ran with ``verify=False``.
    residual : float
        ``sigma_r(P(lambda0)) / ||P(lambda0)||_2`` with r the normal rank (NaN when not
        verified).
    multiplicity : int
        Number of QZ eigenvalues merged into this zero (algebraic multiplicity as seen by the
        regular part).
    verified : bool
        True when the residual is zero at the tolerance; False when it lies in the undecided
        band (or verification was skipped).
    """

    value: complex
    x: np.ndarray
    u: np.ndarray
    residual: float
    multiplicity: int = 1
    verified: bool = True


@dataclass(frozen=True, slots=True)
class PencilAnalysis:
    """Normal rank and finite zeros of a Rosenbrock pencil (numeric).

    Attributes
    ----------
    n_states, n_inputs : int
        n and m.
    normal_rank : int
        Normal rank of [[lam I - A, -B], [C, D]] from the deflation.
    full_normal_column_rank : bool
        ``normal_rank == n_states + n_inputs`` (left-invertible system).
    zeros : tuple of Zero
        Finite zeros (rank drops below the normal rank), each verified on the full pencil
        unless ``verify=False`` was asked.
    decided : bool
        False when a rank or zero decision fell in the undecided band, when the random-point
        normal rank disagrees, or when a QZ eigenvalue failed verification.
    tolerance : float
        The ``rtol`` used.
    n_outputs : int
        p.
    scale : float
        ``||[A B; C D]||_2`` (or the caller's scale), against which ranks were decided.
    notes : tuple of str
        Why the analysis is undecided, eigenvalues that failed verification, ...
    """

    n_states: int
    n_inputs: int
    normal_rank: int
    full_normal_column_rank: bool
    zeros: tuple[Zero, ...]
    decided: bool
    tolerance: float
    n_outputs: int = 0
    scale: float = 0.0
    notes: tuple[str, ...] = field(default_factory=tuple)

    @property
    def left_invertible(self) -> bool:
        """Alias of :attr:`full_normal_column_rank`."""
        return self.full_normal_column_rank


def _system(A: Any, B: Any, C: Any, D: Any) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    A = np.asarray(A)
    if A.ndim != 2 or A.shape[0] != A.shape[1]:
        raise ModelError(f"A must be a square matrix, got shape {A.shape}")
    n = A.shape[0]
    B = np.asarray(B)
    if B.size == 0:
        B = np.zeros((n, B.shape[1] if B.ndim == 2 else 0))
    if B.ndim != 2 or B.shape[0] != n:
        raise ModelError(f"B must have {n} rows (one per state), got shape {B.shape}")
    C = np.asarray(C)
    if C.size == 0:
        C = np.zeros((C.shape[0] if C.ndim == 2 else 0, n))
    if C.ndim != 2 or C.shape[1] != n:
        raise ModelError(f"C must have {n} columns (one per state), got shape {C.shape}")
    p, m = C.shape[0], B.shape[1]
    if D is None:
        D = np.zeros((p, m))
    D = np.asarray(D)
    if D.size == 0:
        D = np.zeros((p, m))
    if D.shape != (p, m):
        raise ModelError(f"D must have shape ({p}, {m}), got {D.shape}")
    cplx = np.issubdtype(np.result_type(A, B, C, D, np.float64), np.complexfloating)
    dt: Any = np.complex128 if cplx else np.float64
    return (A.astype(dt), B.astype(dt), C.astype(dt), D.astype(dt))


def pencil_matrix(A: np.ndarray, B: np.ndarray, C: np.ndarray, D: np.ndarray | None, lam: complex) -> np.ndarray:
    """The Rosenbrock matrix P(lam) = [[lam I - A, -B], [C, D]].

    Parameters
    ----------
    A, B, C, D : array_like
        System matrices (D = None means zero).
    lam : complex
        Point of evaluation.
    """
    A, B, C, D = _system(A, B, C, D)
    n = A.shape[0]
    top = np.hstack([lam * np.eye(n) - A, -B])
    bottom = np.hstack([C, D])
    return np.vstack([top, bottom])


def _norm2(M: np.ndarray) -> float:
    if M.size == 0:
        return 0.0
    if min(M.shape) <= 600:
        return float(np.linalg.norm(M, 2))
    # power iteration on M^H M: a lower estimate within a few per cent after 60 steps
    rng = np.random.default_rng(0)
    x: np.ndarray = np.asarray(rng.standard_normal(M.shape[1]))
    est = 0.0
    for _ in range(60):
        y = M.conj().T @ (M @ x)
        ny = float(np.linalg.norm(y))
        if ny == 0.0:
            return float(np.abs(M).max())
        est = math.sqrt(ny / float(np.linalg.norm(x)))
        x = y / ny
    return max(est, float(np.abs(M).max()))


def _count(s: np.ndarray, scale: float, tol: Tolerance) -> tuple[int, bool]:
    """(number of singular values not certainly zero, whether any is undecided)."""
    if s.size == 0:
        return 0, False
    hi = int(np.sum(s > tol.rtol * scale))
    lo = int(np.sum(s > tol.upper * scale))
    return hi, hi != lo


def _block_reflector(V1: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Compact-WY form Q = I - Y T Y^H of the Householder QR of V1 (n x nu).

    Q is unitary and its first nu columns span Im V1. Applying Q to an n x n matrix costs two
    thin matrix products (O(nu n^2)), never an n x n orthogonal factor.
    """
    (qr, tau), _ = scipy.linalg.qr(V1, mode="raw")
    n, nu = V1.shape
    Y = np.tril(qr[:, :nu], -1)
    Y[np.arange(nu), np.arange(nu)] = 1.0
    T = np.zeros((nu, nu), dtype=qr.dtype)
    for i in range(nu):
        T[i, i] = tau[i]
        if i:
            T[:i, i] = -tau[i] * (T[:i, :i] @ (Y[:, :i].conj().T @ Y[:, i]))
    return Y, T


def _qh_left(Y: np.ndarray, T: np.ndarray, M: np.ndarray) -> np.ndarray:
    """Q^H M with Q = I - Y T Y^H."""
    if M.size == 0:
        return M
    return M - Y @ (T.conj().T @ (Y.conj().T @ M))


def _q_right(Y: np.ndarray, T: np.ndarray, M: np.ndarray) -> np.ndarray:
    """M Q with Q = I - Y T Y^H."""
    if M.size == 0:
        return M
    return M - ((M @ Y) @ T) @ Y.conj().T


def _reduce(
    A: np.ndarray, B: np.ndarray, C: np.ndarray, D: np.ndarray, tol: Tolerance, scale: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, int, bool]:
    """Deflate until D has full row rank; rank P(lam) = acc + rank P_reduced(lam) for all lam.

    One step: rotate the outputs so that D = [0; D2] with D2 of full row rank; the rows
    [C1, 0] with C1 != 0 have a row space of dimension nu; with a state rotation whose first
    nu coordinates span it, those rows read [C12, 0, 0] with C12 of full column rank, so (by
    unimodular row operations) the first nu states contribute exactly nu to the rank for
    every lambda. The rows of their state equation become new output rows.
    """
    acc = 0
    undecided = False
    while True:
        n, m, p = A.shape[0], B.shape[1], C.shape[0]
        if p == 0:
            break
        if m > 0:
            Ud, sd, _ = np.linalg.svd(D)
            rho, und = _count(sd, scale, tol)
            undecided |= und
        else:
            Ud, rho = np.eye(p, dtype=C.dtype), 0
        T = Ud.conj().T
        Ct, Dt = T @ C, T @ D
        if rho == p:
            C, D = Ct, Dt
            break
        C1, C2, D2 = Ct[rho:], Ct[:rho], Dt[:rho]
        if n == 0:
            C, D = C2, D2
            break
        _, sc, Vh = np.linalg.svd(C1, full_matrices=False)
        nu, und = _count(sc, scale, tol)
        undecided |= und
        if nu == 0:  # the rows [C1, 0] are zero: they do not count
            C, D = C2, D2
            break
        Y, Tw = _block_reflector(Vh[:nu].conj().T)
        At = _q_right(Y, Tw, _qh_left(Y, Tw, A))
        Bt = _qh_left(Y, Tw, B)
        C2t = _q_right(Y, Tw, C2)
        A, B = np.ascontiguousarray(At[nu:, nu:]), np.ascontiguousarray(Bt[nu:])
        C = np.vstack([At[:nu, nu:], C2t[:, nu:]])
        D = np.vstack([Bt[:nu], D2])
        acc += nu
    return A, B, C, D, acc, undecided


def _max_input_vector(K: np.ndarray, n: int) -> np.ndarray:
    """The unit vector of span(K) (orthonormal columns) with the largest input part K[n:]."""
    if K.shape[1] == 1 or K.shape[0] == n:
        return K[:, 0]
    _, _, Vh = np.linalg.svd(K[n:], full_matrices=True)
    return K @ Vh[0].conj()


def _normalize_phase(v: np.ndarray) -> np.ndarray:
    nv = float(np.linalg.norm(v))
    if nv == 0.0:
        return v
    v = v / nv
    k = int(np.argmax(np.abs(v)))
    ph = v[k] / abs(v[k])
    out = v / ph
    if np.iscomplexobj(out) and np.all(np.abs(out.imag) <= 1e-15 * np.max(np.abs(out.real), initial=1.0)):
        out = out.real.copy()
    return out


def _kernel_at(P: np.ndarray, r: int, n: int, tol: Tolerance) -> tuple[np.ndarray | None, float, Decision]:
    """Zeroing direction of P with the rank expected to drop below ``r``.

    Returns (vector or None, sigma_r / sigma_1, decision of that ratio).
    """
    ncols = P.shape[1]
    if ncols == 0:
        return None, 1.0, Decision.NONZERO
    _, s, Vh = np.linalg.svd(P, full_matrices=True)
    s_full = np.zeros(ncols)
    s_full[: len(s)] = s
    s1 = float(s_full[0]) if len(s) else 0.0
    idx = min(r, ncols) - 1  # r-th singular value (0-based r-1)
    ratio = float(s_full[idx] / s1) if (s1 > 0.0 and idx >= 0) else 0.0
    dec = tol.decide(ratio, 1.0) if s1 > 0.0 else Decision.ZERO
    if idx < 0:
        dec = Decision.ZERO
    k0 = int(np.sum(s_full > tol.upper * s1)) if s1 > 0.0 else 0
    if k0 >= ncols:
        return None, ratio, dec
    K = Vh[k0:].conj().T
    v = _normalize_phase(_max_input_vector(K, n))
    return v, ratio, dec


def _cluster(values: Sequence[complex], radius: float) -> list[list[int]]:
    """Single-linkage clusters of points closer than ``radius`` (sweep over the real part)."""
    order = sorted(range(len(values)), key=lambda i: (values[i].real, values[i].imag))
    parent = list(range(len(values)))

    def find(i: int) -> int:
        while parent[i] != i:
            parent[i] = parent[parent[i]]
            i = parent[i]
        return i

    for a_pos, i in enumerate(order):
        for j in order[a_pos + 1 :]:
            if values[j].real - values[i].real > radius:
                break
            if abs(values[i] - values[j]) <= radius:
                parent[find(j)] = find(i)
    groups: dict[int, list[int]] = {}
    for i in order:
        groups.setdefault(find(i), []).append(i)
    return list(groups.values())


def analyze_pencil(
    A: Any,
    B: Any,
    C: Any,
    D: Any = None,
    tol: Tolerance = DEFAULT_TOLERANCE,
    *,
    verify: bool = True,
    scale: float | None = None,
) -> PencilAnalysis:
    """Normal rank, left-invertibility and verified finite zeros of a Rosenbrock pencil.

    .. math::

        P(\\lambda) = \\begin{bmatrix} \\lambda I - A & -B \\\\ C & D \\end{bmatrix},\\qquad
        z \\text{ is a zero} \\iff \\operatorname{rank} P(z) < \\operatorname{nrank} P

    (Definition II.2, eq. ``inv_zeros``). Method: see the module docstring (orthogonal
    deflation, QZ on the regular part, verification on the full pencil).

    Parameters
    ----------
    A, B, C, D : array_like
        System matrices, shapes (n, n), (n, m), (p, n), (p, m); ``D = None`` means zero.
        Real or complex.
    tol : Tolerance
        Rank decisions: singular values ``<= rtol * scale`` are zero, ``> rtol * band *
        scale`` nonzero, undecided in between. A QZ eigenvalue with ``|lam| > scale / rtol``
        is infinite. Zero verification: ``sigma_r(P(z)) / ||P(z)||_2`` decided the same way.
    verify : bool
        Verify every zero on the full pencil (one SVD of size (n+p) x (n+m) per zero) and
        cross-check the normal rank at random points. ``False`` skips both: the zeros are
        then the unverified QZ eigenvalues (one per eigenvalue, not merged) with empty
        directions; callers that
        verify on their own structure (e.g. :mod:`glocal_verify.conditions.stealthy`) use it.
    scale : float, optional
        Scale of the rank decisions; default ``||[A B; C D]||_2`` (a power-iteration estimate
        when min(n + p, n + m) > 600).

    Returns
    -------
    PencilAnalysis

    Examples
    --------
    >>> import numpy as np
    >>> pa = analyze_pencil(np.array([[0.0, 1.0], [-2.0, -3.0]]), np.array([[0.0], [1.0]]), np.array([[1.0, 1.0]]))
    >>> pa.full_normal_column_rank, [round(z.value.real, 6) for z in pa.zeros]
    (True, [-1.0])
    """
    A, B, C, D = _system(A, B, C, D)
    n, m, p = A.shape[0], B.shape[1], C.shape[0]
    if scale is None:
        scale = _norm2(np.block([[A, B], [C, D]])) if (n + p) and (n + m) else 0.0
    scale = float(scale) if scale and scale > 0.0 else 1.0
    notes: list[str] = []
    A1, B1, C1, D1, acc1, und1 = _reduce(A, B, C, D, tol, scale)
    A2, B2, C2, D2, acc2, und2 = _reduce(A1.T, C1.T, B1.T, D1.T, tol, scale)
    decided = not (und1 or und2)
    if und1 or und2:
        notes.append("a rank decision of the deflation fell in the undecided band")
    k = D2.shape[0]
    if D2.shape[0] != D2.shape[1]:  # pragma: no cover - excluded by the theory of the deflation
        raise AssertionError(f"deflation left a non-square D ({D2.shape}); please report")
    n2 = A2.shape[0]
    normal_rank = acc1 + acc2 + k + n2
    eigs: list[complex] = []
    if n2 > 0:
        dcond = float(np.linalg.cond(D2)) if k > 0 else 1.0
        if dcond <= _STANDARD_EIG_COND:
            # D square and well conditioned: the zeros are eig(A - B D^{-1} C) (the Schur
            # complement of D); a standard eigenproblem is several times cheaper than QZ
            M = A2 - B2 @ np.linalg.solve(D2, C2) if k > 0 else A2
            eigs = [complex(z) for z in np.linalg.eigvals(M)]
        else:
            G = np.hstack([C2, D2])
            Qz, _ = np.linalg.qr(G.conj().T, mode="complete")
            Z2 = Qz[:, k:]
            E = Z2[:n2]
            M = np.hstack([A2, B2]) @ Z2
            ab = scipy.linalg.eigvals(M, E, homogeneous_eigvals=True)
            for a_, b_ in zip(ab[0], ab[1]):
                d = tol.decide(abs(b_) * scale, abs(a_)) if abs(a_) > 0 else Decision.NONZERO
                if d is Decision.ZERO:
                    continue  # infinite eigenvalue
                if d is Decision.UNDECIDED:
                    decided = False
                    notes.append(f"eigenvalue {complex(a_ / b_)} is undecided between finite and infinite")
                eigs.append(complex(a_ / b_))
    radius = math.sqrt(tol.upper) * scale
    clusters = _cluster(eigs, radius)
    zeros: list[Zero] = []
    empty = np.zeros(0)
    if not verify:  # raw QZ eigenvalues: merging needs verification, which the caller does
        for z in eigs:
            zeros.append(Zero(z, empty, empty, float("nan"), 1, False))
        return PencilAnalysis(n, m, normal_rank, normal_rank == n + m, tuple(zeros), decided, tol.rtol, p, scale, tuple(notes))

    # cross-check of the normal rank at pseudo-random points
    rng = np.random.default_rng(_NORMAL_RANK_SEED)
    a_scale = max(float(np.abs(A).max()) if A.size else 0.0, 1.0)
    ranks: list[tuple[int, int]] = []
    for _ in range(_NORMAL_RANK_POINTS):
        z = math.sqrt(a_scale) * (0.5 + rng.random()) * np.exp(2j * np.pi * rng.random())
        P = pencil_matrix(A, B, C, D, z)
        s = np.linalg.svd(P, compute_uv=False)
        s1 = float(s[0]) if len(s) else 0.0
        hi = int(np.sum(s > tol.rtol * s1)) if s1 > 0 else 0
        lo = int(np.sum(s > tol.upper * s1)) if s1 > 0 else 0
        ranks.append((lo, hi))
    r_lo = max(r[0] for r in ranks)
    r_hi = max(r[1] for r in ranks)
    # the rank at any point is <= the normal rank; a point certainly above it, or every point
    # certainly below it, contradicts the deflation (points far out can look singular when
    # the relative degree is high, so an undecided singular value there is no contradiction)
    if r_lo > normal_rank or r_hi < normal_rank:
        decided = False
        notes.append(f"normal rank {normal_rank} from the deflation vs {r_lo}..{r_hi} at random points")

    def verify_one(z: complex, mult: int) -> Zero | None:
        nonlocal decided
        P = pencil_matrix(A, B, C, D, z)
        v, ratio, dec = _kernel_at(P, normal_rank, n, tol)
        if dec is Decision.NONZERO or v is None:
            return None
        if dec is Decision.UNDECIDED:
            decided = False
            notes.append(f"zero {z} verified only to the undecided band (residual {ratio:.3g})")
        return Zero(z, v[:n], v[n:], ratio, mult, dec is Decision.ZERO)

    for c in clusters:
        members = [eigs[i] for i in c]
        done = False
        if len(c) > 1:
            zc = verify_one(complex(np.mean(members)), len(c))
            if zc is not None and zc.verified:
                zeros.append(zc)
                done = True
        if not done:
            for z in members:
                zz = verify_one(z, 1)
                if zz is None:
                    decided = False
                    notes.append(f"QZ eigenvalue {z} of the regular part failed verification on the full pencil")
                else:
                    zeros.append(zz)
    zeros.sort(key=lambda z: (-z.value.real, -abs(z.value.imag)))
    return PencilAnalysis(n, m, normal_rank, normal_rank == n + m, tuple(zeros), decided, tol.rtol, p, scale, tuple(notes))


def direction_at(
    A: Any, B: Any, C: Any, D: Any, lam: complex, tol: Tolerance = DEFAULT_TOLERANCE
) -> tuple[np.ndarray, np.ndarray] | None:
    """A zeroing direction (x, u) of the pencil at ``lam``, or None if there is none.

    The smallest singular value of P(lam) must be zero relative to ``||P(lam)||_2`` at the
    tolerance (an undecided value also gives None). Among the kernel vectors the one with the
    largest input part is returned (its ``u`` is zero only if every kernel vector has u = 0),
    normalised to ``||[x; u]|| = 1`` with its largest entry real and positive.

    Parameters
    ----------
    A, B, C, D : array_like
        System matrices (``D = None`` means zero).
    lam : complex
        The point lambda.
    tol : Tolerance
        Decides ``sigma_min / sigma_max``.
    """
    A, B, C, D = _system(A, B, C, D)
    n = A.shape[0]
    P = pencil_matrix(A, B, C, D, lam)
    v, _ratio, dec = _kernel_at(P, P.shape[1], n, tol)
    if v is None or dec is not Decision.ZERO:
        return None
    return v[:n], v[n:]
