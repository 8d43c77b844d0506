"""The unobservable subspace of (A_q, C) per mode: from the modal structure, and over Q.

``N(A_q, C) = (W^x_0 x W_0) ⊕ ⊕_{mu>0} (W_mu x W_mu)`` assembled from
:func:`~glocal_verify.analysis.modal.modal_decomposition`; the exact path closes the rows of C
under A_q over Q. Results are kept on ``system.analysis``.
"""

from __future__ import annotations

from fractions import Fraction
from typing import Sequence

import flint
import numpy as np

from glocal_verify.analysis.modal import EigenGroupPart, modal_decomposition
from glocal_verify.model import System
from glocal_verify.numerics.exact_subspace import (
    _kernel,
    _qmat,
    _row_closure,
    _to_fraction_cols,
)
from glocal_verify.numerics.subspace import Subspace, decide_with_error
from glocal_verify.numerics.tolerance import DEFAULT_TOLERANCE, Decision, Tolerance
from glocal_verify.spec.types import NORMAL_MODE

__all__ = [
    "unobservable_subspace",
    "unobservable_subspace_exact",
]

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

    (``docs/conditions.md``, "Modal structure"; the double root ``gamma^2 = 4 alpha mu`` needs no
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
    cache = system.analysis
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
    cache = system.analysis
    if key not in cache:
        cache[key] = _row_closure(_exact_C(system), [_exact_A(system, mode)])
    return cache[key]  # type: ignore[no-any-return]


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
    cache = system.analysis
    if key not in cache:
        cache[key] = _kernel(_exact_obs_rows(system, mode))
    return cache[key]  # type: ignore[no-any-return]
