"""Lemma II.3: the unobservable subspace of the switched system over a mode sequence.

Backward recursion ``N := N(A_m, C)``, then ``N := N(A_k, C) ∩ exp(A_k tau_k)^{-1} N`` with the
exponentials in modal form; both readings of undecided decisions are carried; the exact
bounds work over Q. Results are kept on ``system.analysis``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from fractions import Fraction
from typing import Any, Sequence

import networkx as nx
import numpy as np

from glocal_verify.analysis.unobservable.modal import modal_exponential
from glocal_verify.analysis.unobservable.subspace import (
    exact_A,
    exact_observable_rows,
    certified_unobservable,
    structural_basis,
    unobservable_subspace,
)
from glocal_verify.derived import Kind
from glocal_verify.errors import ModelError
from glocal_verify.model import System
from glocal_verify.numerics.exact_subspace import (
    annihilator,
    cols_closure,
    kernel_basis,
    row_basis,
    row_closure,
    to_fraction_cols,
    stack_rows,
)
from glocal_verify.numerics.rounding import EPS
from glocal_verify.numerics.subspace import Subspace, decide_with_error
from glocal_verify.numerics.tolerance import DEFAULT_TOLERANCE, Decision, Tolerance
from glocal_verify.spec.types import NORMAL_MODE

__all__ = [
    "CertifiedSwitched",
    "certified_switched",
    "union_components",
    "SwitchedBounds",
    "switched_unobservable_subspace",
    "switched_unobservable_bounds_exact",
    "mode_sequence",
    "check_sequence",
    "sequence_text",
]

#: derived results this module keeps on the system (glocal_verify.derived)
_SWITCHED_KIND: Kind[Subspace] = Kind("switched", __name__, "Subspace")
_SWITCHED_EXACT_KIND: Kind[SwitchedBounds] = Kind("switched-exact", __name__, "SwitchedBounds")
_CERTIFIED_SWITCHED_KIND: Kind[CertifiedSwitched] = Kind("certified-switched", __name__, "CertifiedSwitched")

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
    """span(P) ∩ span(V) for orthonormal P, V: kernel of ``(I - P P^T) V`` (sines of principal angles).

    Memory: ``P^T V`` (``k_P x k``), one ``2N x k`` residual and its SVD factors; nothing ``2N x 2N``.
    """
    k = V.shape[1]
    if k == 0:
        return V, True, 1.0
    if P.shape[1] == 0:
        return V[:, :0], True, 1.0
    R = P @ (P.T @ V)
    np.subtract(V, R, out=R)  # R = V - P P^T V in place: one 2N x k temporary, not two
    _, s, Vh = np.linalg.svd(R, full_matrices=False)
    sp = np.zeros(k)
    sp[: len(s)] = s
    dec = [decide_with_error(x, err, tol) for x in sp]
    r_lo = sum(1 for d in dec if d is Decision.NONZERO)
    r_hi = sum(1 for d in dec if d is not Decision.ZERO)
    margin = float(sp[r_lo - 1]) if r_lo else 1.0
    Z = Vh.T[:, (r_lo if upper else r_hi) :]
    return V @ Z, r_lo == r_hi, margin


def check_sequence(system: System, sequence: Sequence[tuple[str, float]]) -> list[tuple[str, float]]:
    """``sequence`` as ``(mode, duration)`` pairs of known modes and positive finite dwell times.

    Parameters
    ----------
    system : System
    sequence : sequence of (mode, duration)

    Raises
    ------
    ModelError
        For an empty sequence, an unknown mode or a dwell time that is not positive and finite.
    """
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

    Memory: O(N d) with ``d`` the largest dimension met (``2N x d`` bases, their residual and SVD
    factors, and the ``N x d`` modal coordinates of :func:`modal_exponential`), on top of the
    cached ``U`` of each mode; no ``2N x 2N`` array. When every input and every intersection is
    decided, the upper reading is the lower one and is not recomputed.

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
    return _SWITCHED_KIND.get(system, (tuple((m, float(t)) for m, t in sequence), tol.rtol, tol.band), lambda: _switched_recursion(system, sequence, tol))


def _switched_recursion(
    system: System, sequence: Sequence[tuple[str, float]], tol: Tolerance = DEFAULT_TOLERANCE
) -> Subspace:
    """Uncached body of :func:`switched_unobservable_subspace`."""
    seq = check_sequence(system, sequence)
    subs = {m: unobservable_subspace(system, m, tol) for m, _ in seq}
    results: dict[bool, tuple[np.ndarray, float]] = {}
    decided = all(subs[m].decided for m, _ in seq)
    margin = 1.0
    steps: list[dict[str, Any]] = []
    for upper in (False, True):
        if upper and decided and all(subs[m].upper is subs[m].basis for m, _ in seq):
            # every input and every intersection decided: the upper pass would repeat the lower one
            results[True] = results[False]
            break
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
            scale = float(np.max(np.abs(system.spectrum(mode).values))) if system.n else 0.0
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
    return _SWITCHED_EXACT_KIND.get(system, (tuple((m, float(t)) for m, t in sequence),), lambda: _switched_bounds_exact(system, sequence))


def _switched_bounds_exact(system: System, sequence: Sequence[tuple[str, float]]) -> SwitchedBounds:
    """Uncached body of :func:`switched_unobservable_bounds_exact`."""
    seq = check_sequence(system, sequence)
    n2 = 2 * system.n
    modes = [m for m, _ in seq]
    A = {m: exact_A(system, m) for m in set(modes)}
    R = {m: exact_observable_rows(system, m) for m in set(modes)}
    m = len(seq)
    if m == 1:
        K = kernel_basis(R[modes[0]])
        basis = to_fraction_cols(K)
        return SwitchedBounds(len(basis), len(basis), basis, basis, [], True)
    # inner: annihilator rows of L_{k}
    lo_rows = R[modes[-1]]
    for k in range(m - 2, 0, -1):
        lo_rows = row_closure(stack_rows([R[modes[k]], lo_rows], n2), [A[modes[k]]])
    first = row_basis(stack_rows([R[modes[0]], lo_rows], n2))
    dim_lo = n2 - first.nrows()
    inner = kernel_basis(row_closure(first, [A[modes[0]]]))
    # outer: column bases of U_k
    U = kernel_basis(R[modes[-1]])
    for k in range(m - 2, 0, -1):
        S = kernel_basis(stack_rows([R[modes[k]], annihilator(U)], n2)) if U.ncols() else U
        U = cols_closure(S, A[modes[k]])
    if U.ncols():
        S1 = kernel_basis(stack_rows([R[modes[0]], annihilator(U)], n2))
    else:
        S1 = U
    dim_hi = S1.ncols()
    outer = cols_closure(S1, A[modes[0]]) if S1.ncols() else S1
    at_switch = to_fraction_cols(S1) if m == 2 else []
    return SwitchedBounds(
        dim_lower=dim_lo,
        dim_upper=dim_hi,
        inner=to_fraction_cols(inner),
        outer=to_fraction_cols(outer),
        at_first_switch=at_switch,
        exact_dimension=dim_lo == dim_hi,
    )


# --------------------------------------------------------------------------------------------
# certified bounds for the switched subspace (structure + per-mode certificates)


def union_components(system: System, modes: Sequence[str]) -> list[list[Any]]:
    """Components of the union of the graphs of ``modes`` (exact edge sets), each in label order.

    Parameters
    ----------
    system : System
        The multi-agent system.
    modes : sequence of str
        The modes of a schedule.
    """
    G = nx.Graph()
    G.add_nodes_from(system.labels)
    for m in dict.fromkeys(modes):
        for key in system.edges(m):
            u, v = tuple(key)
            G.add_edge(u, v)
    comps = [sorted(c, key=system.index.__getitem__) for c in nx.connected_components(G)]
    return sorted(comps, key=lambda c: system.index[c[0]])


@dataclass(frozen=True, slots=True)
class CertifiedSwitched:
    """Proven bounds on ``dim N_1^m`` for every dwell time, from structure and per-mode certificates.

    Attributes
    ----------
    dim_lower : int
        ``dim I`` with ``I = {[w; z] : w in K_x, z in K}``, ``K_x`` (``K``) the vectors constant on
        the components of the union of the schedule's graphs and zero on those with a position
        monitor (with any monitor). I is invariant under every A_k and inside ker C, hence in
        ``N_1^m`` (exact).
    dim_upper : int
        ``min_k`` of the proven upper bounds of ``dim N(A_k, C)`` (``dim N_1^m <= dim N(A_k, C)``
        for every k of the schedule), and ``dim I`` when every mode is certified to have only
        its structural part (then ``N_1^m = I`` exactly, for every dwell time).
    inner : tuple of tuple of Fraction
        Exact basis of I.
    first_upper : int
        Proven upper bound of ``dim N(A_1, C)`` for the first mode (``N_1^m`` lies in it).
    first_structural_positions : int
        Number of components of the first mode's graph without a position monitor.
    all_structural : bool
        Every mode of the schedule is certified (its unobservable subspace is its structural part).
    error_bound : float
        Largest certified eigenvector error met.
    note : str
        Why the bounds do not meet ('' when decided).
    """

    dim_lower: int
    dim_upper: int
    inner: tuple[tuple[Fraction, ...], ...]
    first_upper: int
    first_structural_positions: int
    all_structural: bool
    error_bound: float
    note: str

    @property
    def decided(self) -> bool:
        """``dim_lower == dim_upper``."""
        return self.dim_lower == self.dim_upper


def certified_switched(system: System, sequence: Sequence[tuple[str, float]]) -> CertifiedSwitched:
    """Proven bounds on ``dim N_1^m`` (cached), valid for every dwell time.

    Lower bound: the exact subspace I of :class:`CertifiedSwitched` (for ``z`` constant on
    the union components, ``exp(A_k t) [0; z] = [(1 - e^{-gamma t}) z / gamma; e^{-gamma t} z]``
    and ``A_k [w; 0] = 0``). Upper bound: ``N_k = exp(-A_k tau_k)(N(A_k, C) ∩ N_{k+1})`` gives
    ``dim N_1^m <= dim N(A_k, C)`` for every k, with the per-mode bounds of
    :func:`~glocal_verify.analysis.unobservable.subspace.certified_unobservable`; when every mode is
    certified to have only its structural part ``S_k`` (``mu = 0``), ``S_k ∩ S_{k+1}`` is
    A_k-invariant and the recursion gives ``N_1^m = ∩_k S_k = I`` exactly.

    Parameters
    ----------
    system : System
        The multi-agent system.
    sequence : sequence of (mode, duration)
        The schedule.
    """
    seq = check_sequence(system, sequence)
    params = (tuple(m for m, _ in seq),)
    kept = _CERTIFIED_SWITCHED_KIND.peek(system, params)
    if kept is not None:
        return kept
    modes = [m for m, _ in seq]
    inner = structural_basis(system, union_components(system, modes))
    per = {m: certified_unobservable(system, m) for m in dict.fromkeys(modes)}
    all_structural = all(c.dim_upper == len(c.structural) for c in per.values())
    upper = min(c.dim_upper for c in per.values())
    if all_structural:
        upper = min(upper, len(inner))
    first = per[modes[0]]
    mx = set(system.monitored_positions)
    first_pos = sum(1 for c in system.components(modes[0]) if not mx.intersection(c))
    note = ""
    if upper != len(inner):
        notes = [c.note for c in per.values() if c.note]
        note = notes[0] if notes else (
            f"the schedule's modes have larger unobservable subspaces (proven dims {sorted(c.dim_lower for c in per.values())}) "
            f"than the common structural part (dim {len(inner)}); which of them survive the schedule is not proven"
        )
    out = CertifiedSwitched(
        dim_lower=len(inner),
        dim_upper=upper,
        inner=inner,
        first_upper=first.dim_upper,
        first_structural_positions=first_pos,
        all_structural=all_structural,
        error_bound=max(c.error_bound for c in per.values()),
        note=note,
    )
    _CERTIFIED_SWITCHED_KIND.put(system, params, out)
    return out
