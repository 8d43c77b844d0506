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
import scipy.sparse
import scipy.sparse.csgraph
import scipy.sparse.linalg

from glocal_verify import config
from glocal_verify.errors import ModelError
from glocal_verify.numerics.balancing import (
    _REAL_CUTOFF,
    _balance,
    _Balanced,
    _reduce,
    _rosenbrock,
    _rounding,
)
from glocal_verify.numerics.tolerance import DEFAULT_TOLERANCE, Decision, Tolerance

__all__ = [
    "Zero",
    "PencilAnalysis",
    "analyze_pencil",
    "direction_at",
    "input_directions",
    "pencil_matrix",
    "cluster_points",
]

#: seed of the fixed pseudo-random points at which the normal rank is cross-checked
_NORMAL_RANK_SEED = 20211007


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
        State and input parts of a zeroing direction in the caller's coordinates,
        ``||[x; u]|| = 1``, phase chosen so the largest entry is real and positive. The
        direction is taken from the kernel of the balanced pencil P_b(lambda0) that the
        verification certified (see the module docstring): among those kernel vectors the one
        with the largest balanced input part, so ``u == 0`` means that the kernel at lambda0
        holds no direction with a nonzero input (an unobservable mode). Empty arrays when the
        analysis ran with ``verify=False``.
    residual : float
        ``sigma_r(P_b(lambda0)) / scale`` with r the normal rank and P_b the balanced pencil:
        the relative distance from the balanced data to a system with a rank drop at lambda0
        (NaN when not verified).
    multiplicity : int
        Number of eigenvalues of the regular part merged into this zero (algebraic
        multiplicity as seen by the regular part).
    verified : bool
        True when the rank drop *and* the direction's residual are zero at the tolerance,
        after adding the SVD's own error bound; False when either lies in the undecided band
        (or verification was skipped).
    direction_residual : float
        ``||P_b(lambda0) v_b|| / (scale ||v_b||)`` for the returned direction mapped to the
        balanced coordinates, ``v_b = diag(T, Su)^-1 [x; u]`` (NaN when not verified).
    """

    value: complex
    x: np.ndarray
    u: np.ndarray
    residual: float
    multiplicity: int = 1
    verified: bool = True
    direction_residual: float = float("nan")


def _empty() -> np.ndarray:
    return np.zeros(0)


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
        Finite zeros (rank drops below the normal rank), each verified on the full balanced
        pencil unless ``verify=False`` was asked.
    decided : bool
        True only when every bound of the module docstring separates its cases: each kept
        singular value of the deflation exceeds ``rtol * band * scale`` plus the accumulated
        backward error, every finite/infinite split of the QZ eigenvalues is clear, the
        random-point normal rank agrees, and every eigenvalue verifies as a zero (rank drop
        and direction residual). False otherwise, with the reason in ``notes``.
    tolerance : float
        The ``rtol`` used.
    n_outputs : int
        p.
    scale : float
        ``||[A_b B_b; C_b D_b]||_2`` of the balanced data (or the caller's scale), against
        which every rank, zero and direction was decided.
    notes : tuple of str
        Why the analysis is undecided, eigenvalues that failed verification, ...
    backward_error : float
        Bound delta / scale on the backward error of the deflation actually performed (the
        singular values set to zero plus ``c d eps scale`` per unitary operation, c = 8): the
        normal rank and the regular part are exact for a system within ``delta`` of the
        balanced data.
    state_scaling, input_scaling, output_scaling : ndarray
        The powers of two t, su, sy of the balancing: the decisions were made on
        (T^-1 A T, T^-1 B Su, Sy C T, Sy D Su) with T = diag(t), Su = diag(su),
        Sy = diag(sy) (all ones with ``balance=False``).
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
    backward_error: float = 0.0
    state_scaling: np.ndarray = field(default_factory=_empty)
    input_scaling: np.ndarray = field(default_factory=_empty)
    output_scaling: np.ndarray = field(default_factory=_empty)

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
    return (A.astype(dt, copy=False), B.astype(dt, copy=False), C.astype(dt, copy=False), D.astype(dt, copy=False))  # callers never write into them


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
    return _rosenbrock(A, B, C, D, lam)


# ------------------------------------------------------------------------------------------
# verification on the full balanced pencil


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
    if np.iscomplexobj(out) and np.all(np.abs(out.imag) <= _REAL_CUTOFF * np.max(np.abs(out.real), initial=1.0)):
        out = out.real.copy()
    return out


def _decide_small(value: float, err: float, scale: float, tol: Tolerance, delta: float = 0.0) -> Decision:
    """Is a computed quantity (singular value, residual) zero at the tolerance?

    ZERO when ``value + err <= rtol * scale`` (the exact quantity is then within the
    tolerance), NONZERO when ``value - err > rtol * band * scale + delta``, else UNDECIDED;
    ``err`` is the rounding bound of the computation that produced ``value``.
    """
    if value + err <= tol.rtol * scale:
        return Decision.ZERO
    if value - err > tol.upper * scale + delta:
        return Decision.NONZERO
    return Decision.UNDECIDED


@dataclass(slots=True)
class _Point:
    """SVD of the balanced pencil at one point, with the rank-drop decision at rank r."""

    lam: complex
    s: np.ndarray  # padded with zeros to the column count
    Vh: np.ndarray | None
    err: float
    sigma: float
    decision: Decision


def _svd_point(bal: _Balanced, lam: complex, r: int, scale: float, tol: Tolerance, vectors: bool) -> _Point:
    P = bal.pencil(lam)
    rows, ncols = P.shape
    if ncols == 0:
        return _Point(lam, np.zeros(0), np.zeros((0, 0)), 0.0, 0.0, Decision.NONZERO)
    if vectors:
        _, s, Vh = np.linalg.svd(P, full_matrices=True)
    else:
        s, Vh = np.linalg.svd(P, compute_uv=False), None
    s_full = np.zeros(ncols)
    s_full[: len(s)] = s
    err = _rounding(rows + ncols, float(s_full[0]))
    idx = min(r, ncols) - 1
    if idx < 0:
        return _Point(lam, s_full, Vh, err, 0.0, Decision.ZERO)
    sigma = float(s_full[idx])
    return _Point(lam, s_full, Vh, err, sigma, _decide_small(sigma, err, scale, tol))


def _direction(
    bal: _Balanced, pt: _Point, r: int, scale: float, tol: Tolerance
) -> tuple[np.ndarray, float, Decision]:
    """Direction from the kernel the decision at ``pt`` certified, in caller coordinates.

    The kernel is spanned by the right singular vectors beyond index r - 1 (dimension
    ncols - r + 1, the least a rank drop below the normal rank r gives) and any earlier ones
    whose singular value is certainly zero; never an undecided one. Among them the vector with
    the largest input part (balanced coordinates). Returns (v, ||P_b v_b|| / ||v_b||, its
    decision) with v normalised in the caller's coordinates and v_b = diag(T, Su)^-1 v.
    """
    assert pt.Vh is not None
    ncols = pt.s.size
    n = bal.A.shape[0]
    certain_zero = pt.s + pt.err <= tol.rtol * scale
    k0 = min(max(r - 1, 0), int(np.sum(~certain_zero)))
    K = pt.Vh[k0:].conj().T
    if K.shape[1] == 0:  # pragma: no cover - only when r > ncols, excluded by the deflation
        return np.zeros(ncols), float("inf"), Decision.NONZERO
    vb = _max_input_vector(K, n)
    v, vb2 = bal.to_caller(vb)
    nvb = float(np.linalg.norm(vb2))
    res = float(np.linalg.norm(bal.pencil(pt.lam) @ vb2)) / nvb if nvb > 0 else float("inf")
    return v, res, _decide_small(res, pt.err, scale, tol)


def cluster_points(values: Sequence[complex], radius: float) -> list[list[int]]:
    """Single-linkage clusters of points closer than ``radius`` (Euclidean, in the complex plane).

    The close pairs come from a k-d tree (``scipy.spatial.cKDTree.query_pairs``), the
    clusters from the connected components of the pair graph: O(n log n + pairs), also when
    many points share one real part (a sweep over the real part is quadratic then). Groups
    and their members are ordered by (real, imag).
    """
    import scipy.sparse
    from scipy.sparse.csgraph import connected_components

    n = len(values)
    if n == 0:
        return []
    order = sorted(range(n), key=lambda i: (values[i].real, values[i].imag))
    pts = np.array([[complex(v).real, complex(v).imag] for v in values], dtype=float)
    if n <= config.get("cluster_dense_max"):
        # few points (a cluster pencil's zeros): all pairwise distances, without the tree's set-up
        d = np.hypot(pts[:, None, 0] - pts[None, :, 0], pts[:, None, 1] - pts[None, :, 1])
        pairs = np.argwhere(np.triu(d <= radius, 1)) if radius >= 0 else np.zeros((0, 2), int)
        if not len(pairs):
            return [[i] for i in order]
    else:
        from scipy.spatial import cKDTree  # imported only here: scipy.spatial costs ~0.1 s to import

        pairs = cKDTree(pts).query_pairs(radius, output_type="ndarray") if n > 1 and radius >= 0 else np.zeros((0, 2), int)
    g = scipy.sparse.coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(n, n)) if len(pairs) else scipy.sparse.coo_matrix((n, n))
    _, labels = connected_components(g, directed=False)
    groups: dict[int, list[int]] = {}
    for i in order:
        groups.setdefault(int(labels[i]), []).append(i)
    return list(groups.values())


def _cluster_relative(values: Sequence[complex], rel: float) -> list[list[int]]:
    """Single-linkage clusters of points with ``|z_i - z_j| <= rel (1 + max(|z_i|, |z_j|))``.

    The sweep over the real part stops once the real gap exceeds ``rel (1 + |z_i|) / (1 - rel)``:
    beyond it ``|z_i - z_j| > rel (1 + |z_i| + |z_i - z_j|) >= rel (1 + |z_j|)``.
    """
    order = sorted(range(len(values)), key=lambda i: (values[i].real, values[i].imag))
    parent = list(range(len(values)))

    def find(i: int) -> int:
        while parent[i] != i:
            parent[i] = parent[parent[i]]
            i = parent[i]
        return i

    for a_pos, i in enumerate(order):
        reach = rel * (1.0 + abs(values[i])) / (1.0 - rel)
        for j in order[a_pos + 1 :]:
            if values[j].real - values[i].real > reach:
                break
            if abs(values[i] - values[j]) <= rel * (1.0 + max(abs(values[i]), abs(values[j]))):
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
    balance: bool = True,
) -> PencilAnalysis:
    """Normal rank, left-invertibility and verified finite zeros of a Rosenbrock pencil.

    .. math::

        P(\\lambda) = \\begin{bmatrix} \\lambda I - A & -B \\\\ C & D \\end{bmatrix},\\qquad
        z \\text{ is a zero} \\iff \\operatorname{rank} P(z) < \\operatorname{nrank} P

    (Definition II.2, eq. ``inv_zeros``). Method: see the module docstring (power-of-two
    balancing, orthogonal deflation, QZ on the regular part, verification and directions on
    the full balanced pencil, each decision against a stated bound).

    Parameters
    ----------
    A, B, C, D : array_like
        System matrices, shapes (n, n), (n, m), (p, n), (p, m); ``D = None`` means zero.
        Real or complex.
    tol : Tolerance
        Every decision is made on the balanced data against ``scale``: a deflation singular
        value ``<= rtol * scale`` is zero, one above ``rtol * band * scale`` plus the
        accumulated backward error nonzero, undecided in between. A QZ eigenvalue with
        ``|lam| > scale / rtol`` is infinite. A zero verifies when ``sigma_r(P_b(z))`` plus
        the SVD's error bound is ``<= rtol * scale``, and so must its direction's residual.
    verify : bool
        Verify every zero on the full balanced pencil (one SVD of size (n+p) x (n+m) per
        zero) and cross-check the normal rank at random points. ``False`` skips both: the
        zeros are then the unverified QZ eigenvalues (one per eigenvalue, not merged) with
        empty directions; callers that verify on their own structure (e.g.
        :mod:`glocal_verify.conditions.stealthy`) use it.
    scale : float, optional
        Scale of the decisions on the balanced data; default ``||[A_b B_b; C_b D_b]||_2``
        (a power-iteration estimate when min(n + p, n + m) > 600).
    balance : bool
        Balance the data by powers of two first (default). ``False`` decides on the data as
        given (scalings all one).

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
    bal = _balance(A, B, C, D, balance)
    if scale is None:
        scale = bal.norm()
    scale = float(scale) if scale and scale > 0.0 else 1.0
    notes: list[str] = []
    A1, B1, C1, D1, acc1, und1, delta = _reduce(bal.A, bal.B, bal.C, bal.D, tol, scale, 0.0)
    A2, B2, C2, D2, acc2, und2, delta = _reduce(A1.T, C1.T, B1.T, D1.T, tol, scale, delta)
    decided = not (und1 or und2)
    if und1 or und2:
        notes.append(
            "a rank decision of the deflation fell in the undecided band "
            f"(between rtol and rtol * band of the scale, plus the backward error {delta / scale:.3g})"
        )
    k = D2.shape[0]
    if D2.shape[0] != D2.shape[1]:  # pragma: no cover - excluded by the theory of the deflation
        raise AssertionError(f"deflation left a non-square D ({D2.shape}); please report")
    n2 = A2.shape[0]
    normal_rank = acc1 + acc2 + k + n2
    eigs: list[complex] = []
    if n2 > 0:
        dcond = float(np.linalg.cond(D2)) if k > 0 else 1.0
        if dcond <= config.get("standard_eig_cond"):
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
    zeros: list[Zero] = []
    empty = np.zeros(0)

    def result(zs: tuple[Zero, ...]) -> PencilAnalysis:
        return PencilAnalysis(
            n, m, normal_rank, normal_rank == n + m, zs, decided, tol.rtol, p, scale, tuple(notes),
            delta / scale, bal.t, bal.su, bal.sy,
        )  # fmt: skip

    if not verify:  # raw QZ eigenvalues: merging needs verification, which the caller does
        return result(tuple(Zero(z, empty, empty, float("nan"), 1, False) for z in eigs))

    # cross-check of the normal rank at pseudo-random points of the balanced pencil
    rng = np.random.default_rng(_NORMAL_RANK_SEED)
    a_scale = max(float(np.abs(bal.A).max()) if bal.A.size else 0.0, 1.0)
    ranks: list[tuple[int, int]] = []
    for _ in range(config.get("normal_rank_points")):
        z = math.sqrt(a_scale) * (0.5 + rng.random()) * np.exp(2j * np.pi * rng.random())
        P = bal.pencil(z)
        s = np.linalg.svd(P, compute_uv=False) if P.size else np.zeros(0)
        err = _rounding(sum(P.shape), float(s[0]) if s.size else 0.0)
        lo = int(np.sum(s - err > tol.upper * scale + delta))  # certainly nonzero, even for the deflated system
        hi = int(np.sum(s + err > tol.rtol * scale))  # not certainly zero
        ranks.append((lo, hi))
    r_lo = max(r[0] for r in ranks)
    r_hi = max(r[1] for r in ranks)
    # the rank at any point is <= the normal rank; a point certainly above it, or every point
    # certainly below it, contradicts the deflation
    if r_lo > normal_rank or r_hi < normal_rank:
        decided = False
        notes.append(f"normal rank {normal_rank} from the deflation vs {r_lo}..{r_hi} at random points")

    r = normal_rank

    def accept(pt: _Point, mult: int) -> Zero:
        nonlocal decided
        v, res, dres = _direction(bal, pt, r, scale, tol)
        ok = pt.decision is Decision.ZERO and dres is Decision.ZERO
        if pt.decision is Decision.UNDECIDED:
            decided = False
            notes.append(f"zero {pt.lam} verified only to the undecided band (residual {pt.sigma / scale:.3g})")
        elif dres is not Decision.ZERO:
            decided = False
            notes.append(f"zero {pt.lam}: the direction's residual {res / scale:.3g} is not zero at the tolerance")
        return Zero(pt.lam, v[:n], v[n:], pt.sigma / scale, mult, ok, res / scale)

    rel = math.sqrt(tol.upper)
    for c in _cluster_relative(eigs, rel):
        members = [eigs[i] for i in c]
        if len(c) > 1:
            worst = max(_svd_point(bal, z, r, scale, tol, False).sigma for z in members)
            pm = _svd_point(bal, complex(np.mean(members)), r, scale, tol, True)
            if pm.decision is Decision.ZERO and pm.sigma <= worst + pm.err:
                zeros.append(accept(pm, len(c)))
                continue
        for z in members:
            pt = _svd_point(bal, z, r, scale, tol, True)
            if pt.decision is Decision.NONZERO:
                decided = False
                notes.append(
                    f"eigenvalue {z} of the regular part failed verification on the full pencil (residual {pt.sigma / scale:.3g})"
                )
                continue
            zeros.append(accept(pt, 1))
    zeros.sort(key=lambda z: (-z.value.real, -abs(z.value.imag)))
    return result(tuple(zeros))


def _nullity_bounds(M: np.ndarray, scale: float, tol: Tolerance) -> tuple[int, int]:
    """Bounds on the nullity of ``M`` at the tolerance: (certainly zero singular values, not
    certainly nonzero ones), each decided as :func:`_decide_small` decides."""
    ncols = M.shape[1]
    if ncols == 0:
        return 0, 0
    s = np.zeros(ncols)
    sv = np.linalg.svd(M, compute_uv=False) if M.size else np.zeros(0)
    s[: len(sv)] = sv[:ncols]
    err = _rounding(sum(M.shape), float(s[0]))
    decisions = [_decide_small(float(v), err, scale, tol) for v in s]
    return sum(d is Decision.ZERO for d in decisions), sum(d is not Decision.NONZERO for d in decisions)


def input_directions(
    A: Any, B: Any, C: Any, D: Any, points: Sequence[complex], tol: Tolerance = DEFAULT_TOLERANCE
) -> tuple[Decision, ...]:
    """Whether the kernel of the pencil at each point holds a direction with a nonzero input.

    A zero lambda0 of the Rosenbrock pencil is a zero-dynamics *attack* only when its kernel has
    a direction ``[x; u]`` with ``u != 0`` (Definition II.2 with ``u0 != 0``); a kernel with
    ``u = 0`` only is an unobservable mode of (A, C). Since ``ker [lambda0 I - A; C] x {0}``
    lies in ``ker P(lambda0)``,

    .. math::

        \\exists\\, [x; u] \\in \\ker P(\\lambda_0),\\ u \\ne 0 \\iff
        \\dim\\ker P(\\lambda_0) > \\dim\\ker \\begin{bmatrix} \\lambda_0 I - A \\\\ C \\end{bmatrix}

    (for ``D = 0``; with ``D`` the state columns are ``[lambda0 I - A; C]`` all the same). Both
    nullities are bounded on the balanced pencil by its singular values against the SVD's
    error bound and the tolerance (as :func:`direction_at` decides a rank drop): ``NONZERO``
    (an input direction exists) when the pencil's certain nullity exceeds the state part's
    possible one, ``ZERO`` (none: an unobservable mode) when the pencil's possible nullity is at
    most the state part's certain one, ``UNDECIDED`` otherwise. The largest input part of a
    computed kernel vector is no such test: rounding leaves it nonzero at every zero.

    Parameters
    ----------
    A, B, C, D : array_like
        System matrices (``D = None`` means zero).
    points : sequence of complex
        The zeros to classify.
    tol : Tolerance

    Returns
    -------
    tuple of Decision
        One per point: NONZERO (an attack direction), ZERO (none), UNDECIDED.
    """
    A, B, C, D = _system(A, B, C, D)
    n = A.shape[0]
    bal = _balance(A, B, C, D)
    scale = bal.norm()
    scale = scale if scale > 0.0 else 1.0
    out = []
    for lam in points:
        P = bal.pencil(complex(lam))
        full_lo, full_hi = _nullity_bounds(P, scale, tol)
        state_lo, state_hi = _nullity_bounds(P[:, :n], scale, tol)
        if full_lo > state_hi:
            out.append(Decision.NONZERO)
        elif full_hi <= state_lo:
            out.append(Decision.ZERO)
        else:
            out.append(Decision.UNDECIDED)
    return tuple(out)


def direction_at(
    A: Any, B: Any, C: Any, D: Any, lam: complex, tol: Tolerance = DEFAULT_TOLERANCE
) -> tuple[np.ndarray, np.ndarray] | None:
    """A zeroing direction (x, u) of the pencil at ``lam``, or None if there is none.

    Decided on the balanced pencil P_b (see the module docstring) against its data norm
    ``scale = ||[A_b B_b; C_b D_b]||_2``: the smallest singular value of P_b(lam) plus the
    SVD's error bound ``c d eps ||P_b(lam)||`` must be ``<= rtol * scale`` (a system within
    ``rtol * scale`` of the data has lam as a rank drop; an undecided value also gives None).
    The direction is taken from the certainly-zero right singular vectors only: the one with
    the largest input part (its ``u`` is zero only if every such kernel vector has u = 0); its
    residual ``||P_b v_b||`` must pass the same bound, else None. It is returned in the
    caller's coordinates, normalised to ``||[x; u]|| = 1`` with its largest entry real and
    positive.

    Parameters
    ----------
    A, B, C, D : array_like
        System matrices (``D = None`` means zero).
    lam : complex
        The point lambda.
    tol : Tolerance
        Decides ``sigma_min(P_b(lam)) / scale`` and the direction's residual.
    """
    A, B, C, D = _system(A, B, C, D)
    n = A.shape[0]
    bal = _balance(A, B, C, D)
    scale = bal.norm()
    scale = scale if scale > 0.0 else 1.0
    ncols = n + B.shape[1]
    if ncols == 0:
        return None
    pt = _svd_point(bal, lam, ncols, scale, tol, True)
    if pt.decision is not Decision.ZERO:
        return None
    v, _res, dres = _direction(bal, pt, ncols, scale, tol)
    if dres is not Decision.ZERO:
        return None
    return v[:n], v[n:]
