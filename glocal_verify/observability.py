"""Unobservable subspaces: per mode (modal structure), generic (staircase), exact, switched.

The closed loop of eq. ``cl_sys`` has a modal structure that reduces every observability
question to N-sized questions on the Laplacian. If ``L_q w = mu w`` then

.. math::

    A_q \\begin{bmatrix} a\\,w \\\\ b\\,w \\end{bmatrix}
    = \\begin{bmatrix} b\\,w \\\\ (-\\alpha\\mu a - \\gamma b)\\,w \\end{bmatrix},

so every space ``X (x) R^2 = {[w; z] : w, z in X}`` with ``X`` inside one eigenspace ``E_mu``
is A_q-invariant, and A_q acts on it as ``B_mu (x) I`` with
``B_mu = [[0, 1], [-alpha mu, -gamma]]`` (a Jordan block when ``gamma^2 = 4 alpha mu``). With
``W^x_mu = E_mu ∩ ker S_{M_x}`` and ``W_mu = E_mu ∩ ker S_M`` (``CONDITIONS.md``, "Modal
structure"):

.. math::

    \\mathcal N(A_q, C) = (W^x_0 \\times W_0) \\;\\oplus\\; \\bigoplus_{\\mu > 0} (W_\\mu \\times W_\\mu).

*Why.* Each summand is A_q-invariant and inside ``ker C`` (for ``mu > 0`` the velocity part of
``A_q [w; z]`` is ``-alpha mu w - gamma z``, which must be seen by neither monitor set, hence
``W_mu`` in both slots; for ``mu = 0`` a position ``w in ker L`` only needs ``S_{M_x} w = 0``).
Maximality: the unobservable subspace is A_q-invariant, hence the direct sum of its parts in
the A_q-invariant spaces ``E_mu (x) R^2``; inside ``E_mu (x) R^2`` an eigenvector of
``B_mu (x) I`` is ``[w; lam w]`` and lies in ``ker C`` iff ``S_{M_x} w = 0`` and
``lam S_{M_v} w = 0``, and an invariant subspace of ``ker C`` is spanned by such chains. The
``proofs_checks`` and the property tests compare the formula with exact rational ranks.

This module gives

* :func:`unobservable_subspace` -- the formula above from ``System.eigh`` (O(N^3) once for the
  eigendecomposition, then O(N k^2) per eigen-group of size k); scales to thousands of agents;
* :func:`unobservable_subspace_dense` -- a generic orthogonal staircase for any (A, C), for small
  systems and tests;
* :func:`unobservable_subspace_exact` -- the same subspace over Q (python-flint);
* :func:`switched_unobservable_subspace` -- Lemma II.3's backward recursion with modal
  exponentials;

and the checkers of ``switched-observability`` (Lemma II.3), ``privacy.unobservable``
(Lemma III.1), ``privacy.initial-state`` and ``privacy.consensus-value`` (Problem 1 (i)).
None of them forms the observability matrix ``(C, CA, ..., CA^{2N-1})``: in double precision it is
already wrong at N = 50.

Tolerance rule
--------------
Eigenvalues are grouped with :func:`~glocal_verify.linalg.group_eigenvalues` at
``rtol * ||L_q||_2``; a gap in the undecided band is read both ways (split: the *lower* reading,
merged: the *upper* reading). Every other decision compares a quantity on the unit scale
(singular values of ``S E`` for an orthonormal eigenbasis ``E``, sines of principal angles,
distances of unit vectors) with ``rtol`` and ``rtol * band``, after widening it by the estimated
error of the computed subspaces: a value ``s`` with error ``e`` is zero iff
``s + e <= rtol``, nonzero iff ``s - e > rtol * band``, undecided otherwise. The eigenvector
error of a group is the a-posteriori Davis-Kahan bound ``||L E - E Lambda|| / gap``
(:func:`eigen_residuals`; ``gap`` = distance to the nearest other eigenvalue, shrunk by twice the
largest residual); the eigenspace of 0 is taken exactly, spanned by the component indicators. A
:class:`Subspace` carries both readings: the true subspace lies between ``basis`` and ``upper``
and is decided when their dimensions agree.
"""

from __future__ import annotations

import math
import weakref
from dataclasses import dataclass, field
from fractions import Fraction
from typing import Any, Mapping, Sequence

import flint
import numpy as np
import scipy.sparse

from .errors import ModelError
from .linalg import DEFAULT_TOLERANCE, Decision, Tolerance
from .model import System
from .registry import CheckContext, checker, finding_rule, result
from .results import ConditionResult, Finding, Status
from .spec import NORMAL_MODE, Label

__all__ = [
    "Subspace",
    "EigenGroupPart",
    "ModalDecomposition",
    "SwitchedBounds",
    "unobservable_subspace",
    "unobservable_subspace_dense",
    "unobservable_subspace_exact",
    "switched_unobservable_subspace",
    "switched_unobservable_bounds_exact",
    "modal_decomposition",
    "eigen_residuals",
    "modal_exponential",
    "block_exponentials",
    "mode_sequence",
    "sequence_text",
    "decide_with_error",
    "check_switched_observability",
    "check_privacy_unobservable",
    "check_privacy_initial_state",
    "check_privacy_consensus_value",
    "switched_subspace_not_invariant",
]

EPS = float(np.finfo(float).eps)


# --------------------------------------------------------------------------------------------
# decisions with an error estimate


def decide_with_error(value: float, error: float, tol: Tolerance, scale: float = 1.0) -> Decision:
    """Three-valued zero test of a computed ``value`` known up to ``error`` (both absolute).

    ``ZERO`` iff ``|value| + error <= rtol * scale``, ``NONZERO`` iff
    ``|value| - error > rtol * band * scale``, ``UNDECIDED`` otherwise. With ``error = 0`` this is
    :meth:`Tolerance.decide <glocal_verify.linalg.Tolerance.decide>`.

    Parameters
    ----------
    value : float
        The computed quantity.
    error : float
        Estimated absolute error of ``value`` (>= 0).
    tol : Tolerance
        Relative tolerance and band.
    scale : float
        The scale ``value`` is compared with.
    """
    v = abs(float(value))
    e = max(float(error), 0.0)
    if not math.isfinite(v) or not math.isfinite(e):
        return Decision.UNDECIDED
    if v + e <= tol.rtol * scale:
        return Decision.ZERO
    if v - e > tol.upper * scale:
        return Decision.NONZERO
    return Decision.UNDECIDED


# --------------------------------------------------------------------------------------------
# subspaces


@dataclass(frozen=True, slots=True)
class Subspace:
    """A numerically computed subspace of R^n with both readings of its undecided decisions.

    Attributes
    ----------
    basis : ndarray
        ``n x k`` orthonormal basis of the *lower* reading: only directions certainly in the
        subspace (every deciding quantity certainly zero).
    upper : ndarray
        ``n x k'`` orthonormal basis of the *upper* reading (every undecided quantity read as
        zero); ``k' >= k`` and ``span(basis)`` lies (numerically) inside ``span(upper)``.
    decided : bool
        ``k == k'``: the tolerance separates every case and ``basis`` is the subspace.
    margin : float
        Smallest certainly nonzero deciding quantity (unit scale; 1.0 when there is none): how
        far the subspace is from growing.
    error : float
        Estimated sine of the largest principal angle between ``basis`` and the exact subspace.
    rtol : float
        The relative tolerance used.
    evidence : mapping
        Method-specific details (eigen-groups, steps of a recursion ...).
    """

    basis: np.ndarray
    upper: np.ndarray
    decided: bool
    margin: float
    error: float
    rtol: float
    evidence: Mapping[str, Any] = field(default_factory=dict)

    @property
    def dim(self) -> int:
        """Dimension of the lower reading."""
        return int(self.basis.shape[1])

    @property
    def dim_upper(self) -> int:
        """Dimension of the upper reading."""
        return int(self.upper.shape[1])

    @property
    def ambient(self) -> int:
        """Dimension of the ambient space."""
        return int(self.basis.shape[0])

    def contains_decision(self, v: np.ndarray, tol: Tolerance) -> tuple[Decision, float]:
        """Is the vector ``v`` in the subspace? Returns the decision on ``dist(v, S) / ||v||`` and that distance.

        ``ZERO`` (inside) uses the lower reading, ``NONZERO`` (outside) the upper one, both
        widened by :attr:`error`.

        Parameters
        ----------
        v : ndarray
            A nonzero vector of the ambient space.
        tol : Tolerance
            Tolerance of the decision.
        """
        v = np.asarray(v, dtype=float)
        nv = float(np.linalg.norm(v))
        u = v / nv
        d_lo = _distance(u, self.basis)
        d_hi = _distance(u, self.upper)
        inside = decide_with_error(d_lo, self.error, tol)
        outside = decide_with_error(d_hi, self.error, tol)
        if inside is Decision.ZERO:
            return Decision.ZERO, d_lo
        if outside is Decision.NONZERO:
            return Decision.NONZERO, d_lo
        return Decision.UNDECIDED, d_lo


def _distance(u: np.ndarray, B: np.ndarray) -> float:
    if B.shape[1] == 0:
        return float(np.linalg.norm(u))
    return float(np.linalg.norm(u - B @ (B.T @ u)))


# --------------------------------------------------------------------------------------------
# modal decomposition of one mode


@dataclass(frozen=True, slots=True)
class EigenGroupPart:
    """One group of numerically equal eigenvalues of L_q and its unobservable parts.

    Attributes
    ----------
    value : float
        Mean eigenvalue ``mu`` of the group.
    indices : tuple of int
        Positions in the ascending eigenvalue array.
    zero : Decision
        Is ``mu = 0`` (decided at ``rtol * ||L_q||_2``)?
    E : ndarray
        ``N x k`` orthonormal eigenbasis of the group.
    W : ndarray
        Orthonormal basis of ``W_mu = E ∩ ker S_M`` (lower reading).
    W_upper : ndarray
        Upper reading of ``W_mu``.
    Wx : ndarray
        Orthonormal basis of ``W^x_mu = E ∩ ker S_{M_x}`` (lower reading; used for ``mu = 0``).
    Wx_upper : ndarray
        Upper reading of ``W^x_mu``.
    sv : ndarray
        Singular values of ``S_M E`` padded with zeros to ``k``.
    svx : ndarray
        Singular values of ``S_{M_x} E`` padded with zeros to ``k``.
    error : float
        Estimated eigenvector error of the group (Davis-Kahan).
    """

    value: float
    indices: tuple[int, ...]
    zero: Decision
    E: np.ndarray
    W: np.ndarray
    W_upper: np.ndarray
    Wx: np.ndarray
    Wx_upper: np.ndarray
    sv: np.ndarray
    svx: np.ndarray
    error: float


@dataclass(frozen=True, slots=True)
class ModalDecomposition:
    """Eigen-groups of L_q with their unobservable parts (both readings of undecided gaps).

    Attributes
    ----------
    mode : str
        The mode.
    groups : tuple of EigenGroupPart
        Groups of the split reading (undecided gaps split).
    merged : tuple of EigenGroupPart
        Groups of the merged reading (undecided gaps merged); equal to ``groups`` when every
        gap is decided.
    scale : float
        ``||L_q||_2`` (1.0 for the zero Laplacian).
    gaps_decided : bool
        No gap between consecutive eigenvalues fell in the undecided band.
    """

    mode: str
    groups: tuple[EigenGroupPart, ...]
    merged: tuple[EigenGroupPart, ...]
    scale: float
    gaps_decided: bool


def _kernel_readings(S: np.ndarray, k: int, err: float, tol: Tolerance) -> tuple[np.ndarray, np.ndarray, np.ndarray, bool]:
    """Kernel of a ``p x k`` matrix with orthonormal-scale singular values, both readings.

    Returns (kernel lower reading, kernel upper reading, padded singular values, decided)
    as coefficient matrices ``k x r``.
    """
    if k == 0:
        z = np.zeros((0, 0))
        return z, z, np.zeros(0), True
    if S.shape[0] == 0:
        I = np.eye(k)
        return I, I, np.zeros(k), True
    _, s, Vh = np.linalg.svd(S, full_matrices=True)
    sp = np.zeros(k)
    sp[: len(s)] = s
    dec = [decide_with_error(x, err, tol) for x in sp]
    r_lo = sum(1 for d in dec if d is Decision.NONZERO)  # certainly nonzero
    r_hi = sum(1 for d in dec if d is not Decision.ZERO)  # not certainly zero
    V = Vh.T
    return V[:, r_hi:], V[:, r_lo:], sp, r_lo == r_hi


def _partition(w: np.ndarray, scale: float, tol: Tolerance) -> tuple[list[list[int]], list[list[int]], bool]:
    split: list[list[int]] = [[0]] if len(w) else []
    merged: list[list[int]] = [[0]] if len(w) else []
    decided = True
    for k in range(1, len(w)):
        d = tol.decide(w[k] - w[k - 1], scale)
        if d is Decision.ZERO:
            split[-1].append(k)
            merged[-1].append(k)
        elif d is Decision.UNDECIDED:
            decided = False
            split.append([k])
            merged[-1].append(k)
        else:
            split.append([k])
            merged.append([k])
    return split, merged, decided


def _group_parts(
    w: np.ndarray,
    U: np.ndarray,
    partition: list[list[int]],
    scale: float,
    mx: list[int],
    m: list[int],
    tol: Tolerance,
    residuals: np.ndarray,
    kernel_basis: np.ndarray | None,
) -> tuple[EigenGroupPart, ...]:
    n = len(w)
    rmax = float(np.max(residuals)) if len(residuals) else 0.0
    out = []
    for gi, g in enumerate(partition):
        lo = w[g[0]]
        hi = w[g[-1]]
        gap_left = lo - w[partition[gi - 1][-1]] if gi > 0 else math.inf
        gap_right = w[partition[gi + 1][0]] - hi if gi + 1 < len(partition) else math.inf
        gap = min(gap_left, gap_right) - 2.0 * rmax
        value = float(np.mean(w[g]))
        zero = tol.decide(value, scale)
        k = len(g)
        if zero is Decision.ZERO and kernel_basis is not None and kernel_basis.shape[1] == k:
            # ker L is spanned by the component indicators: known exactly
            E = kernel_basis
            err = math.sqrt(n) * EPS
        else:
            E = U[:, g]
            rg = float(np.linalg.norm(residuals[g]))
            err = (rg / gap if gap > 0 else math.inf) + math.sqrt(n) * EPS
        ker_lo, ker_hi, sv, _ = _kernel_readings(E[m, :], k, err, tol)
        kx_lo, kx_hi, svx, _ = _kernel_readings(E[mx, :], k, err, tol)
        out.append(
            EigenGroupPart(
                value=value,
                indices=tuple(g),
                zero=zero,
                E=E,
                W=E @ ker_lo,
                W_upper=E @ ker_hi,
                Wx=E @ kx_lo,
                Wx_upper=E @ kx_hi,
                sv=sv,
                svx=svx,
                error=err,
            )
        )
    return tuple(out)


def eigen_residuals(system: System, mode: str = NORMAL_MODE) -> np.ndarray:
    """Residual norms ``||L_q u_i - w_i u_i||_2`` of the computed eigenpairs (cached).

    With the gap ``delta`` between a group of computed eigenvalues and the rest of the
    spectrum, the Davis-Kahan sin-theta theorem bounds the angle between the computed and the
    exact eigenspace by ``||R_g|| / delta`` (``R_g`` the group's residual block; each computed
    eigenvalue lies within its residual of an exact one, so ``delta`` is shrunk by twice the
    largest residual). This a-posteriori bound replaces the a-priori ``N eps ||L|| / gap``.
    L_q is applied as a sparse matrix: O(nnz * N).

    Parameters
    ----------
    system : System
        The multi-agent system.
    mode : str
        The mode q.
    """
    key = ("residuals", mode)
    cache = _cache(system)
    if key not in cache:
        w, U = system.eigh(mode)
        L = scipy.sparse.csr_matrix(system.laplacian(mode))
        R = L @ U - U * w[None, :]
        cache[key] = np.linalg.norm(R, axis=0)
    return cache[key]  # type: ignore[no-any-return]


def _kernel_indicators(system: System, mode: str) -> np.ndarray:
    comps = system.components(mode)
    K = np.zeros((system.n, len(comps)))
    for c, comp in enumerate(comps):
        idx = system.idx(comp)
        K[idx, c] = 1.0 / math.sqrt(len(idx))
    return K


_CACHE: "weakref.WeakKeyDictionary[System, dict[Any, Any]]" = weakref.WeakKeyDictionary()


def _cache(system: System) -> dict[Any, Any]:
    c = _CACHE.get(system)
    if c is None:
        c = {}
        _CACHE[system] = c
    return c


def modal_decomposition(system: System, mode: str = NORMAL_MODE, tol: Tolerance = DEFAULT_TOLERANCE) -> ModalDecomposition:
    """Eigen-groups of L_q and, per group, ``W_mu = E_mu ∩ ker S_M`` and ``W^x_mu = E_mu ∩ ker S_{M_x}``.

    Parameters
    ----------
    system : System
        The multi-agent system.
    mode : str
        Mode whose Laplacian is decomposed.
    tol : Tolerance
        Tolerance of the eigenvalue grouping and of the kernel decisions (module docstring).
    """
    key = ("modal", mode, tol.rtol, tol.band)
    cache = _cache(system)
    if key in cache:
        return cache[key]  # type: ignore[no-any-return]
    system.check_mode(mode)
    w, U = system.eigh(mode)
    scale = float(np.max(np.abs(w))) if len(w) else 0.0
    if scale == 0.0:
        scale = 1.0
    split, merged, decided = _partition(w, scale, tol)
    mx = system.idx(system.monitored_positions)
    m = system.idx(system.monitored)
    res = eigen_residuals(system, mode)
    K = _kernel_indicators(system, mode)
    groups = _group_parts(w, U, split, scale, mx, m, tol, res, K)
    mgroups = groups if decided else _group_parts(w, U, merged, scale, mx, m, tol, res, K)
    md = ModalDecomposition(mode, groups, mgroups, scale, decided)
    cache[key] = md
    return md


def _assemble(n: int, groups: Sequence[EigenGroupPart], upper: bool) -> tuple[np.ndarray, bool]:
    """Basis of (W^x_0 x W_0) ⊕ ⊕_{mu>0} (W_mu x W_mu) for one reading; also 'zero decisions certain'."""
    cols: list[np.ndarray] = []
    certain = True
    for g in groups:
        W = g.W_upper if upper else g.W
        Wx = g.Wx_upper if upper else g.Wx
        if g.zero is Decision.UNDECIDED:
            certain = False
        as_zero = g.zero is Decision.ZERO or (upper and g.zero is Decision.UNDECIDED)
        if as_zero:
            # W^x_0 in the position slot; W_0 (a subspace of W^x_0) in the velocity slot
            for j in range(Wx.shape[1]):
                c = np.zeros(2 * n)
                c[:n] = Wx[:, j]
                cols.append(c)
        else:
            for j in range(W.shape[1]):
                c = np.zeros(2 * n)
                c[:n] = W[:, j]
                cols.append(c)
        for j in range(W.shape[1]):
            c = np.zeros(2 * n)
            c[n:] = W[:, j]
            cols.append(c)
    B = np.column_stack(cols) if cols else np.zeros((2 * n, 0))
    return B, certain


def unobservable_subspace(system: System, mode: str = NORMAL_MODE, tol: Tolerance = DEFAULT_TOLERANCE) -> Subspace:
    """Unobservable subspace of ``(A_q, C)`` from the modal structure of L_q.

    .. math::

        \\mathcal N(A_q, C) = (W^x_0 \\times W_0) \\oplus \\bigoplus_{\\mu > 0} (W_\\mu \\times W_\\mu),
        \\quad W^x_\\mu = E_\\mu \\cap \\ker S_{M_x},\\; W_\\mu = E_\\mu \\cap \\ker S_M

    (``CONDITIONS.md``, "Modal structure"; the double root ``gamma^2 = 4 alpha mu`` needs no
    special case: the formula does not involve the eigenvalues of A_q). Cost: one ``eigh`` of
    L_q (cached by the system) and an SVD of ``S_M E_mu`` per eigen-group; no 2N x 2N matrix.

    Parameters
    ----------
    system : System
        The multi-agent system.
    mode : str
        The mode q.
    tol : Tolerance
        Eigenvalues are grouped at ``rtol * ||L_q||_2``; ``W_mu`` keeps the right singular
        vectors of ``S_M E_mu`` whose singular values are zero after widening by the
        a-posteriori Davis-Kahan error ``||L E_mu - mu E_mu|| / gap`` (module docstring).

    Returns
    -------
    Subspace
        Orthonormal basis (2N x k) in the state ordering ``[positions; velocities]``;
        ``margin`` = min over eigen-groups of ``sigma_min(S E_mu)`` (``S = S_{M_x}`` for
        ``mu = 0``, ``S_M`` otherwise; 0 when some group has an unobservable part).
    """
    key = ("N", mode, tol.rtol, tol.band)
    cache = _cache(system)
    if key in cache:
        return cache[key]  # type: ignore[no-any-return]
    md = modal_decomposition(system, mode, tol)
    n = system.n
    lower, certain_lo = _assemble(n, md.groups, upper=False)
    upper, certain_hi = _assemble(n, md.merged, upper=True)
    margin = 1.0
    largest_zero = 0.0
    for g in md.groups:
        s = g.svx if g.zero is Decision.ZERO else g.sv
        if len(s):
            margin = min(margin, float(s[-1]))
        for x in s:
            if decide_with_error(x, g.error, tol) is Decision.ZERO:
                largest_zero = max(largest_zero, float(x))
    err = max((g.error for g in md.groups if (g.W.shape[1] or g.Wx.shape[1])), default=0.0)
    groups_ev = [
        {
            "eigenvalue": g.value,
            "multiplicity": len(g.indices),
            "dim_W": int(g.W.shape[1]),
            "dim_Wx": int(g.Wx.shape[1]) if g.zero is Decision.ZERO else None,
        }
        for g in md.groups
        if g.W.shape[1] or (g.zero is Decision.ZERO and g.Wx.shape[1]) or g.zero is Decision.UNDECIDED
    ]
    evidence = {
        "method": "modal",
        "mode": mode,
        "eigenvalue_scale": md.scale,
        "eigen_groups": len(md.groups),
        "gaps_decided": md.gaps_decided,
        "unobservable_groups": groups_ev,
        "largest_zero_singular_value": largest_zero,
    }
    sub = Subspace(
        basis=lower,
        upper=upper,
        decided=lower.shape[1] == upper.shape[1] and certain_lo and certain_hi,
        margin=margin,
        error=err,
        rtol=tol.rtol,
        evidence=evidence,
    )
    cache[key] = sub
    return sub


# --------------------------------------------------------------------------------------------
# generic dense staircase


def _staircase(A: np.ndarray, C: np.ndarray, tol: Tolerance, upper: bool) -> tuple[np.ndarray, bool, float, int, float]:
    """One reading of the staircase; returns (basis, decided, margin, steps, error estimate)."""
    n = A.shape[0]
    scale_a = float(np.linalg.norm(A, 2)) if A.size else 0.0
    decided = True
    margin = 1.0
    err = n * EPS
    if C.shape[0]:
        _, s, Vh = np.linalg.svd(C, full_matrices=True)
        sc = float(s[0]) if len(s) else 0.0
        sp = np.zeros(n)
        sp[: len(s)] = s / sc if sc > 0 else s
        dec = [decide_with_error(x, n * EPS, tol) if sc > 0 else Decision.ZERO for x in sp]
        r_lo = sum(1 for d in dec if d is Decision.NONZERO)
        r_hi = sum(1 for d in dec if d is not Decision.ZERO)
        decided &= r_lo == r_hi
        r = r_lo if upper else r_hi
        if r:
            gap = float(sp[r - 1] - (sp[r] if r < n else 0.0))
            err = n * EPS / gap if gap > 0 else math.inf
        V = Vh.T[:, r:]
    else:
        V = np.eye(n)
    steps = 0
    if scale_a == 0.0:
        return V, decided, margin, steps, err
    while V.shape[1] > 0:
        steps += 1
        Y = A @ V
        R = Y - V @ (V.T @ Y)
        k = V.shape[1]
        _, s, Vh = np.linalg.svd(R, full_matrices=False)  # R is n x k with n >= k: Vh is k x k
        sp = np.zeros(k)
        sp[: len(s)] = s / scale_a
        dec = [tol.decide(x, 1.0) for x in sp]
        r_lo = sum(1 for d in dec if d is Decision.NONZERO)
        r_hi = sum(1 for d in dec if d is not Decision.ZERO)
        decided &= r_lo == r_hi
        if r_lo:
            margin = min(margin, float(sp[r_lo - 1]))
        r = r_lo if upper else r_hi
        if r == 0:
            break
        # this step's rounding moves the kernel by about n eps / gap (Wedin), gap between kept
        # and dropped singular values; recorded as information, not used in the decisions
        gap = float(sp[r - 1] - (sp[r] if r < k else 0.0))
        err = err + (n * EPS / gap if gap > 0 else math.inf)
        Z = Vh.T[:, r:]
        V, _ = np.linalg.qr(V @ Z)
        V = V[:, : Z.shape[1]]
    return V, decided, margin, steps, err


def unobservable_subspace_dense(A: np.ndarray, C: np.ndarray, tol: Tolerance = DEFAULT_TOLERANCE) -> Subspace:
    """Unobservable subspace of a generic pair (A, C) by an orthogonal staircase (reference method).

    The largest A-invariant subspace inside ``ker C`` is the limit of

    .. math:: \\mathcal V_0 = \\ker C, \\qquad
              \\mathcal V_{j+1} = \\{ v \\in \\mathcal V_j : A v \\in \\mathcal V_j \\},

    computed with orthonormal bases: for ``V_j`` orthonormal, ``V_{j+1} = V_j Z`` where ``Z``
    spans the kernel of ``(I - V_j V_j^T) A V_j`` (an SVD per step; at most n steps). This is the
    dual of the controllability staircase; it never forms ``(C, CA, ..., CA^{n-1})``. Meant for
    small systems (O(n^3) per step) and as a generic reference for the modal method.

    The staircase is backward stable, but the unobservable subspace of a generic pair is
    ill-conditioned: with few outputs it needs many steps, each of which can amplify the error
    by ``||A|| / s`` (``s`` the singular value it peels off). A 30-agent graph with one velocity
    monitor and a 16-fold Laplacian eigenvalue loses its true 35-dimensional subspace this way
    (the same ill-conditioning that ruins the observability matrix); a rigorous compounded
    error bound would declare almost every staircase undecided, so none is applied: the
    result is the exact unobservable subspace of a nearby pair, not a certified one. Use it as
    a reference on small, well-conditioned systems; the modal method, which only needs the
    well-conditioned ``eigh`` of L, is the one the checkers use.

    Parameters
    ----------
    A : ndarray
        ``n x n`` state matrix.
    C : ndarray
        ``p x n`` output matrix.
    tol : Tolerance
        ``ker C``: singular values of C compared with ``rtol * ||C||_2``; each step: singular
        values of ``(I - V V^T) A V`` compared with ``rtol * ||A||_2``. Undecided singular
        values give the two readings of :class:`Subspace`. ``error`` sums the per-step
        estimates ``n eps / gap`` (Wedin; first order, information only). Undecided
        singular values give the two readings of :class:`Subspace`; a small gap makes later
        decisions undecided rather than wrong.
    """
    A = np.asarray(A, dtype=float)
    C = np.asarray(C, dtype=float).reshape(-1, A.shape[0])
    lo, dec_lo, margin, steps, err = _staircase(A, C, tol, upper=False)
    hi, dec_hi, _, _, _ = _staircase(A, C, tol, upper=True)
    return Subspace(
        basis=lo,
        upper=hi,
        decided=dec_lo and dec_hi and lo.shape[1] == hi.shape[1],
        margin=margin,
        error=err,
        rtol=tol.rtol,
        evidence={"method": "staircase", "steps": steps},
    )


# --------------------------------------------------------------------------------------------
# exact (rational) subspaces


def _qmat(rows: Sequence[Sequence[Fraction | int]], ncols: int) -> flint.fmpq_mat:
    flat = []
    for r in rows:
        for x in r:
            q = x if isinstance(x, Fraction) else Fraction(x)
            flat.append(flint.fmpq(q.numerator, q.denominator))
    return flint.fmpq_mat(len(rows), ncols, flat)


def _vstack(mats: Sequence[flint.fmpq_mat], ncols: int) -> flint.fmpq_mat:
    entries: list[Any] = []
    m = 0
    for M in mats:
        if M.nrows():
            entries.extend(M.entries())
            m += M.nrows()
    return flint.fmpq_mat(m, ncols, entries)


def _row_basis(M: flint.fmpq_mat) -> flint.fmpq_mat:
    """RREF rows spanning the row space of M (no zero rows)."""
    n = M.ncols()
    if M.nrows() == 0:
        return flint.fmpq_mat(0, n, [])
    R, r = M.rref()
    r = int(r)
    return flint.fmpq_mat(r, n, R.entries()[: r * n])


def _row_closure(R0: flint.fmpq_mat, mats: Sequence[flint.fmpq_mat]) -> flint.fmpq_mat:
    """Smallest row space containing R0's rows and closed under right multiplication by each matrix.

    Its kernel is the largest subspace of ker(R0) invariant under every matrix.
    """
    n = R0.ncols()
    B = _row_basis(R0)
    while True:
        r = B.nrows()
        if r == n or r == 0:
            return B
        new = [B * M for M in mats]
        B2 = _row_basis(_vstack([B, *new], n))
        if B2.nrows() == r:
            return B
        B = B2


def _kernel(R: flint.fmpq_mat) -> flint.fmpq_mat:
    """Basis of the right kernel of R as the columns of an ``n x k`` matrix."""
    n = R.ncols()
    if R.nrows() == 0:
        return flint.fmpq_mat(n, n, [int(i == j) for i in range(n) for j in range(n)])
    E, r = R.rref()
    r = int(r)
    rows = E.tolist()[:r]
    pivots = []
    for row in rows:
        for j, x in enumerate(row):
            if x != 0:
                pivots.append(j)
                break
    free = [j for j in range(n) if j not in set(pivots)]
    K = flint.fmpq_mat(n, len(free), [0] * (n * len(free)))
    for c, f in enumerate(free):
        K[f, c] = 1
        for row, p in zip(rows, pivots):
            K[p, c] = -row[f]
    return K


def _annihilator(X: flint.fmpq_mat) -> flint.fmpq_mat:
    """Rows spanning the orthogonal complement of the column space of X."""
    K = _kernel(X.transpose())
    return K.transpose()


def _cols_closure(X: flint.fmpq_mat, A: flint.fmpq_mat) -> flint.fmpq_mat:
    """Smallest A-invariant subspace containing the columns of X (as columns)."""
    n = X.nrows()
    if X.ncols() == 0:
        return X
    return _row_basis(_row_closure(X.transpose(), [A.transpose()])).transpose()


def _exact_A(system: System, mode: str) -> flint.fmpq_mat:
    n = system.n
    L = system.laplacian_exact(mode)
    al, ga = system.alpha_q, system.gamma_q
    rows: list[list[Fraction]] = []
    for i in range(n):
        rows.append([Fraction(int(j == n + i)) for j in range(2 * n)])
    for i in range(n):
        rows.append([-al * L[i][j] for j in range(n)] + [(-ga if j == i else Fraction(0)) for j in range(n)])
    return _qmat(rows, 2 * n)


def _exact_C(system: System) -> flint.fmpq_mat:
    n = system.n
    rows = []
    for i in system.idx(system.monitored_positions):
        rows.append([int(j == i) for j in range(2 * n)])
    for i in system.idx(system.monitored_velocities):
        rows.append([int(j == n + i) for j in range(2 * n)])
    return _qmat(rows, 2 * n)


def _exact_obs_rows(system: System, mode: str) -> flint.fmpq_mat:
    """Row basis of the observable row space of (A_q, C): the annihilator of N(A_q, C)."""
    key = ("exact-rows", mode)
    cache = _cache(system)
    if key not in cache:
        cache[key] = _row_closure(_exact_C(system), [_exact_A(system, mode)])
    return cache[key]  # type: ignore[no-any-return]


def _to_fraction_cols(K: flint.fmpq_mat) -> list[list[Fraction]]:
    out = []
    for c in range(K.ncols()):
        out.append([Fraction(int(K[r, c].p), int(K[r, c].q)) for r in range(K.nrows())])
    return out


def unobservable_subspace_exact(system: System, mode: str = NORMAL_MODE) -> list[list[Fraction]]:
    """Unobservable subspace of ``(A_q, C)`` over Q: a basis of rational vectors of length 2N.

    The observable row space is the smallest row space containing the rows of C and closed
    under right multiplication by A_q (Krylov closure ``N_0 = ker C``,
    ``N_{k+1} = N_k ∩ ker(C A^{k+1})``, kept as a reduced row basis so that it stops after at
    most 2N steps); the result is its right kernel. Exact rational arithmetic (python-flint):
    no tolerance.

    Parameters
    ----------
    system : System
        The multi-agent system (rational weights and gains).
    mode : str
        The mode q.
    """
    K = _kernel(_exact_obs_rows(system, mode))
    return _to_fraction_cols(K)


def _exact_N(system: System, mode: str) -> flint.fmpq_mat:
    key = ("exact-N", mode)
    cache = _cache(system)
    if key not in cache:
        cache[key] = _kernel(_exact_obs_rows(system, mode))
    return cache[key]  # type: ignore[no-any-return]


# --------------------------------------------------------------------------------------------
# modal exponentials and the switched recursion


def block_exponentials(mu: np.ndarray, alpha: float, gamma: float, t: float) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Entries of ``exp(B_mu t)``, ``B_mu = [[0, 1], [-alpha mu, -gamma]]``, for each ``mu``.

    With ``d = gamma^2 / 4 - alpha mu`` (so that ``(B + gamma/2 I)^2 = d I``),

    .. math:: e^{B t} = e^{-\\gamma t / 2} \\left( c\\, I + s\\, (B + \\tfrac{\\gamma}{2} I) \\right),
              \\quad c = \\cosh(\\sqrt{d} t),\\; s = \\frac{\\sinh(\\sqrt d t)}{\\sqrt d},

    read as ``cos``/``sin`` for ``d < 0`` and as ``c = 1, s = t`` at the double root ``d = 0``
    (the Jordan case ``gamma^2 = 4 alpha mu``); a series is used near ``d t^2 = 0``, so the
    formula is continuous through the double root.

    Parameters
    ----------
    mu : ndarray
        Eigenvalues of L.
    alpha, gamma : float
        Gains.
    t : float
        Time (negative for the inverse map).

    Returns
    -------
    tuple of ndarray
        ``(p11, p12, p21, p22)``, each of the shape of ``mu``.
    """
    mu = np.asarray(mu, dtype=float)
    d = gamma * gamma / 4.0 - alpha * mu
    z = d * t * t
    c = np.empty_like(z)
    sfac = np.empty_like(z)
    small = np.abs(z) < 1e-4
    pos = (z >= 1e-4)
    neg = (z <= -1e-4)
    zs = z[small]
    c[small] = 1 + zs / 2 + zs**2 / 24 + zs**3 / 720
    sfac[small] = 1 + zs / 6 + zs**2 / 120 + zs**3 / 5040
    rp = np.sqrt(z[pos])
    c[pos] = np.cosh(rp)
    sfac[pos] = np.sinh(rp) / rp
    rn = np.sqrt(-z[neg])
    c[neg] = np.cos(rn)
    sfac[neg] = np.sin(rn) / rn
    s = t * sfac
    e = math.exp(-gamma * t / 2.0)
    p11 = e * (c + s * gamma / 2.0)
    p12 = e * s
    p21 = e * (-alpha * mu * s)
    p22 = e * (c - s * gamma / 2.0)
    return p11, p12, p21, p22


def modal_exponential(system: System, mode: str, t: float, X: np.ndarray) -> np.ndarray:
    """``exp(A_q t) X`` through the eigendecomposition of L_q (2 x 2 blocks per eigenvalue).

    Cost O(N^2 k) for ``X`` of shape ``2N x k`` (after the cached ``eigh``); never forms A_q.

    Parameters
    ----------
    system : System
        The multi-agent system.
    mode : str
        The mode q.
    t : float
        Time (negative values give ``exp(-A_q |t|)``).
    X : ndarray
        ``2N x k`` (or length-2N) array.
    """
    w, U = system.eigh(mode)
    n = system.n
    X = np.asarray(X, dtype=float)
    vec = X.ndim == 1
    if vec:
        X = X[:, None]
    a = U.T @ X[:n]
    b = U.T @ X[n:]
    p11, p12, p21, p22 = block_exponentials(w, system.alpha, system.gamma, t)
    a2 = p11[:, None] * a + p12[:, None] * b
    b2 = p21[:, None] * a + p22[:, None] * b
    out = np.vstack([U @ a2, U @ b2])
    return out[:, 0] if vec else out


def mode_sequence(system: System) -> list[tuple[str, float]] | None:
    """The mode schedule of the spec: ``switching.sequence``, else ``[normal, switching.mode]``.

    Returns ``None`` when the spec defines no switching (each mode is then checked alone).
    With ``switching.mode`` at ``switching.time`` the schedule is
    ``[("normal", time), (mode, horizon - time)]`` (just ``[("normal", horizon)]`` if the switch
    falls after the horizon).

    Parameters
    ----------
    system : System
        The multi-agent system.
    """
    sw = system.spec.switching
    if sw is None:
        return None
    if sw.sequence:
        return [(s.mode, float(s.duration)) for s in sw.sequence]
    if sw.mode is not None and sw.time is not None:
        horizon = float(system.spec.simulation.horizon)
        if horizon <= sw.time:
            return [(NORMAL_MODE, horizon)]
        return [(NORMAL_MODE, float(sw.time)), (sw.mode, horizon - float(sw.time))]
    return None


def sequence_text(sequence: Sequence[tuple[str, float]]) -> str:
    """``"normal(10) -> case-2(20)"``.

    Parameters
    ----------
    sequence : sequence of (mode, duration)
        A mode schedule.
    """
    return " -> ".join(f"{m}({d:g})" for m, d in sequence)


def _orth_readings(X: np.ndarray) -> tuple[np.ndarray, float]:
    """Orthonormal basis of span(X) for full-column-rank X and its condition number."""
    if X.shape[1] == 0:
        return X, 1.0
    Q, s, _ = np.linalg.svd(X, full_matrices=False)
    cond = float(s[0] / s[-1]) if s[-1] > 0 else math.inf
    return Q, cond


def _intersect(P: np.ndarray, V: np.ndarray, err: float, tol: Tolerance, upper: bool) -> tuple[np.ndarray, bool, float]:
    """span(P) ∩ span(V) for orthonormal P, V: kernel of ``(I - P P^T) V`` (sines of principal angles)."""
    k = V.shape[1]
    if k == 0:
        return V, True, 1.0
    if P.shape[1] == 0:
        return V[:, :0], True, 1.0
    R = V - P @ (P.T @ V)
    _, s, Vh = np.linalg.svd(R, full_matrices=False)
    sp = np.zeros(k)
    sp[: len(s)] = s
    dec = [decide_with_error(x, err, tol) for x in sp]
    r_lo = sum(1 for d in dec if d is Decision.NONZERO)
    r_hi = sum(1 for d in dec if d is not Decision.ZERO)
    margin = float(sp[r_lo - 1]) if r_lo else 1.0
    Z = Vh.T[:, (r_lo if upper else r_hi) :]
    return V @ Z, r_lo == r_hi, margin


def _check_sequence(system: System, sequence: Sequence[tuple[str, float]]) -> list[tuple[str, float]]:
    seq = [(str(m), float(d)) for m, d in sequence]
    if not seq:
        raise ModelError("a mode sequence needs at least one mode")
    for m, d in seq:
        system.check_mode(m)
        if not (d > 0 and math.isfinite(d)):
            raise ModelError(f"mode {m!r}: dwell time must be a positive finite number, got {d!r}")
    return seq


def switched_unobservable_subspace(
    system: System, sequence: Sequence[tuple[str, float]], tol: Tolerance = DEFAULT_TOLERANCE
) -> Subspace:
    """Unobservable subspace ``N_1^m`` of the switched system over a mode schedule (Lemma II.3).

    Backward recursion of eqs. ``obsv_nullspace_1``-``obsv_nullspace_2``:

    .. math::

        \\mathcal N \\leftarrow \\mathcal N(A_m, C); \\qquad
        \\mathcal N \\leftarrow \\mathcal N(A_k, C) \\cap e^{-A_k \\tau_k} \\mathcal N
        = e^{-A_k \\tau_k} \\left( \\mathcal N(A_k, C) \\cap \\mathcal N \\right),
        \\quad k = m-1, \\dots, 1.

    The equality holds because ``N(A_k, C)`` is A_k-invariant, so ``exp(A_k tau_k)`` maps it onto
    itself. Each step intersects two orthonormal bases by the sines of their principal angles
    and pushes the result through ``exp(-A_k tau_k)`` with :func:`modal_exponential`; the
    result is re-orthonormalized by an SVD. The estimated subspace error grows by the
    condition number ``kappa`` of the pushed basis:
    ``err <- kappa (err + N eps (1 + alpha ||L_k|| tau_k + gamma tau_k))``.
    The dwell time of the last mode does not matter.

    Parameters
    ----------
    system : System
        The multi-agent system.
    sequence : sequence of (mode, duration)
        The schedule ``[(mode_1, tau_1), ..., (mode_m, tau_m)]``, e.g. :func:`mode_sequence`.
    tol : Tolerance
        Tolerance of every decision (sines compared with ``rtol``, ``rtol * band`` after
        widening by the estimated error).

    Returns
    -------
    Subspace
        Basis of ``N_1^m`` as initial states ``x(t_0)``; ``margin`` is the smallest certainly
        nonzero sine met in the intersections (1.0 if none).
    """
    key = ("switched", tuple((m, float(t)) for m, t in sequence), tol.rtol, tol.band)
    cache = _cache(system)
    if key not in cache:
        cache[key] = _switched_recursion(system, sequence, tol)
    return cache[key]  # type: ignore[no-any-return]


def _switched_recursion(
    system: System, sequence: Sequence[tuple[str, float]], tol: Tolerance = DEFAULT_TOLERANCE
) -> Subspace:
    """Uncached body of :func:`switched_unobservable_subspace`."""
    seq = _check_sequence(system, sequence)
    subs = {m: unobservable_subspace(system, m, tol) for m, _ in seq}
    results = {}
    decided = all(subs[m].decided for m, _ in seq)
    margin = 1.0
    steps: list[dict[str, Any]] = []
    for upper in (False, True):
        last = subs[seq[-1][0]]
        V = last.upper if upper else last.basis
        err = last.error
        for k in range(len(seq) - 2, -1, -1):
            mode, tau = seq[k]
            Sk = subs[mode]
            P = Sk.upper if upper else Sk.basis
            S, dec, mg = _intersect(P, V, err + Sk.error, tol, upper)
            decided &= dec
            if not upper:
                margin = min(margin, mg)
            X = modal_exponential(system, mode, -tau, S)
            if not np.all(np.isfinite(X)):
                decided = False
                err = math.inf
                V = S
                continue
            V, kappa = _orth_readings(X)
            scale = float(np.max(np.abs(system.eigh(mode)[0]))) if system.n else 0.0
            err = kappa * (err + Sk.error + system.n * EPS * (1 + system.alpha * scale * tau + system.gamma * tau))
            if not upper:
                steps.append({"mode": mode, "tau": tau, "dim": int(V.shape[1]), "condition": kappa, "error": err})
        results[upper] = (V, err)
    lo, err_lo = results[False]
    hi, _ = results[True]
    return Subspace(
        basis=lo,
        upper=hi,
        decided=decided and lo.shape[1] == hi.shape[1],
        margin=margin,
        error=err_lo,
        rtol=tol.rtol,
        evidence={"method": "backward recursion", "sequence": [list(s) for s in seq], "steps": steps[::-1]},
    )


# --------------------------------------------------------------------------------------------
# exact bounds for the switched subspace


@dataclass(frozen=True, slots=True)
class SwitchedBounds:
    """Exact, dwell-time-independent bounds on the switched unobservable subspace.

    Attributes
    ----------
    dim_lower, dim_upper : int
        ``dim_lower <= dim N_1^m <= dim_upper`` for every choice of dwell times.
    inner : list of list of Fraction
        Basis of a rational subspace contained in ``N_1^m`` (as initial states).
    outer : list of list of Fraction
        Basis of a rational subspace containing ``N_1^m``.
    at_first_switch : list of list of Fraction
        For a two-mode schedule, a basis of ``N(A_1, C) ∩ N(A_2, C)``: the states ``x(t_1)`` at
        the switch, ``N_1^2 = exp(-A_1 tau_1)`` of this space; empty otherwise.
    exact_dimension : bool
        ``dim_lower == dim_upper``.
    """

    dim_lower: int
    dim_upper: int
    inner: list[list[Fraction]]
    outer: list[list[Fraction]]
    at_first_switch: list[list[Fraction]]
    exact_dimension: bool


def switched_unobservable_bounds_exact(system: System, sequence: Sequence[tuple[str, float]]) -> SwitchedBounds:
    """Exact bounds on ``N_1^m`` that hold for every dwell time (python-flint, no tolerance).

    With rational data the exponentials ``exp(A_k tau_k)`` are transcendental, so the switched
    subspace itself is not computed over Q. What exact arithmetic proves:

    * ``N_k = exp(-A_k tau_k)(N(A_k, C) ∩ N_{k+1})`` and ``exp(-A_k tau_k)`` is a bijection, so
      ``dim N_1^m = dim(N(A_1, C) ∩ N_2^m)``. For two modes (the paper's normal -> safe switch)
      ``dim N_1^2 = dim(N(A_1, C) ∩ N(A_2, C))`` exactly, for every ``tau_1``.
    * Inner bound: ``L_m = N(A_m, C)``, ``L_k`` = the largest A_k-invariant subspace of
      ``N(A_k, C) ∩ L_{k+1}``; then ``L_k ⊆ N_k`` (an A_k-invariant space is fixed by
      ``exp(-A_k tau)``) and ``dim N_1 >= dim(N(A_1, C) ∩ L_2)``.
    * Outer bound: ``U_m = N(A_m, C)``, ``U_k`` = the smallest A_k-invariant subspace containing
      ``N(A_k, C) ∩ U_{k+1}``; then ``N_k ⊆ U_k`` and ``dim N_1 <= dim(N(A_1, C) ∩ U_2)``.

    When the two dimensions agree (always for m <= 2) the dimension, hence observability, is
    decided exactly; otherwise the answer depends on the dwell times and exact arithmetic
    cannot decide it (the checkers then fall back to the numeric recursion and say so).

    Parameters
    ----------
    system : System
        The multi-agent system (rational data).
    sequence : sequence of (mode, duration)
        The schedule; durations are validated but not used.
    """
    key = ("switched-exact", tuple((m, float(t)) for m, t in sequence))
    cache = _cache(system)
    if key not in cache:
        cache[key] = _switched_bounds_exact(system, sequence)
    return cache[key]  # type: ignore[no-any-return]


def _switched_bounds_exact(system: System, sequence: Sequence[tuple[str, float]]) -> SwitchedBounds:
    """Uncached body of :func:`switched_unobservable_bounds_exact`."""
    seq = _check_sequence(system, sequence)
    n2 = 2 * system.n
    modes = [m for m, _ in seq]
    A = {m: _exact_A(system, m) for m in set(modes)}
    R = {m: _exact_obs_rows(system, m) for m in set(modes)}
    m = len(seq)
    if m == 1:
        K = _kernel(R[modes[0]])
        basis = _to_fraction_cols(K)
        return SwitchedBounds(len(basis), len(basis), basis, basis, [], True)
    # inner: annihilator rows of L_{k}
    lo_rows = R[modes[-1]]
    for k in range(m - 2, 0, -1):
        lo_rows = _row_closure(_vstack([R[modes[k]], lo_rows], n2), [A[modes[k]]])
    first = _row_basis(_vstack([R[modes[0]], lo_rows], n2))
    dim_lo = n2 - first.nrows()
    inner = _kernel(_row_closure(first, [A[modes[0]]]))
    # outer: column bases of U_k
    U = _kernel(R[modes[-1]])
    for k in range(m - 2, 0, -1):
        S = _kernel(_vstack([R[modes[k]], _annihilator(U)], n2)) if U.ncols() else U
        U = _cols_closure(S, A[modes[k]])
    if U.ncols():
        S1 = _kernel(_vstack([R[modes[0]], _annihilator(U)], n2))
    else:
        S1 = U
    dim_hi = S1.ncols()
    outer = _cols_closure(S1, A[modes[0]]) if S1.ncols() else S1
    at_switch = _to_fraction_cols(S1) if m == 2 else []
    return SwitchedBounds(
        dim_lower=dim_lo,
        dim_upper=dim_hi,
        inner=_to_fraction_cols(inner),
        outer=_to_fraction_cols(outer),
        at_first_switch=at_switch,
        exact_dimension=dim_lo == dim_hi,
    )


# --------------------------------------------------------------------------------------------
# witnesses


def _state_map(system: System, v: Sequence[Any] | np.ndarray, digits: int | None = 12) -> dict[str, Any]:
    n = system.n
    vals = list(v)
    if digits is None:
        return {"x": dict(zip(system.labels, vals[:n])), "v": dict(zip(system.labels, vals[n:]))}
    arr = np.asarray([float(x) for x in vals])
    big = float(np.max(np.abs(arr))) if len(arr) else 0.0
    arr = np.where(np.abs(arr) <= 1e-13 * max(big, 1.0), 0.0, arr)
    return {
        "x": {lab: round(float(x), digits) for lab, x in zip(system.labels, arr[:n])},
        "v": {lab: round(float(x), digits) for lab, x in zip(system.labels, arr[n:])},
    }


def _basis_witness(system: System, B: np.ndarray, limit: int = 6) -> list[dict[str, Any]]:
    return [_state_map(system, B[:, j]) for j in range(min(B.shape[1], limit))]


def _exact_basis_witness(system: System, B: list[list[Fraction]], limit: int = 6) -> list[dict[str, Any]]:
    return [_state_map(system, b, digits=None) for b in B[:limit]]


def _consensus(system: System) -> np.ndarray:
    v = np.zeros(2 * system.n)
    v[: system.n] = 1.0 / math.sqrt(system.n)
    return v


def _numeric_ctx(ctx: CheckContext) -> CheckContext:
    return CheckContext(exact=False, tol=ctx.tol, options=ctx.options)


_FALLBACK_NOTE = (
    "exact arithmetic cannot decide this schedule: with more than two modes the switched subspace "
    "depends on transcendental exponentials exp(A_k tau_k) and the exact dwell-time-independent bounds "
    "disagree; the verdict is the numeric recursion's"
)


# --------------------------------------------------------------------------------------------
# switched-observability


def _status_from_dims(dim: int, dim_upper: int, observable_holds: bool) -> Status:
    """holds/fails for 'N = {0}' (observable_holds) or 'N != {0}'."""
    if dim_upper == 0:
        return Status.HOLDS if observable_holds else Status.FAILS
    if dim > 0:
        return Status.FAILS if observable_holds else Status.HOLDS
    return Status.UNDECIDED


@checker("switched-observability")
def check_switched_observability(system: System, ctx: CheckContext) -> list[ConditionResult]:
    """Lemma II.3 (``lemma:observability``): the switched pair is observable, ``N_1^m = {0}``.

    .. math:: \\mathcal N_1^m = \\ker \\mathcal O = \\{0\\}

    with the backward recursion of :func:`switched_unobservable_subspace`. Scopes: every mode
    alone (``{"mode": q}``: observability of ``(A_q, C)``), and the spec's schedule (scope
    ``{}``; the schedule is in the witness) when :func:`mode_sequence` gives one.

    Numeric: dimensions of the lower and upper readings (module tolerance rule); holds iff the
    upper reading is ``{0}``, fails iff the lower reading is not, undecided otherwise.
    Exact: per mode the rational kernel of the Krylov row closure; for the schedule the exact
    dwell-time-independent bounds of :func:`switched_unobservable_bounds_exact` (exact for two
    modes). If they disagree (three or more modes), the result is the numeric one
    (``method = numeric``) with a note in the witness.

    Margin
        Per mode: min over eigen-groups of ``sigma_min(S E_mu)`` (unit scale; 0 when
        unobservable). Schedule: the smallest certainly nonzero sine of the principal angles
        met in the recursion (1.0 if none), 0 when unobservable. Computed in floating point in
        both modes.
    Witness
        ``dim`` (and ``dim_upper`` if undecided) and an orthonormal (numeric) or rational
        (exact) basis of the unobservable subspace as ``{"x": {label: ...}, "v": {label: ...}}``
        maps (at most six vectors); for the schedule the schedule itself.
    """
    out: list[ConditionResult] = []
    cid = "switched-observability"
    for mode in system.modes:
        S = unobservable_subspace(system, mode, ctx.tol)
        if ctx.exact:
            basis = unobservable_subspace_exact(system, mode)
            status = Status.HOLDS if not basis else Status.FAILS
            witness: dict[str, Any] = {"dim": len(basis), "basis": _exact_basis_witness(system, basis)}
            margin = 0.0 if basis else S.margin
        else:
            status = _status_from_dims(S.dim, S.dim_upper, observable_holds=True)
            witness = {"dim": S.dim, "basis": _basis_witness(system, S.basis)}
            if not S.decided:
                witness["dim_upper"] = S.dim_upper
            margin = 0.0 if S.dim else S.margin
        out.append(result(cid, ctx, status, scope={"mode": mode}, margin=margin, witness=witness))
    seq = mode_sequence(system)
    if seq is None:
        return out
    seq = _check_sequence(system, seq)
    Ssw = switched_unobservable_subspace(system, seq, ctx.tol)
    base = {"sequence": [list(s) for s in seq], "schedule": sequence_text(seq)}
    if ctx.exact:
        bounds = switched_unobservable_bounds_exact(system, seq)
        if bounds.dim_upper == 0 or bounds.dim_lower > 0:
            status = Status.HOLDS if bounds.dim_upper == 0 else Status.FAILS
            witness = dict(base, dim_lower=bounds.dim_lower, dim_upper=bounds.dim_upper)
            if bounds.exact_dimension:
                witness["dim"] = bounds.dim_lower
            if bounds.at_first_switch:
                witness["states_at_switch"] = _exact_basis_witness(system, bounds.at_first_switch)
                witness["note"] = "N_1^2 = exp(-A_1 tau_1) (N(A_1, C) ∩ N(A_2, C)); the basis is of the states x(t_1) at the switch"
            elif bounds.inner:
                witness["inner_basis"] = _exact_basis_witness(system, bounds.inner)
            margin = 0.0 if status is Status.FAILS else Ssw.margin
            out.append(result(cid, ctx, status, margin=margin, witness=witness))
            return out
        nctx = _numeric_ctx(ctx)
        status = _status_from_dims(Ssw.dim, Ssw.dim_upper, observable_holds=True)
        witness = dict(base, dim=Ssw.dim, basis=_basis_witness(system, Ssw.basis), note=_FALLBACK_NOTE,
                       exact_bounds=[bounds.dim_lower, bounds.dim_upper])
        out.append(result(cid, nctx, status, margin=0.0 if Ssw.dim else Ssw.margin, witness=witness))
        return out
    status = _status_from_dims(Ssw.dim, Ssw.dim_upper, observable_holds=True)
    witness = dict(base, dim=Ssw.dim, basis=_basis_witness(system, Ssw.basis), steps=Ssw.evidence["steps"])
    if not Ssw.decided:
        witness["dim_upper"] = Ssw.dim_upper
    out.append(result(cid, ctx, status, margin=0.0 if Ssw.dim else Ssw.margin, witness=witness))
    return out


# --------------------------------------------------------------------------------------------
# privacy (Lemma III.1, Problem 1 (i))


def _exact_in_span(K: flint.fmpq_mat, v: Sequence[Fraction]) -> bool:
    """Is the rational vector v in the column span of K?"""
    n = len(v)
    if K.ncols() == 0:
        return all(x == 0 for x in v)
    vm = _qmat([[x] for x in v], 1)
    cols = K.ncols()
    rows = [[K[i, j] for j in range(cols)] + [vm[i, 0]] for i in range(n)]
    M = flint.fmpq_mat(n, cols + 1, [x for r in rows for x in r])
    return int(M.rank()) == int(K.rank())


@checker("privacy.unobservable")
def check_privacy_unobservable(system: System, ctx: CheckContext) -> list[ConditionResult]:
    """Lemma III.1 (``lemma:Inv_unobs_subspace``): span{[1; 0]} is A_q-invariant and unobservable.

    .. math:: A_q \\begin{bmatrix} \\mathbf 1 \\\\ 0 \\end{bmatrix} = 0, \\qquad
              \\begin{bmatrix} \\mathbf 1 \\\\ 0 \\end{bmatrix} \\in \\mathcal N(A_q, C)
              \\;\\; \\forall q, \\quad \\text{and} \\in \\mathcal N_1^m

    Scopes: every mode (``{"mode": q}``) and the spec's schedule (scope ``{}``) if any.

    Numeric: ``e = [1; 0]/sqrt(N)``; invariance: ``||A_q e|| <= rtol ||A_q||`` (always true:
    ``L_q 1 = 0``); membership: the distance of e from the lower reading of the subspace plus
    its estimated error is at most ``rtol`` (holds), the distance from the upper reading minus
    the error exceeds ``rtol * band`` (fails), undecided otherwise.
    Exact: ``A_q e = 0`` and e in the rational unobservable subspace. For the schedule, since
    ``A_k e = 0`` for every k, e is fixed by every ``exp(A_k t)``, so e is in ``N_1^m`` iff
    ``C e = 0`` (exact, for every dwell time). Note that connectivity, which the lemma assumes,
    is not needed: ``L_q 1 = 0`` for every undirected graph.

    Margin
        ``dist(e, N)`` (unit scale): 0 inside the subspace.
    Witness
        ``distance``, ``dim`` of the subspace, ``A_q_e_norm``; on failure the position monitors
        that see e (``C e != 0``).
    """
    out: list[ConditionResult] = []
    cid = "privacy.unobservable"
    e = _consensus(system)
    mx = list(system.monitored_positions)
    n = system.n
    for mode in system.modes:
        S = unobservable_subspace(system, mode, ctx.tol)
        Ae_norm = float(np.linalg.norm(system.laplacian(mode) @ e[:n])) * system.alpha
        dec, dist = S.contains_decision(e, ctx.tol)
        witness: dict[str, Any] = {"distance": dist, "dim": S.dim, "A_q_e_norm": Ae_norm}
        if ctx.exact:
            L = system.laplacian_exact(mode)
            invariant = all(sum(row, Fraction(0)) == 0 for row in L)
            ones = [Fraction(1)] * n + [Fraction(0)] * n
            inside = _exact_in_span(_exact_N(system, mode), ones)
            status = Status.HOLDS if (invariant and inside) else Status.FAILS
            witness["dim"] = int(_exact_N(system, mode).ncols())
        else:
            scale_a = max(system.alpha * float(np.max(np.abs(system.eigh(mode)[0]))) if n else 0.0, system.gamma, 1.0)
            inv = ctx.tol.decide(Ae_norm, scale_a)
            if inv is Decision.NONZERO or dec is Decision.NONZERO:
                status = Status.FAILS
            elif inv is Decision.ZERO and dec is Decision.ZERO:
                status = Status.HOLDS
            else:
                status = Status.UNDECIDED
        if status is not Status.HOLDS and mx:
            witness["position_monitors"] = mx
        out.append(result(cid, ctx, status, scope={"mode": mode}, margin=dist, witness=witness))
    seq = mode_sequence(system)
    if seq is None:
        return out
    seq = _check_sequence(system, seq)
    Ssw = switched_unobservable_subspace(system, seq, ctx.tol)
    dec, dist = Ssw.contains_decision(e, ctx.tol)
    witness = {"sequence": [list(s) for s in seq], "schedule": sequence_text(seq), "distance": dist, "dim": Ssw.dim}
    if ctx.exact:
        fixed = all(all(sum(row, Fraction(0)) == 0 for row in system.laplacian_exact(m)) for m, _ in seq)
        status = Status.FAILS if (mx or not fixed) else Status.HOLDS
        witness["reason"] = "A_k [1; 0] = 0 for every mode, so [1; 0] is fixed by every exp(A_k t); it is unobservable iff C [1; 0] = 0"
    else:
        status = {Decision.ZERO: Status.HOLDS, Decision.NONZERO: Status.FAILS, Decision.UNDECIDED: Status.UNDECIDED}[dec]
    if status is not Status.HOLDS and mx:
        witness["position_monitors"] = mx
    out.append(result(cid, ctx, status, margin=dist, witness=witness))
    return out


@checker("privacy.initial-state")
def check_privacy_initial_state(system: System, ctx: CheckContext) -> list[ConditionResult]:
    """Problem 1 (i) (``prob:privacy``): the initial state x(t0) cannot be reconstructed.

    .. math:: \\mathcal N_1^m \\neq \\{0\\}

    (Lemma II.3: x(t0) is reconstructable iff the unobservable subspace is trivial). Scopes:
    every mode alone and the spec's schedule (scope ``{}``) if any. Numeric and exact
    decisions as in :func:`check_switched_observability`, with holds and fails exchanged.

    Margin
        The number of independent unobservable directions (``dim N``; 0 on failure). The
        condition is a rank condition; its numerical robustness is the margin of
        ``switched-observability``.
    Witness
        A nonzero vector of N (orthonormal numeric or rational exact) that produces the same
        output as the zero state; on failure the observability margin.
    """
    out: list[ConditionResult] = []
    cid = "privacy.initial-state"
    for mode in system.modes:
        S = unobservable_subspace(system, mode, ctx.tol)
        witness: dict[str, Any]
        if ctx.exact:
            basis = unobservable_subspace_exact(system, mode)
            status = Status.HOLDS if basis else Status.FAILS
            dim = len(basis)
            witness = {"dim": dim, "vector": _state_map(system, basis[0], digits=None)} if basis else {"dim": 0, "observability_margin": S.margin}
        else:
            status = _status_from_dims(S.dim, S.dim_upper, observable_holds=False)
            dim = S.dim
            witness = {"dim": dim, "vector": _state_map(system, S.basis[:, 0])} if dim else {"dim": 0, "observability_margin": S.margin}
            if not S.decided:
                witness["dim_upper"] = S.dim_upper
        out.append(result(cid, ctx, status, scope={"mode": mode}, margin=dim, witness=witness))
    seq = mode_sequence(system)
    if seq is None:
        return out
    seq = _check_sequence(system, seq)
    Ssw = switched_unobservable_subspace(system, seq, ctx.tol)
    base = {"sequence": [list(s) for s in seq], "schedule": sequence_text(seq)}
    if ctx.exact:
        b = switched_unobservable_bounds_exact(system, seq)
        if b.dim_upper == 0 or b.dim_lower > 0:
            status = Status.HOLDS if b.dim_lower > 0 else Status.FAILS
            witness = dict(base, dim_lower=b.dim_lower, dim_upper=b.dim_upper)
            if status is Status.HOLDS:
                witness["vector"] = _state_map(system, b.inner[0], digits=None) if b.inner else None
                if not b.inner and b.at_first_switch:
                    witness["state_at_switch"] = _state_map(system, b.at_first_switch[0], digits=None)
            out.append(result(cid, ctx, status, margin=b.dim_lower, witness=witness))
            return out
        status = _status_from_dims(Ssw.dim, Ssw.dim_upper, observable_holds=False)
        witness = dict(base, dim=Ssw.dim, note=_FALLBACK_NOTE, exact_bounds=[b.dim_lower, b.dim_upper])
        if Ssw.dim:
            witness["vector"] = _state_map(system, Ssw.basis[:, 0])
        out.append(result(cid, _numeric_ctx(ctx), status, margin=Ssw.dim, witness=witness))
        return out
    status = _status_from_dims(Ssw.dim, Ssw.dim_upper, observable_holds=False)
    witness = dict(base, dim=Ssw.dim)
    if Ssw.dim:
        witness["vector"] = _state_map(system, Ssw.basis[:, 0])
    if not Ssw.decided:
        witness["dim_upper"] = Ssw.dim_upper
    out.append(result(cid, ctx, status, margin=Ssw.dim, witness=witness))
    return out


def _projection_decision(S: Subspace, f: np.ndarray, tol: Tolerance) -> tuple[Status, float, np.ndarray | None]:
    """Is the unit vector f NOT orthogonal to S? (cosine of the angle between f and S)."""
    c_lo = float(np.linalg.norm(S.basis.T @ f)) if S.dim else 0.0
    c_hi = float(np.linalg.norm(S.upper.T @ f)) if S.dim_upper else 0.0
    if decide_with_error(c_lo, S.error, tol) is Decision.NONZERO:
        v = S.basis @ (S.basis.T @ f)
        return Status.HOLDS, c_lo, v / np.linalg.norm(v)
    if decide_with_error(c_hi, S.error, tol) is Decision.ZERO:
        return Status.FAILS, c_lo, None
    return Status.UNDECIDED, c_lo, None


@checker("privacy.consensus-value")
def check_privacy_consensus_value(system: System, ctx: CheckContext) -> list[ConditionResult]:
    """Problem 1 (i): the consensus value ``x* = (1/N) 1^T x(t0)`` cannot be reconstructed.

    A linear functional ``f^T x(t0)`` is reconstructable from the output iff f is orthogonal to
    the unobservable subspace (``f`` in the row space of the observability map). So with
    ``f = [1/N 1; 0]``:

    .. math:: x^* \\text{ not reconstructable} \\iff f \\not\\perp \\mathcal N_1^m,

    and then two initial states with the same output differ in x*. Scopes: every mode alone
    and the spec's schedule (scope ``{}``) if any.

    Numeric: ``c = ||P_N f|| / ||f||``, the cosine between f and N, decided against ``rtol`` after
    widening by the subspace error (lower reading for holds, upper reading for fails).
    Exact: per mode, ``f . b != 0`` for a rational basis vector b of N. Schedule with two
    modes: ``N_1^2 = exp(-A_1 tau_1) S`` with ``S = N(A_1, C) ∩ N(A_2, C)`` rational, and
    ``exp(-A_1^T tau_1) f = (1/N) [1; kappa 1]`` with ``kappa = (1 - e^{gamma tau_1}) / gamma``, which
    is transcendental (Lindemann: ``e^r`` is transcendental for rational ``r != 0``; ``gamma`` and
    the floating-point ``tau_1`` are rational). Hence ``f`` is orthogonal to ``N_1^2`` iff
    ``sum(s_x) = sum(s_v) = 0`` for every s in S: decided exactly. Longer schedules use the exact
    inner/outer bounds and fall back to the numeric result (flagged) when they disagree.

    Margin
        The cosine ``c`` in [0, 1] (0: x* is reconstructable).
    Witness
        On success a vector v of N with ``f . v != 0`` (``f_dot_v``); exact two-mode schedule: a
        rational state ``s`` at the switch with nonzero position or velocity sum.
    """
    out: list[ConditionResult] = []
    cid = "privacy.consensus-value"
    n = system.n
    f = _consensus(system)
    for mode in system.modes:
        S = unobservable_subspace(system, mode, ctx.tol)
        status, c, v = _projection_decision(S, f, ctx.tol)
        witness: dict[str, Any] = {"cosine": c, "dim": S.dim}
        if ctx.exact:
            basis = unobservable_subspace_exact(system, mode)
            hit = next((b for b in basis if sum(b[:n], Fraction(0)) != 0), None)
            status = Status.HOLDS if hit is not None else Status.FAILS
            witness["dim"] = len(basis)
            if hit is not None:
                witness["vector"] = _state_map(system, hit, digits=None)
                witness["f_dot_v"] = sum(hit[:n], Fraction(0)) / n
        elif v is not None:
            witness["vector"] = _state_map(system, v)
            witness["f_dot_v"] = float(f @ v) / math.sqrt(n)
        out.append(result(cid, ctx, status, scope={"mode": mode}, margin=c, witness=witness))
    seq = mode_sequence(system)
    if seq is None:
        return out
    seq = _check_sequence(system, seq)
    Ssw = switched_unobservable_subspace(system, seq, ctx.tol)
    status, c, v = _projection_decision(Ssw, f, ctx.tol)
    base: dict[str, Any] = {"sequence": [list(s) for s in seq], "schedule": sequence_text(seq), "cosine": c, "dim": Ssw.dim}
    if ctx.exact:
        b = switched_unobservable_bounds_exact(system, seq)
        ex_status: Status | None = None
        witness = dict(base)
        if len(seq) == 1:
            hit = next((x for x in b.inner if sum(x[:n], Fraction(0)) != 0), None)
            ex_status = Status.HOLDS if hit is not None else Status.FAILS
            if hit is not None:
                witness["vector"] = _state_map(system, hit, digits=None)
        elif len(seq) == 2:
            hit = next((x for x in b.at_first_switch if sum(x[:n], Fraction(0)) != 0 or sum(x[n:], Fraction(0)) != 0), None)
            ex_status = Status.HOLDS if hit is not None else Status.FAILS
            witness["reason"] = "f is orthogonal to exp(-A_1 tau_1) S iff every s in S has zero position and velocity sums (kappa is transcendental)"
            if hit is not None:
                witness["state_at_switch"] = _state_map(system, hit, digits=None)
        else:
            hit = next((x for x in b.inner if sum(x[:n], Fraction(0)) != 0), None)
            if hit is not None:
                ex_status = Status.HOLDS
                witness["vector"] = _state_map(system, hit, digits=None)
            elif all(sum(x[:n], Fraction(0)) == 0 for x in b.outer):
                ex_status = Status.FAILS
        if ex_status is not None:
            out.append(result(cid, ctx, ex_status, margin=c, witness=witness))
            return out
        witness["note"] = _FALLBACK_NOTE
        out.append(result(cid, _numeric_ctx(ctx), status, margin=c, witness=witness))
        return out
    witness = dict(base)
    if v is not None:
        witness["vector"] = _state_map(system, v)
        witness["f_dot_v"] = float(f @ v) / math.sqrt(n)
    out.append(result(cid, ctx, status, margin=c, witness=witness))
    return out


# --------------------------------------------------------------------------------------------
# finding: Lemma II.3 (ii) calls N_1^m "the largest A_sigma-invariant subspace contained in ker C"


@finding_rule
def switched_subspace_not_invariant(system: System, results: Sequence[ConditionResult]) -> list[Finding]:
    """Lemma II.3 (ii): the switched unobservable subspace need not be invariant under the A_k.

    The lemma describes ``N_1^m`` as "the largest A_sigma(t)-invariant subspace contained in
    ker(C)". The recursion it gives computes the set of initial states with zero output over the
    schedule, which in general is invariant under none of the A_k; the largest subspace of
    ker C invariant under every A_k (the Krylov closure of C under all modes, computed exactly)
    can be strictly smaller. The rule fires when ``switched-observability`` ran on a schedule
    and the computed ``N_1^m`` has a certainly nonzero invariance residual
    ``||(I - V V^T) A_k V|| > rtol * band * ||A_k||`` for some mode of the schedule.
    """
    if not any(r.id == "switched-observability" and not r.scope for r in results):
        return []
    seq = mode_sequence(system)
    if seq is None or len(seq) < 2:
        return []
    seq = _check_sequence(system, seq)
    tol = DEFAULT_TOLERANCE
    S = switched_unobservable_subspace(system, seq, tol)
    if not S.decided or S.dim == 0:
        return []
    V = S.basis
    residuals: dict[str, float] = {}
    for m in dict.fromkeys(mm for mm, _ in seq):
        w, _ = system.eigh(m)
        scale = max(system.alpha * float(np.max(np.abs(w))), system.gamma, 1.0)
        X = _apply_A(system, m, V)
        res = float(np.linalg.norm(X - V @ (V.T @ X), 2)) / scale
        if decide_with_error(res, S.error, tol) is Decision.NONZERO:
            residuals[m] = res
    if not residuals:
        return []
    n2 = 2 * system.n
    common = _kernel(_row_closure(_exact_C(system), [_exact_A(system, m) for m in dict.fromkeys(mm for mm, _ in seq)])).ncols() if system.n <= 60 else None
    return [
        Finding(
            "lemma2.switched-subspace-not-invariant",
            "The switched unobservable subspace of Lemma II.3 is not invariant under the modes' A_k",
            f"Lemma II.3 (ii) calls N_1^m 'the largest A_sigma(t)-invariant subspace contained in ker(C)'. On the schedule "
            f"{sequence_text(seq)} the recursion gives dim N_1^m = {S.dim}, and this subspace is not invariant under "
            f"{', '.join(residuals)} (relative residuals {', '.join(f'{v:.2g}' for v in residuals.values())})"
            + (f"; the largest subspace of ker C invariant under every A_k has dimension {common}." if common is not None else ".")
            + " The recursion (eqs. obsv_nullspace_1-2) is right; the description is not.",
            "Lemma II.3 (ii)",
            {"schedule": [list(x) for x in seq], "dim": S.dim, "common_invariant_dim": common, "residuals": residuals, "state_dim": n2},
        )
    ]


def _apply_A(system: System, mode: str, X: np.ndarray) -> np.ndarray:
    n = system.n
    L = system.laplacian(mode)
    return np.vstack([X[n:], -system.alpha * (L @ X[:n]) - system.gamma * X[n:]])
