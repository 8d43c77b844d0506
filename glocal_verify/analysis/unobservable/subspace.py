"""The unobservable subspace of (A_q, C) per mode: from the modal structure, and over Q.

``N(A_q, C) = (W^x_0 x W_0) ⊕ ⊕_{mu>0} (W_mu x W_mu)`` assembled from
:func:`~glocal_verify.analysis.unobservable.modal.modal_decomposition`; the exact path closes the rows of C
under A_q over Q. Results are kept on ``system.analysis``.
"""

from __future__ import annotations

from fractions import Fraction
from typing import Sequence

import math
from dataclasses import dataclass

import flint
import numpy as np
import scipy.linalg

from glocal_verify import config
from glocal_verify.analysis.unobservable.modal import EigenGroupPart, form_bases, modal_decomposition
from glocal_verify.derived import Kind
from glocal_verify.model import System
from glocal_verify.numerics.exact_subspace import (
    kernel_basis,
    qmat,
    row_closure,
    to_fraction_cols,
)
from glocal_verify.numerics.minors import RATIONAL_ZERO
from glocal_verify.numerics.rounding import EPS
from glocal_verify.numerics.spectrum import Spectrum
from glocal_verify.numerics.subspace import Subspace, decide_with_error
from glocal_verify.numerics.tolerance import DEFAULT_TOLERANCE, Decision, Tolerance
from glocal_verify.spec.types import NORMAL_MODE

__all__ = [
    "unobservable_subspace",
    "unobservable_subspace_exact",
    "CertifiedUnobservable",
    "certified_unobservable",
    "structural_basis",
    "rational_unobservable_candidates",
    "exact_A",
    "exact_C",
    "exact_N",
    "exact_observable_rows",
]

#: derived results this module keeps on the system (glocal_verify.derived)
_N_KIND: Kind[Subspace] = Kind("N", __name__, "Subspace")
_EXACT_ROWS_KIND: Kind[flint.fmpq_mat] = Kind("exact-rows", __name__, "fmpq_mat")
_EXACT_N_KIND: Kind[flint.fmpq_mat] = Kind("exact-N", __name__, "fmpq_mat")
_CERTIFIED_N_KIND: Kind[CertifiedUnobservable] = Kind("certified-N", __name__, "CertifiedUnobservable")

def _assemble(n: int, groups: Sequence[EigenGroupPart], upper: bool) -> tuple[np.ndarray, bool]:
    """Basis of (W^x_0 x W_0) ⊕ ⊕_{mu>0} (W_mu x W_mu) for one reading; also 'zero decisions certain'.

    The ``2N x d`` result (``d`` the dimension of the reading) is allocated once and filled in
    place: no per-column temporaries.
    """
    certain = True
    parts: list[tuple[np.ndarray, np.ndarray]] = []
    for g in groups:
        if g.zero is Decision.UNDECIDED:
            certain = False
        as_zero = g.zero is Decision.ZERO or (upper and g.zero is Decision.UNDECIDED)
        dim_w = g.dim_W_upper if upper else g.dim_W
        dim_pos = (g.dim_Wx_upper if upper else g.dim_Wx) if as_zero else dim_w
        if not (dim_pos or dim_w):
            continue  # nothing to add: the group's basis is not formed
        W = g.W_upper if upper else g.W
        # W^x_0 in the position slot for mu = 0 (W_0, a subspace of it, in the velocity slot)
        pos = (g.Wx_upper if upper else g.Wx) if as_zero else W
        parts.append((pos, W))
    d = sum(p.shape[1] + v.shape[1] for p, v in parts)
    B = np.zeros((2 * n, d))
    j = 0
    for pos, W in parts:
        B[:n, j : j + pos.shape[1]] = pos
        j += pos.shape[1]
        B[n:, j : j + W.shape[1]] = W
        j += W.shape[1]
    return B, certain


def unobservable_subspace(system: System, mode: str = NORMAL_MODE, tol: Tolerance = DEFAULT_TOLERANCE) -> Subspace:
    """Unobservable subspace of ``(A_q, C)`` from the modal structure of L_q.

    .. math::

        \\mathcal N(A_q, C) = (W^x_0 \\times W_0) \\oplus \\bigoplus_{\\mu > 0} (W_\\mu \\times W_\\mu),
        \\quad W^x_\\mu = E_\\mu \\cap \\ker S_{M_x},\\; W_\\mu = E_\\mu \\cap \\ker S_M

    (``docs/conditions.md``, "Modal structure"; the double root ``gamma^2 = 4 alpha mu`` needs no
    special case: the formula does not involve the eigenvalues of A_q). Cost: one ``eigh`` of
    L_q (cached by the system), a column norm of ``S_M u_i`` per simple eigenvalue and an SVD
    of ``S_M E_mu`` per multiple group; no 2N x 2N matrix. Memory beyond ``U``: the two bases,
    ``2N x d`` and ``2N x d'`` (``d <= d'`` the dimensions of the readings); when every decision
    is decided they are one shared array.

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
    params = (mode, tol.rtol, tol.band)
    kept = _N_KIND.peek(system, params)
    if kept is not None:
        return kept
    md = modal_decomposition(system, mode, tol)
    n = system.n
    # the bases of the groups with an unobservable part W (the kernel's is exact), formed together:
    # one pass over a factored basis
    form_bases(system.spectrum(mode), [g for g in (*md.groups, *md.merged) if g.dim_W or g.dim_W_upper])
    lower, certain_lo = _assemble(n, md.groups, upper=False)
    # every decision decided: the upper reading is the lower one (shared, not rebuilt)
    same = md.merged is md.groups and all(g.decided and g.zero is not Decision.UNDECIDED for g in md.groups)
    upper, certain_hi = (lower, certain_lo) if same else _assemble(n, md.merged, upper=True)
    margin = 1.0
    largest_zero = 0.0
    for g in md.groups:
        s = g.svx if g.zero is Decision.ZERO else g.sv
        if len(s):
            margin = min(margin, float(s[-1]))
        for x in s:
            if decide_with_error(x, g.error, tol) is Decision.ZERO:
                largest_zero = max(largest_zero, float(x))
    err = max((g.error for g in md.groups if (g.dim_W or g.dim_Wx)), default=0.0)
    groups_ev = [
        {
            "eigenvalue": g.value,
            "multiplicity": len(g.indices),
            "dim_W": g.dim_W,
            "dim_Wx": g.dim_Wx if g.zero is Decision.ZERO else None,
        }
        for g in md.groups
        if g.dim_W or (g.zero is Decision.ZERO and g.dim_Wx) or g.zero is Decision.UNDECIDED
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
    _N_KIND.put(system, params, sub)
    return sub


def exact_A(system: System, mode: str) -> flint.fmpq_mat:
    """``A_q = [[0, I], [-alpha L_q, -gamma I]]`` over Q (2N x 2N).

    Parameters
    ----------
    system : System
    mode : str
    """
    n = system.n
    L = system.laplacian_exact(mode)
    al, ga = system.alpha_q, system.gamma_q
    rows: list[list[Fraction]] = []
    for i in range(n):
        rows.append([Fraction(int(j == n + i)) for j in range(2 * n)])
    for i in range(n):
        rows.append([-al * L[i][j] for j in range(n)] + [(-ga if j == i else Fraction(0)) for j in range(n)])
    return qmat(rows, 2 * n)


def exact_C(system: System) -> flint.fmpq_mat:
    """The selection output ``C = blkdiag(S_{M_x}, S_{M_v})`` over Q.

    Parameters
    ----------
    system : System
    """
    n = system.n
    rows = []
    for i in system.idx(system.monitored_positions):
        rows.append([int(j == i) for j in range(2 * n)])
    for i in system.idx(system.monitored_velocities):
        rows.append([int(j == n + i) for j in range(2 * n)])
    return qmat(rows, 2 * n)


def exact_observable_rows(system: System, mode: str) -> flint.fmpq_mat:
    """Row basis of the observable row space of (A_q, C): the annihilator of N(A_q, C).

    Parameters
    ----------
    system : System
    mode : str
    """
    return _EXACT_ROWS_KIND.get(system, (mode,), lambda: row_closure(exact_C(system), [exact_A(system, mode)]))


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
    K = kernel_basis(exact_observable_rows(system, mode))
    return to_fraction_cols(K)


def exact_N(system: System, mode: str) -> flint.fmpq_mat:
    """A rational basis of ``N(A_q, C)`` as the columns of a 2N x k matrix (kept on the system).

    Parameters
    ----------
    system : System
    mode : str
    """
    return _EXACT_N_KIND.get(system, (mode,), lambda: kernel_basis(exact_observable_rows(system, mode)))


# --------------------------------------------------------------------------------------------
# certified dimension bounds (structure + rigorous floating-point bounds)


@dataclass(frozen=True, slots=True)
class CertifiedUnobservable:
    """Rigorous bounds on ``dim N(A_q, C)`` from exact structure and certified eigenvector bounds.

    Attributes
    ----------
    mode : str
        The mode q.
    dim_lower : int
        Proven lower bound: ``dim (W^x_0 x W_0)``, read from the exact components of G_q
        (``ker L_q`` is spanned by their indicators): the number of components without a
        position monitor plus the number without any monitor (``2N`` when nothing is monitored).
    dim_upper : int
        Proven upper bound: ``dim_lower + 2 * (sizes of the eigenvalue clusters of mu > 0 on
        which S_M is not certified injective)``.
    structural : tuple of tuple of Fraction
        Exact rational basis (length 2N) of ``W^x_0 x W_0``: ``[1_c; 0]`` for components c
        without a position monitor, ``[0; 1_c]`` for components without any monitor.
    error_bound : float
        Largest certified eigenvector error (sine) met; ``inf`` for a cluster that is not
        separated at all.
    note : str
        Which bound failed and by how much ('' when decided).
    slack : float
        Smallest certified ``sigma_min(S_M U_g) sqrt(1 - s^2) - s - e`` over the clusters (the
        quantity whose positivity proves injectivity; 1.0 when there is none).
    verified : tuple of tuple of Fraction
        Exact rational basis (length 2N) of a part ``W x W`` of the summands ``mu > 0``: W is
        rationalised from the floating-point clusters where S_M is numerically singular, then
        proven L_q-invariant, zero on M and free of ``ker L_q`` in exact arithmetic
        (:func:`~glocal_verify.numerics.minors.verified_invariant_subspace`). Counted in
        ``dim_lower``; empty when no cluster needed it.
    """

    mode: str
    dim_lower: int
    dim_upper: int
    structural: tuple[tuple[Fraction, ...], ...]
    error_bound: float
    note: str
    slack: float
    verified: tuple[tuple[Fraction, ...], ...] = ()

    @property
    def exact_basis(self) -> tuple[tuple[Fraction, ...], ...]:
        """``structural + verified``: an exact basis of a subspace of N of dimension ``dim_lower``."""
        return self.structural + self.verified

    @property
    def decided(self) -> bool:
        """``dim_lower == dim_upper``: the dimension is proven."""
        return self.dim_lower == self.dim_upper


def structural_basis(system: System, comps: Sequence[Sequence[object]]) -> tuple[tuple[Fraction, ...], ...]:
    """``[1_c; 0]`` for each component without a position monitor, ``[0; 1_c]`` without any monitor (exact).

    Parameters
    ----------
    system : System
        The multi-agent system (its monitor sets).
    comps : sequence of label sequences
        Components (of one mode's graph, or of the union of a schedule's graphs).
    """
    n = system.n
    mx = set(system.monitored_positions)
    m = set(system.monitored)
    out: list[tuple[Fraction, ...]] = []
    members = [set(c) for c in comps]
    zero, one = Fraction(0), Fraction(1)
    for c in members:
        if not mx.intersection(c):
            ind = [one if lab in c else zero for lab in system.labels]
            out.append(tuple(ind + [zero] * n))
    for c in members:
        if not m.intersection(c):
            ind = [one if lab in c else zero for lab in system.labels]
            out.append(tuple([zero] * n + ind))
    return tuple(out)


def rational_unobservable_candidates(E: np.ndarray, measured: Sequence[int]) -> list[list[Fraction]]:
    """Rationalised echelon rows spanning ``span(E) ∩ ker S_M`` (floating point, unproven).

    ``E`` (N x k) is the computed basis of an eigenvalue cluster; the right singular vectors
    of ``E[M, :]`` with singular value <= ``candidate_zero`` (:mod:`glocal_verify.config`) give the numerical null
    space; its basis is brought to reduced echelon form (pivoted QR, then a solve) and each
    entry rounded to the nearest fraction with denominator <= 10^6 (entries below 1e-9 to 0).
    Twin modes come out exact; the caller must prove whatever it uses.

    Parameters
    ----------
    E : ndarray (N, k)
    measured : sequence of int
        M.
    """
    S = E[list(measured), :]
    if S.size:
        _, sv, vh = np.linalg.svd(S)
        r = int(np.sum(sv > config.get("candidate_zero")))
        null = vh[r:].conj().T
    else:
        null = np.eye(E.shape[1])
    if null.shape[1] == 0:
        return []
    Wt = (E @ null).T  # k x N
    _, _, piv = scipy.linalg.qr(Wt, pivoting=True, mode="economic")
    P = piv[: Wt.shape[0]]
    R = np.linalg.solve(Wt[:, P], Wt)
    zero = RATIONAL_ZERO  # shared: most entries are zero
    return [[zero if abs(x) < 1e-9 else Fraction(float(x)).limit_denominator(10**6) for x in row] for row in R.tolist()]


def _verified_singular_part(
    system: System, mode: str, sp: Spectrum, M: Sequence[int], singular: Sequence[tuple[int, int, float, float, np.ndarray]]
) -> tuple[tuple[tuple[Fraction, ...], ...], int]:
    """Exact ``W x W`` basis (length 2N) from the numerically singular clusters, and the upper bound on dim W.

    W: the candidates of :func:`rational_unobservable_candidates`, cluster by cluster, kept
    when :func:`~glocal_verify.numerics.minors.verified_invariant_subspace` proves them (with
    the ones kept before) L_q-invariant and zero on M, and the restriction B of L_q to them
    is exactly nonsingular (so W meets ``ker L_q`` only in 0). Upper bound: per cluster,
    ``k - #{i : sigma_i(S_M U_g) sqrt(1 - s^2) - s - e > 0}`` (the i-th singular value of
    S_M on the exact spectral subspace exceeds the same bound as the smallest one does in
    :func:`certified_unobservable`; Weyl for singular values), summed.
    """
    from glocal_verify.analysis.laplacian.twins import laplacian_entries
    from glocal_verify.numerics.minors import verified_invariant_subspace

    upper_w = 0
    for a, b, s, e, sv in singular:
        proven = int(np.sum(sv * math.sqrt(max(0.0, 1.0 - s * s)) - s - e > 0)) if math.isfinite(s) else 0
        upper_w += (b - a + 1) - proven
    if upper_w > config.get("max_verified_candidates") or any(float(sv[-1]) > config.get("candidate_zero") for *_, sv in singular):
        return (), upper_w
    entries = laplacian_entries(system, mode)
    kept: list[list[Fraction]] = []
    B: list[list[Fraction]] = []
    # the clusters' columns together: one pass over a factored basis
    cols = sp.columns(np.concatenate([np.arange(a, b + 1) for a, b, *_ in singular]))
    start = 0
    for a, b, *_ in singular:
        E, start = cols[:, start : start + b - a + 1], start + b - a + 1
        rows = rational_unobservable_candidates(E, M)
        if not rows:
            continue
        ver = verified_invariant_subspace(system.n, entries, M, kept + rows)
        if ver is not None:
            kept, B = ver
    if not kept or flint.fmpq_mat(len(B), len(B), [flint.fmpq(x.numerator, x.denominator) for row in B for x in row]).det() == 0:
        return (), upper_w
    n = system.n
    zero = [Fraction(0)] * n
    basis = tuple(tuple(wv) + tuple(zero) for wv in kept) + tuple(tuple(zero) + tuple(wv) for wv in kept)
    return basis, upper_w


def certified_unobservable(system: System, mode: str = NORMAL_MODE) -> CertifiedUnobservable:
    """Proven bounds on ``dim N(A_q, C)`` (cached): structure for ``mu = 0``, certificates for ``mu > 0``.

    ``N(A_q, C) = (W^x_0 x W_0) ⊕ ⊕_{mu>0} (W_mu x W_mu)`` (module docstring). The first
    summand is exact: ``ker L_q`` is spanned by the indicators of the components of G_q (the
    exact edge set), so ``W^x_0``/``W_0`` are spanned by the indicators of the components
    without position monitor / without any monitor. For ``mu > 0`` nothing small is read as
    zero: the eigenvalues of index ``>= #components`` are grouped into the certified clusters
    of :attr:`Spectrum.clusters <glocal_verify.numerics.spectrum.Spectrum.clusters>` (Weyl
    radius rho); for a cluster g with computed basis ``U_g`` and Davis-Kahan sine bound ``s``
    (:meth:`Spectrum.subspace_sine <glocal_verify.numerics.spectrum.Spectrum.subspace_sine>`),
    every unit x of the exact spectral subspace has

    .. math:: \\|S_M x\\| \\ge \\sigma_{\\min}(S_M U_g) \\sqrt{1 - s^2} - s - e,

    ``e = eta + 2 k eps + sqrt(|M| k) epsilon_U`` (loss of orthonormality ``eta``, the rounding
    of the k x k SVD of rows of ``U_g``, backward error ``k eps`` per singular value, doubled, and
    the error ``epsilon_U`` of each computed entry of the rows: 0 for explicit eigenvectors,
    :attr:`~glocal_verify.numerics.spectrum.Spectrum.entry_error` for a safe mode kept in
    factored form). If it is positive,
    S_M is injective on every eigenspace of the cluster: ``W_mu = 0`` there (certified). A
    cluster that fails the test adds at most ``2 |g|`` to the upper bound. A cluster that
    straddles 0 and a positive eigenvalue (``w <= rho``) is treated the same way, with the
    exact zero eigenvalues removed from it (they are known exactly).

    Cost and memory (after the cached spectrum and its bounds): O(N^2) once per mode for the
    rounding constants, the monitored rows ``U[M, :]`` (``|M| x N``; ``|M| N^2`` per factor of a
    factored spectrum) and, per cluster, a column norm (simple) or a ``|M| x k`` SVD; no
    ``N x N`` array is formed.

    Parameters
    ----------
    system : System
        The multi-agent system.
    mode : str
        The mode q.
    """
    kept = _CERTIFIED_N_KIND.peek(system, (mode,))
    if kept is not None:
        return kept
    system.check_mode(mode)
    n = system.n
    comps = system.components(mode)
    struct = structural_basis(system, comps)
    m = system.idx(system.monitored)
    if not m:
        cu = CertifiedUnobservable(mode, 2 * n, 2 * n, struct, 0.0, "", 1.0)
        _CERTIFIED_N_KIND.put(system, (mode,), cu)
        return cu
    sp = system.spectrum(mode)
    w = sp.values
    nz = len(comps)
    rho = sp.error_radius
    eta = sp.orthogonality_error
    # per-mode constants of the residual rounding bound (O(N^2) once, not per cluster)
    k_row = sp.row_nonzeros
    fro = sp.frobenius
    Um = sp.rows(m)  # |M| x N: the only rows of U the certificate needs
    entry = sp.entry_error  # their computed entries' error (0 for explicit eigenvectors)
    col_m = np.linalg.norm(Um, axis=0)
    extra = 0
    worst_err = 0.0
    slack_min = 1.0
    note = ""
    # clusters where S_M is numerically singular: (first index, last index, sine, error, singular values)
    singular: list[tuple[int, int, float, float, np.ndarray]] = []
    for c in sp.clusters:
        if c[-1] < nz:
            continue
        a, b = max(c[0], nz), c[-1]
        g = range(a, b + 1)
        # distance of the cluster's Ritz values to the other exact eigenvalues: the exact zeros are 0,
        # the others lie within rho of their computed values (Weyl, index pairing)
        left = (w[a] if a - 1 < nz else w[a] - w[a - 1] - rho) if a > 0 else math.inf
        right = w[b + 1] - w[b] - rho if b + 1 < n else math.inf
        delta = float(min(left, right))
        if delta > 0:
            r = float(abs(sp.residuals[a])) if a == b else float(np.linalg.norm(sp.residuals[a : b + 1]))
            r += (k_row + 2) * EPS * math.sqrt(n) * (fro + float(np.max(np.abs(w[a : b + 1])))) + sp.input_error
            s = min(1.0, r * (1.0 + 4.0 * n * EPS) / delta)
        else:
            s = math.inf
        if a == b:
            # simple: the singular value of the |M| x 1 matrix S_M u_a is its norm, rounded by at
            # most (|M| / 2 + 1) u, which the 2 N eps inside eta covers
            sv = col_m[a : a + 1]
        else:
            sv = np.linalg.svd(Um[:, a : b + 1], compute_uv=False)
            if len(sv) < len(g):
                sv = np.concatenate([sv, np.zeros(len(g) - len(sv))])
        smin = float(sv[-1])
        e = eta + 2.0 * len(g) * EPS + math.sqrt(len(m) * len(g)) * entry
        slack = smin * math.sqrt(max(0.0, 1.0 - s * s)) - s - e if math.isfinite(s) else -math.inf
        worst_err = max(worst_err, s)
        slack_min = min(slack_min, slack)
        if not slack > 0:
            extra += 2 * len(g)
            singular.append((a, b, s, e, sv))
            if not note:
                note = (
                    f"mode {mode}: eigenvalue cluster {a + 1}..{b + 1} (mu ~ {float(np.mean(w[a : b + 1])):.6g}): "
                    f"sigma_min(S_M U_g) = {smin:.3g} does not exceed its certified error "
                    f"(Davis-Kahan sine {s:.3g} + {e:.2g}); whether an unobservable eigenvector exists there is not proven"
                )
    base = len(struct)
    verified: tuple[tuple[Fraction, ...], ...] = ()
    upper = base + extra
    if singular:
        verified, upper_w = _verified_singular_part(system, mode, sp, m, singular)
        if verified:
            upper = base + 2 * upper_w  # every cluster that failed the injectivity test is in `singular`
            if len(verified) > upper - base:  # pragma: no cover - a contradiction is a bug
                raise RuntimeError(f"internal: mode {mode}: an exactly verified unobservable part exceeds its certified upper bound")
            if base + len(verified) == upper:
                note = ""
    cu = CertifiedUnobservable(mode, base + len(verified), min(2 * n, upper), struct, worst_err, note, slack_min, verified)
    _CERTIFIED_N_KIND.put(system, (mode,), cu)
    return cu
