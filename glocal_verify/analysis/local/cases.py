"""The local cases of Proposition III.2: one per cluster, observer, mode and suspected set.

A :class:`LocalCase` bundles the cluster model (eq. ``cluster_dyn2``), the observer's output
matrix and the suspected actuators (the spec's attack, or every agent of the cluster for the
worst case of Remark III.2.1), with the pencil matrices numeric and exact.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from fractions import Fraction
from typing import Any, Mapping

import numpy as np
import scipy.sparse

from glocal_verify import config
from glocal_verify.analysis.local.pencil_rank_certificates import measured_inputs_unknown, observability_certificate, zero_count_certificate
from glocal_verify.derived import Kind
from glocal_verify.model import ClusterModel, LocalObserver, System
from glocal_verify.numerics.minors import RATIONAL_ZERO
from glocal_verify.results import Status, Verdict
from glocal_verify.spec.types import NORMAL_MODE, Label

__all__ = [
    "LocalCase",
    "PencilScreen",
    "certificate_verdict",
    "certify_pencil_verdict",
    "exact_int",
    "cluster_summary",
    "exact_A_float",
    "full_pencil",
    "full_pencil_sparse",
    "local_cases",
    "input_output_matrices",
    "pencil_matrices",
    "pencil_matrices_exact",
    "screened_pencil_verdict",
]

#: derived results this module keeps on the system (glocal_verify.derived)
_ALPHA_LAPLACIAN_MOD_KIND: Kind[Any] = Kind("alpha-laplacian-mod", __name__, "Any")
_EXACT_A_KIND: Kind[Any] = Kind("exact-A", __name__, "Any")
_GROUNDED_TABLES_KIND: Kind[Any] = Kind("grounded-tables", __name__, "Any")
_LOCAL_MINOR_CERTIFICATE_KIND: Kind[str | None] = Kind("local-minor-certificate", __name__, "str | None")
_TWIN_MODES_KIND: Kind[Any] = Kind("twin-modes", __name__, "Any")

# --------------------------------------------------------------------------------------------
# cases


@dataclass(frozen=True, slots=True)
class LocalCase:
    """One (cluster, observer, suspected set) combination.

    Attributes
    ----------
    model : ClusterModel
        Cluster matrices in ``mode``.
    observer : LocalObserver
        Centre and resolved measured sets.
    kind : str
        ``"attack"`` or ``"all"`` (the scope's ``suspected`` value).
    suspected : tuple of labels
        Suspected agents inside the cluster, in cluster order.
    mode : str
        Mode of the cluster model (the normal mode for the checkers).
    """

    model: ClusterModel
    observer: LocalObserver
    kind: str
    suspected: tuple[Label, ...]
    mode: str = NORMAL_MODE

    @property
    def scope(self) -> dict[str, Any]:
        return {"cluster": self.model.name, "observer": self.observer.center, "suspected": self.kind}

    @property
    def structural(self) -> tuple[Label, ...]:
        """Agents both suspected and on the boundary (each makes (iii) fail at every lam)."""
        b = set(self.model.boundary)
        return tuple(a for a in self.suspected if a in b)

    @property
    def C(self) -> np.ndarray:
        return self.model.C(self.observer.positions, self.observer.velocities)

    @property
    def B(self) -> np.ndarray:
        return self.model.B(self.suspected)


def local_cases(system: System, mode: str = NORMAL_MODE, cluster: str | None = None) -> list[LocalCase]:
    """All (cluster, observer, suspected) cases of ``system`` in ``mode``.

    Parameters
    ----------
    system : System
    mode : str
        Mode of the cluster models.
    cluster : str, optional
        Restrict to one cluster.
    """
    attacked = set(system.attacked)
    out = []
    for c in system.clusters:
        if cluster is not None and c.name != cluster:
            continue
        cm = system.cluster_model(c.name, mode)
        for obs in system.observers(c.name):
            if system.spec.attack is not None:
                out.append(LocalCase(cm, obs, "attack", tuple(a for a in cm.nodes if a in attacked), mode))
            out.append(LocalCase(cm, obs, "all", tuple(cm.nodes), mode))
    return out


def cluster_summary(system: System, name: str, mode: str = NORMAL_MODE) -> dict[str, Any]:
    """Decomposition facts of one cluster: agents, boundary, cut edges, their count and rank(E^i).

    Parameters
    ----------
    system : System
    name : str
        Cluster name.
    mode : str
        Mode of the cluster model.
    """
    cm = system.cluster_model(name, mode)
    return {
        "nodes": list(cm.nodes),
        "boundary": list(cm.boundary),
        "cut_edges": [[u, v, w] for u, v, w in cm.cut_edges],
        "inter_cluster_edges": len(cm.cut_edges),
        "rank_E": int(cm.E.shape[1]),
    }


def pencil_matrices(case: LocalCase) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(A^i, G, C_loc) with G = [B^i, -E^i]: the local pencil of eq. ``pencil_uio``,
    [[lam I - A^i, -B^i, E^i], [C_loc, 0, 0]], is the Rosenbrock pencil of (A^i, G, C_loc, 0).

    A^i is dense, built on this call (:attr:`ClusterModel.A <glocal_verify.model.ClusterModel.A>`);
    callers that need only G and C_loc use :func:`input_output_matrices`."""
    G, C = input_output_matrices(case)
    return case.model.A, G, C


def input_output_matrices(case: LocalCase) -> tuple[np.ndarray, np.ndarray]:
    """(G, C_loc) of :func:`pencil_matrices`, without forming the dense A^i (a 3333-agent
    cluster's is 6666 x 6666, 355 MB)."""
    return np.hstack([case.B, -case.model.E]), case.C


def full_pencil(case: LocalCase, lam: complex) -> np.ndarray:
    """The matrix [[lam I - A^i, -B^i, E^i], [C_loc, 0, 0]] of eq. ``pencil_uio`` at ``lam``.

    Parameters
    ----------
    case : LocalCase
    lam : complex
    """
    A, G, C = pencil_matrices(case)
    n, m = A.shape[0], G.shape[1]
    P = np.zeros((n + C.shape[0], n + m), dtype=complex)
    P[:n, :n] = lam * np.eye(n) - A
    P[:n, n:] = -G
    P[n:, :n] = C
    return P


def full_pencil_sparse(case: LocalCase, lam: complex) -> scipy.sparse.csr_matrix:
    """:func:`full_pencil` as a sparse matrix (O(nonzeros of A^i) memory and products).

    Parameters
    ----------
    case : LocalCase
    lam : complex
    """
    A = case.model.A_sparse
    G, C = input_output_matrices(case)
    n, m, p = A.shape[0], G.shape[1], C.shape[0]
    top = scipy.sparse.hstack([lam * scipy.sparse.identity(n, dtype=complex, format="csr") - A, scipy.sparse.csr_matrix(-G)])
    bottom = scipy.sparse.hstack([scipy.sparse.csr_matrix(C), scipy.sparse.csr_matrix((p, m))])
    return scipy.sparse.vstack([top, bottom], format="csr").astype(complex)


def _exact_A(system: System, case: LocalCase) -> list[list[Fraction]]:
    return exact_A_float(system, case)[0]


def exact_A_float(system: System, case: LocalCase) -> tuple[list[list[Fraction]], np.ndarray, np.ndarray]:
    """A^i = [[0, I], [-alpha L_i, -gamma I]] exactly, as floats, and its exact support.

    Built from the nonzeros of the cluster Laplacian: O(n^2) list slots but only O(nnz)
    rational products and conversions (a 333-agent cluster: 0.5 M fewer multiplications).

    Kept on ``system.analysis`` per cluster and mode: the returned lists and arrays are shared
    by every caller and must not be modified.

    Parameters
    ----------
    system : System
    case : LocalCase
    """
    return _EXACT_A_KIND.get(system, (case.model.name, case.mode), lambda: _exact_A_float(system, case))  # type: ignore[no-any-return]


def _exact_A_float(system: System, case: LocalCase) -> tuple[list[list[Fraction]], np.ndarray, np.ndarray]:
    L = system.cluster_laplacian_exact(case.model.name, case.mode)
    n = len(L)
    zero, one = Fraction(0), Fraction(1)
    A = [[zero] * (2 * n) for _ in range(2 * n)]
    Af = np.zeros((2 * n, 2 * n))
    support = np.zeros((2 * n, 2 * n), dtype=bool)
    a, g = Fraction(system.alpha_q), Fraction(system.gamma_q)
    for i in range(n):
        A[i][n + i] = one
        A[n + i][n + i] = -g
        cols = [j for j, x in enumerate(L[i]) if x]
        for j in cols:
            A[n + i][j] = -a * L[i][j]
        for j in (*cols, n + i):
            Af[n + i, j] = float(A[n + i][j])
        Af[i, n + i] = 1.0
        support[n + i, cols] = True
    support[np.arange(n), np.arange(n, 2 * n)] = True
    if g:
        support[np.arange(n, 2 * n), np.arange(n, 2 * n)] = True
    Af.setflags(write=False)
    support.setflags(write=False)
    return A, Af, support


def exact_int(M: np.ndarray) -> list[list[Fraction]]:
    """An integer-valued float matrix (0/1 selections and incidences) as exact rationals."""
    return [[Fraction(round(float(x))) for x in row] for row in M]


def pencil_matrices_exact(system: System, case: LocalCase) -> tuple[list[list[Fraction]], list[list[Fraction]], list[list[Fraction]]]:
    """(A^i, G, C_loc) with rational entries (weights and gains exactly as the spec gives them).

    Parameters
    ----------
    system : System
    case : LocalCase
    """
    A = _exact_A(system, case)
    G, C = input_output_matrices(case)
    return A, exact_int(G), exact_int(C)


# --------------------------------------------------------------------------------------------
# certificates of the numeric verdict of (iii)


def _exact_pencil_at(system: System, case: LocalCase, lam: Fraction | None) -> tuple[list[list[Fraction]], np.ndarray]:
    """The full pencil of eq. ``pencil_uio`` at a rational lam as exact rows, and its exact
    support (lam None: the generic pattern, the diagonal of lam I - A^i counted as nonzero)."""
    A, G, C = pencil_matrices_exact(system, case)
    n, m = len(A), (len(G[0]) if G else 0)
    lq = Fraction(0) if lam is None else lam
    rows = [[(lq if i == j else Fraction(0)) - A[i][j] for j in range(n)] + [-G[i][k] for k in range(m)] for i in range(n)]
    rows += [[Fraction(c) for c in C[r]] + [Fraction(0)] * m for r in range(len(C))]
    pat = np.array([[x != 0 for x in row] for row in rows], dtype=bool).reshape(len(rows), n + m)
    if lam is None:
        pat[np.arange(n), np.arange(n)] = True
    return rows, pat


def _exact_pattern_at(system: System, case: LocalCase, lam: Fraction | None) -> np.ndarray:
    """The exact support of the pencil of eq. ``pencil_uio`` at a rational lam, without forming
    its rational entries (:func:`_exact_pencil_at` gives the same pattern with the rows).

    Off the diagonal of lam I - A^i the support is that of A^i (from the nonzeros of the exact
    cluster Laplacian, :func:`exact_A_float`); on it, lam - A^i_jj is compared exactly (lam
    None: the generic pattern, every diagonal entry counted as nonzero); G and C_loc hold
    integers (their rounded values, as :func:`pencil_matrices_exact` reads them).
    """
    A, _, support = exact_A_float(system, case)
    G, C = input_output_matrices(case)
    n = len(A)
    top = support.copy()
    diag = np.arange(n)
    if lam is None:
        top[diag, diag] = True
    else:
        top[diag, diag] = [lam != A[i][i] for i in range(n)]
    return np.vstack([np.hstack([top, np.round(G) != 0]), np.hstack([np.round(C) != 0, np.zeros((C.shape[0], G.shape[1]), dtype=bool)])])


def _witness_vector(case: LocalCase, d: dict[str, Any]) -> np.ndarray:
    """The full-pencil vector [x; u_B; u_E] of a direction witness (labels -> values)."""
    nodes = case.model.nodes
    parts = [
        [d.get("positions", {}).get(a, 0.0) for a in nodes],
        [d.get("velocities", {}).get(a, 0.0) for a in nodes],
        [d.get("attack_input", {}).get(a, 0.0) for a in case.suspected],
        [d.get("coupling_input", {}).get(a, 0.0) for a in case.model.boundary],
    ]
    return np.array([complex(x) for p in parts for x in p], dtype=complex)


_ONE = Fraction(1)


class _LazyRows:
    """Rows of an exact matrix whose entries ``entry(i, j)`` are computed when read (``M[i][j]``)."""

    def __init__(self, rows: int, cols: int, entry: Any) -> None:
        self.rows, self.cols, self.entry = rows, cols, entry

    def __len__(self) -> int:
        return self.rows

    def __getitem__(self, i: int) -> "_LazyRow":
        if not 0 <= i < self.rows:
            raise IndexError(i)
        return _LazyRow(self, i)

    def block(self, rows: Sequence[int], cols: Sequence[int]) -> list[list[Fraction]]:
        """The entries of M[rows, cols], each computed once (what ``[[M[i][j] for j in cols] for i in rows]`` reads)."""
        f = self.entry
        return [[f(i, j) for j in cols] for i in rows]


class _LazyRow:
    def __init__(self, rows: _LazyRows, i: int) -> None:
        self.rows, self.i = rows, i

    def __len__(self) -> int:
        return self.rows.cols

    def __getitem__(self, j: int) -> Fraction:
        if not 0 <= j < self.rows.cols:
            raise IndexError(j)
        return self.rows.entry(self.i, j)  # type: ignore[no-any-return]


def _support_pencil(system: System, case: LocalCase) -> tuple[_LazyRows, _LazyRows, np.ndarray]:
    """The exact pencil P(lam) = P0 + lam P1 of the case as lazy rows, and the support of P0 or P1.

    The rows are evaluated on access: the zero proofs below read only the rows and columns of a
    candidate's support (G and C_loc hold integers, read as pencil_matrices_exact reads them).
    """
    A, _, support = exact_A_float(system, case)
    G, C = input_output_matrices(case)
    n, m = len(A), G.shape[1]
    nonzero = _exact_pattern_at(system, case, None)  # the support of P0 or P1 (lam I counted on the diagonal)

    def p0(i: int, j: int) -> Fraction:
        if i < n:
            if j < n:
                return -A[i][j] if support[i, j] else RATIONAL_ZERO
            return -Fraction(round(float(G[i, j - n])))
        return Fraction(round(float(C[i - n, j]))) if j < n else RATIONAL_ZERO

    P0 = _LazyRows(n + C.shape[0], n + m, p0)
    P1 = _LazyRows(n + C.shape[0], n + m, lambda i, j: _ONE if i == j and i < n else RATIONAL_ZERO)
    return P0, P1, nonzero


def _zero_candidates(witness: Mapping[str, Any]) -> list[dict[str, Any]]:
    """The reported zeros (at most 12) and the direction witness: the candidates a zero proof tries."""
    cands = list(witness.get("zeros", []))[:12]
    if isinstance(witness.get("direction"), dict) and "lambda" in witness["direction"]:
        cands.append(witness["direction"])
    return cands


def _square_zero_mod_p(system: System, case: LocalCase, witness: Mapping[str, Any], pencil: tuple[_LazyRows, _LazyRows, np.ndarray] | None = None) -> str | None:
    """A zero of the exact pencil proven by a square restriction whose determinant is not constant, or None.

    A candidate (lam, v) proposes the support S of v (entries above 1e-13 of the largest) and
    the rows R with an exact nonzero of P0 or P1 in the columns S; every other row vanishes on
    the vectors supported on S, exactly. When ``|R| = |S|``, ``d(lam) = det P[R, S](lam)`` is a
    polynomial over Q. Two different values of d modulo a prime p that divides no
    denominator of the block (at two points drawn modulo p) prove a coefficient of positive
    degree nonzero modulo p, so nonzero over Q: d has a complex root lam*, where P[R, S](lam*)
    has a kernel vector w, and w extended by zeros is a kernel vector of P(lam*): the pencil
    loses column rank. The float candidate only proposes S; the location of lam* is not
    certified. Cost: two |S| x |S| determinants modulo p (python-flint ``nmod_mat``), against
    the Krawczyk test's |S| x |S| ball products at 128 bits.
    """
    import flint

    from glocal_verify.numerics.minors import prime_for

    P0, P1, nonzero = pencil if pencil is not None else _support_pencil(system, case)
    rng = np.random.default_rng(len(nonzero))
    for d in _zero_candidates(witness):
        v = _witness_vector(case, d)
        if v.size != nonzero.shape[1] or not np.all(np.isfinite(v)) or not np.any(v):
            continue
        top = float(np.max(np.abs(v)))
        S = np.flatnonzero(np.abs(v) > 1e-13 * top).tolist()
        R = np.flatnonzero(np.any(nonzero[:, S], axis=1)).tolist()
        if len(R) != len(S):
            continue
        # only the exact support's entries of the block are read (a few per row), not |S|^2
        rr, cc = np.nonzero(nonzero[np.ix_(R, S)])
        ent = [(int(a), int(b), P0.entry(R[a], S[b]), P1.entry(R[a], S[b])) for a, b in zip(rr, cc)]
        values = {x for _, _, e0, e1 in ent for x in (e0, e1) if x is not RATIONAL_ZERO and x != 0}
        q = prime_for(sorted(values) or [Fraction(1)])

        def red(x: Fraction) -> int:
            return 0 if x is RATIONAL_ZERO or x == 0 else x.numerator % q * pow(x.denominator % q, -1, q) % q

        red_ent = [(a * len(S) + b, red(e0), red(e1)) for a, b, e0, e1 in ent]
        k = len(S)
        x1, x2 = (int(t) for t in rng.integers(1, q, size=2))
        dets = []
        for t in (x1, x2):
            flat = [0] * (k * k)
            for pos, a0, a1 in red_ent:
                flat[pos] = (a0 + t * a1) % q
            dets.append(int(flint.nmod_mat(k, k, flat, q).det()))
        d1, d2 = dets
        if d1 != d2:
            return (
                f"det P[R, S](lam) over the candidate's support ({k} rows and columns, every other row zero there) takes two values "
                f"modulo the prime {q}: a nonconstant polynomial, so P loses column rank at one of its roots (near lam ~ {complex(d['lambda']):.6g}; location not certified)"
            )
    return None


def _krawczyk_zero(system: System, case: LocalCase, witness: dict[str, Any], pencil: tuple[_LazyRows, _LazyRows, np.ndarray] | None = None) -> Any:
    """The first reported zero (or normal-rank direction) that the Krawczyk test proves, or None."""
    from glocal_verify.analysis.local.cluster_pencil import krawczyk_kernel

    P0, P1, nonzero = pencil if pencil is not None else _support_pencil(system, case)
    for d in _zero_candidates(witness):
        enc = krawczyk_kernel(P0, P1, complex(d["lambda"]), _witness_vector(case, d), nonzero=nonzero)
        if enc is not None:
            return enc
    return None


def _rational_s_zero(system: System, case: LocalCase, witness: Mapping[str, Any]) -> str | None:
    """An exact rank loss of the reduced pencil at a rational s near a reported zero, or None.

    With s = lam^2 + gamma lam, P(lam) loses column rank at a lam != 0 iff
    ``T(s) = [(s I + alpha L)[U \\ I, U]; alpha L[M \\ I, U]]`` does (U the unmeasured agents, I
    the input agents, M the measured ones; :mod:`glocal_verify.numerics.minors`). A reported
    zero whose s is real is rounded to the nearest rational of small denominator and the rank
    of T at it is computed over Q (python-flint): a rank below |U| is a proof, however the
    candidate was found, at both roots lam of ``lam^2 + gamma lam = s`` (neither is 0 unless
    s = 0, whose other root -gamma is not). Clusters above ``exact_rank_max_columns`` columns
    are skipped (rational elimination).
    """
    import flint

    cm = case.model
    measured, inputs, U = measured_inputs_unknown(case)
    if not U or len(U) > config.get("exact_rank_max_columns"):
        return None
    rows = [i for i in U if i not in inputs] + sorted(measured - inputs)
    L = system.cluster_laplacian_exact(cm.name, case.mode)
    alpha = Fraction(system.alpha_q)
    tried: set[Fraction] = set()
    for w in list(witness.get("zeros", []))[:12]:
        sv = complex(w.get("s", math.nan))
        if not math.isfinite(sv.real) or abs(sv.imag) > 1e-9 * max(1.0, abs(sv.real)):
            continue
        sq = Fraction(sv.real).limit_denominator(10**6)
        if sq in tried:
            continue
        tried.add(sq)
        T = flint.fmpq_mat(len(rows), len(U))
        for r, i in enumerate(rows):
            Li = L[i]
            for c, j in enumerate(U):
                v = alpha * Li[j] + (sq if (i == j and i not in measured) else 0)
                if v:
                    T[r, c] = flint.fmpq(v.numerator, v.denominator)
        rank = int(T.rank())
        if rank < len(U):
            return (
                f"T(s) = [(s I + alpha L)[U \\ I, U]; alpha L[M \\ I, U]] has rank {rank} < {len(U)} over Q at s = {sq}: "
                f"P(lam) loses column rank at both roots of lam^2 + gamma lam = {sq}"
            )
    return None


def minor_certificate(system: System, case: LocalCase, cache: dict[Any, Any] | None = None) -> str | None:
    """Prove Proposition III.2 (iii) for every lam by exact maximal minors, or return None.

    lam != 0: the pencil has full column rank iff T(s) = [K(s)[U \\ I', :]; alpha L[M', U]]
    does for every s (:mod:`glocal_verify.numerics.minors`, with L = L[P_i, P_i], U the
    cluster agents the observer does not measure, I the suspected and boundary agents);
    proved by maximal minors without a common root modulo a prime. lam = 0: P(0) has full
    column rank iff alpha L[P_i \\ I, P_i \\ M_x] does, proved by its rank modulo a prime.
    Both proofs are exact (reduction modulo p never raises a rank); None proves nothing.

    Parameters
    ----------
    system : System
    case : LocalCase
    cache : dict, optional
        Per-process store of the polynomials (see :func:`~glocal_verify.numerics.minors.full_rank_certificate`).

    Returns
    -------
    str or None
        The certificate, one line.
    """
    from glocal_verify.numerics.minors import (
        full_rank_certificate,
        grounded_tables,
        residues_mod_p,
        submatrix_full_rank_mod_p,
    )

    if case.structural:
        return None
    cm, obs = case.model, case.observer
    nodes = cm.nodes
    idx = {a: k for k, a in enumerate(nodes)}
    measured = sorted({idx[a] for a in obs.positions} | {idx[a] for a in obs.velocities})
    alpha = Fraction(system.alpha_q)

    def build() -> Any:
        return grounded_tables(len(nodes), system.cluster_laplacian_entries(cm.name, case.mode), alpha, measured)

    inputs = [idx[a] for a in case.suspected] + [idx[a] for a in cm.boundary]
    mset = set(measured)
    unmeasured_inputs = sum(1 for i in set(inputs) if i not in mset)
    # the maximal minors apply to at most minor_max_inputs unmeasured inputs (and as many other
    # measured rows): their tables (a characteristic polynomial and a Krylov sequence) are
    # built only then
    minors_apply = unmeasured_inputs <= config.get("minor_max_inputs") and len(mset - set(inputs)) >= unmeasured_inputs

    def prove() -> str | None:
        tables = _GROUNDED_TABLES_KIND.get(system, (cm.name, case.mode, tuple(measured)), build) if minors_apply else None
        kr = observability_certificate(system, case)
        cert = None
        if kr is not None:
            text = kr
        elif tables is not None and (cert := full_rank_certificate(tables, inputs, cache if cache is not None else {})) is not None:
            text = cert.text()
        elif (zc := zero_count_certificate(system, case)) is not None:
            text = zc
        else:
            return None
        mx = {idx[a] for a in obs.positions}
        # alpha L[P_i \ I, P_i \ M_x] modulo a prime which divides no denominator of alpha L
        # (the tables', when they were built): the residues of alpha L are kept per cluster and mode
        p = tables.prime if tables is not None else _prime_of(system, case, alpha)
        res = _ALPHA_LAPLACIAN_MOD_KIND.get(system, (cm.name, case.mode, p), lambda: residues_mod_p(_alpha_rows(system, case, alpha), p))
        inset = set(inputs)
        if not submatrix_full_rank_mod_p(res, [i for i in range(len(nodes)) if i not in inset], [j for j in range(len(nodes)) if j not in mx], p):
            return None
        return text + f"; lam = 0: alpha L[P_i \\ I, P_i \\ M_x] has full column rank modulo the prime {p}"

    # the outcome (a proof or None) depends only on the exact tables and the input rows: the
    # audit's screen and the certification of a numeric verdict ask for the same one
    return _LOCAL_MINOR_CERTIFICATE_KIND.get(system, (cm.name, case.mode, tuple(measured), tuple(obs.positions), tuple(sorted(inputs))), prove)


def _prime_of(system: System, case: LocalCase, alpha: Fraction) -> int:
    """A prime below 2^30 that divides no denominator of alpha L[P_i, P_i]."""
    from glocal_verify.numerics.minors import prime_for

    return prime_for([alpha, *system.cluster_laplacian_entries(case.model.name, case.mode).values()])


def _alpha_rows(system: System, case: LocalCase, alpha: Fraction) -> list[list[Fraction]]:
    """alpha L[P_i, P_i] as rational rows, from the nonzero entries only (the zeros share one object)."""
    n = len(case.model.nodes)
    rows = [[RATIONAL_ZERO] * n for _ in range(n)]
    for (i, j), v in system.cluster_laplacian_entries(case.model.name, case.mode).items():
        rows[i][j] = alpha * v
    return rows


def twin_failure(system: System, case: LocalCase) -> str | None:
    """An exact proof that Proposition III.2 (iii) fails: a twin mode the observer cannot see.

    If agents a, r of the cluster are twins of L[P_i, P_i] (equal rows off {a, r}, equal
    diagonal; :func:`glocal_verify.numerics.symmetry.twin_modes`) and the observer measures
    neither, z = e_a - e_r satisfies L[P_i, P_i] z = mu z exactly, so [z; lam z; 0] is a kernel
    vector of the pencil of eq. ``pencil_uio`` at both roots of lam^2 + gamma lam + alpha mu:
    the pencil loses column rank there, whatever the suspected set.

    Parameters
    ----------
    system : System
    case : LocalCase

    Returns
    -------
    str or None
        The proof, one line; None proves nothing.
    """
    from glocal_verify.numerics.symmetry import twin_modes

    cm, obs = case.model, case.observer
    nodes = cm.nodes
    idx = {a: k for k, a in enumerate(nodes)}
    measured = sorted({idx[a] for a in obs.positions} | {idx[a] for a in obs.velocities})

    def compute() -> Any:
        return twin_modes(len(nodes), system.cluster_laplacian_entries(cm.name, case.mode), measured)

    modes = _TWIN_MODES_KIND.get(system, (cm.name, case.mode, tuple(measured)), compute)
    for mu, pairs in modes:
        a, r = pairs[0]
        return (
            f"{nodes[a]} and {nodes[r]} are twins of L[P_i, P_i] unmeasured by the observer: [z; lam z; 0] with "
            f"z = e_{nodes[a]} - e_{nodes[r]} is an exact kernel vector at the roots of lam^2 + gamma lam + alpha*{mu}"
        )
    return None


def certificate_verdict(status: Status, margin: float | None, witness: Mapping[str, Any], *, exact: bool = False) -> Verdict:
    """A local verdict whose numeric certificate sets its error bound and note.

    The local checks record their floating-point certificate in ``witness["certificate"]``
    (``error_bound``, ``note``, ``by``); exact verdicts have none.

    Parameters
    ----------
    status : Status
    margin : float or None
    witness : mapping
    exact : bool
        Decided in exact arithmetic.
    """
    cert = witness.get("certificate")
    if not isinstance(cert, Mapping):
        return Verdict(status, margin=margin, witness=witness, exact=exact)
    eb = cert.get("error_bound")
    return Verdict(status, margin=margin, error_bound=None if eb is None else float(eb), witness=witness, exact=exact, note=str(cert.get("note", "")))


@dataclass(frozen=True, eq=False)
class PencilScreen:
    """The exact screens the rule of ``local.pencil`` may try before its pencil analysis (an audit's options).

    They choose how a verdict is proved, never how a status follows from a proof
    (:func:`screened_pencil_verdict`).

    Attributes
    ----------
    member : (label, Verdict) or None
        A suspected agent and the rule's verdict of its single set (the caller's earlier call):
        when that verdict fails, so does every set containing the agent.
    minors : bool
        Try the exact maximal minors (:func:`minor_certificate`).
    cache : dict or None
        The per-run store of the minors' polynomials.
    locate_zeros : bool
        Prove a failure by an enclosed zero (the Krawczyk test) before the cheaper proof that
        some zero exists (:func:`_square_zero_mod_p`); False: the existence proof first (an
        audit reads the status only; both prove the same status).
    """

    member: tuple[Label, Verdict] | None = None
    minors: bool = True
    cache: dict[Any, Any] | None = None
    locate_zeros: bool = True


def screened_pencil_verdict(system: System, case: LocalCase, screen: PencilScreen, method: str, *, exact: bool = False) -> Verdict | None:
    """The verdict of Proposition III.2 (iii) an exact screen proves, or None (then the pencil analysis decides).

    In this order: a member a of the suspected set S whose pencil loses column rank at some
    lam makes S's lose it too (its kernel vector padded with zero inputs on S minus {a}); a
    twin mode the observer cannot see is an exact kernel vector (:func:`twin_failure`); exact
    maximal minors prove full column rank for every lam (:func:`minor_certificate`). Called by
    the rule (``pencil_verdict(..., screen=)``), which states the verdict.

    Parameters
    ----------
    system : System
    case : LocalCase
    screen : PencilScreen
    method : str
        The method the witness records.
    exact : bool
        The verdict is one of the exact path.
    """
    a, single = screen.member if screen.member is not None else (None, None)
    if single is not None and single.status is Status.FAILS and a in case.suspected and len(case.suspected) > 1:
        proof = single.witness.get("certificate", {}).get("by") if isinstance(single.witness.get("certificate"), Mapping) else None
        by = f"the suspected agent {a} alone fails ({proof or 'its verdict'}): its kernel vector, padded with zero inputs, is one of this suspected set"
        status = Status.FAILS
    elif (by := twin_failure(system, case)) is not None:  # type: ignore[assignment]
        status = Status.FAILS
    elif screen.minors and (by := minor_certificate(system, case, screen.cache)) is not None:  # type: ignore[assignment]
        status = Status.HOLDS
    else:
        return None
    return Verdict(status, margin=0.0 if status is Status.FAILS else math.nan, witness={"method": method, "certificate": {"by": by, "error_bound": None}}, exact=exact)


def certify_pencil_verdict(system: System, case: LocalCase, numeric: Verdict, *, locate_zeros: bool = True) -> Verdict:
    """Certify a numeric verdict of Proposition III.2 (iii) for the exact pencil, or make it undecided.

    (Zero forcing first, then the exact maximal-minor certificate of :func:`minor_certificate`,
    which proves ``holds`` whatever the numeric status was.)

    Returns the verdict with ``witness["certificate"]`` (``by``, ``error_bound``, ``note``,
    which also set the verdict's error bound and note, :func:`certificate_verdict`) and the
    numeric margin; its status is the numeric one when proved, ``holds`` when zero forcing
    proves it, else ``undecided``.

    * ``holds`` (full column rank for every lam) is proved combinatorially by zero forcing
      (:func:`~glocal_verify.analysis.local.cluster_pencil.zero_forcing_closure` on the exact support
      of L[P_i, P_i]; suspected and boundary rows never force);
      when zero forcing covers lam != 0 only, lam = 0 is certified by a Weyl bound on the
      exact P(0): sigma_min(fl P(0)) > ||fl P(0) - P(0)||_2 + SVD backward error
      (:func:`~glocal_verify.numerics.pencil_exact.rank_bounds`). A reduced or dense analysis
      that finds no zero proves nothing about the exact pencil (a zero may sit within the
      rounding level): undecided.
    * ``fails`` is proved by the structural rank of the exact support: below the column count
      for the generic pattern (normal-rank deficiency, every lam) or at a rational zero lam in
      {0, -gamma} whose exact pattern loses structural rank, by the Krawczyk test in ball
      arithmetic on a reported zero (:func:`~glocal_verify.analysis.local.cluster_pencil.krawczyk_kernel`:
      an exact kernel vector inside certified enclosures), or by a square restriction of the
      pencil to a reported zero's support whose determinant is not constant modulo a prime
      (:func:`_square_zero_mod_p`: a root exists, its location not certified); with
      ``locate_zeros=False`` (an audit's :class:`PencilScreen`) the last one is tried first. A zero verified only by a small
      backward error is a robustness statement, not a proof of rank loss: undecided.

    Parameters
    ----------
    system : System
    case : LocalCase
    numeric : Verdict
        The numeric verdict; its witness (directions with ``lambda``, ``positions``,
        ``velocities``, ``attack_input``, ``coupling_input``) is extended with the certificate.
    """
    from glocal_verify.analysis.local.cluster_pencil import zero_forcing_closure
    from glocal_verify.numerics.exact_subspace import rational_kernel_vector
    from glocal_verify.numerics.pencil_exact import (
        rank_bounds,
        rounding_error,
        structural_rank,
    )

    status, margin, witness = numeric.status, numeric.margin, dict(numeric.witness)

    def verdict(status_now: Status) -> Verdict:
        return certificate_verdict(status_now, margin, witness)

    cm = case.model
    idx = {a: k for k, a in enumerate(cm.nodes)}
    n = len(cm.nodes)
    inputs = {idx[a] for a in case.suspected} | {idx[a] for a in cm.boundary}
    mx = {idx[a] for a in case.observer.positions}
    measured = mx | {idx[a] for a in case.observer.velocities}
    nbrs: list[list[int]] = [[] for _ in range(n)]
    for i, j in sorted(system.cluster_laplacian_entries(cm.name, case.mode)):  # the exact support, off the diagonal
        if i != j:
            nbrs[i].append(j)
    forced = zero_forcing_closure(nbrs, measured, inputs)
    ok = len(forced) == n
    ok0 = ok if mx == measured else len(zero_forcing_closure(nbrs, mx, inputs)) == n
    ncols = 2 * n + len(case.suspected) + len(cm.boundary)
    cert: dict[str, Any] = {"error_bound": None}

    def proved(status_now: Status, by: str, how: str) -> Verdict:
        cert["by"] = by
        witness["certificate"] = cert
        if status is not status_now:
            cert["note"] = f"the numeric analysis said {status.value}; {how}"
        return verdict(status_now)

    if ok and ok0:
        return proved(Status.HOLDS, "zero forcing from the measured agents on the exact support (every lam)", "zero forcing proves full column rank for every lam")

    def prove_fails() -> str | None:
        """A proof of rank loss of the exact pencil (twin mode, structural rank, an exact or
        enclosed kernel vector), or None."""
        tw = twin_failure(system, case)
        if tw is not None:
            return tw
        if status is not Status.FAILS:
            return None
        if structural_rank(_exact_pattern_at(system, case, None)) < ncols:
            return "structural rank of the exact support below the column count (normal-rank deficiency)"
        for lam in (Fraction(0), -system.gamma_q):
            if structural_rank(_exact_pattern_at(system, case, lam)) < ncols:
                return f"structural rank of the exact support of P({lam}) below the column count"
        d = witness.get("direction")
        if isinstance(d, dict) and complex(d.get("lambda", 1j)).imag == 0:
            lq = Fraction(complex(d["lambda"]).real)
            rows, _ = _exact_pencil_at(system, case, lq)
            if rational_kernel_vector(rows, _witness_vector(case, d)) is not None:
                return f"the direction at lam = {lq} rationalises to an exact kernel vector (checked over Q)"
        rz = _rational_s_zero(system, case, witness)
        if rz is not None:
            return rz
        # an enclosed zero (Krawczyk) says where; a nonconstant determinant only that one exists
        pencil = _support_pencil(system, case)  # the exact rows both proofs read
        for located in (True, False) if locate_zeros else (False, True):
            if not located and (sq := _square_zero_mod_p(system, case, witness, pencil)) is not None:
                return sq
            if located and (enc := _krawczyk_zero(system, case, witness, pencil)) is not None:
                cert["lambda_enclosure"] = str(enc.lam)
                return f"Krawczyk test: an exact kernel vector of P(lam) at lam in {enc.lam} (ball arithmetic)"
        return None

    # a proof of holds and a proof of fails exclude each other, so the order only decides the
    # cost: the proof matching the numeric verdict is tried first (the exact maximal minors
    # are the dearest part when the numeric verdict is fails)
    for kind in (Status.FAILS, Status.HOLDS) if status is Status.FAILS else (Status.HOLDS, Status.FAILS):
        by = minor_certificate(system, case) if kind is Status.HOLDS else prove_fails()
        if by is not None:
            how = "exact minors prove full column rank for every lam" if kind is Status.HOLDS else "an exact twin mode proves rank loss"
            return proved(kind, by, how)
    if status is Status.HOLDS:
        if ok:
            rows, pat = _exact_pencil_at(system, case, Fraction(0))
            P0 = np.array([[float(x) for x in r] for r in rows])
            rb = rank_bounds(P0, input_error=rounding_error(P0, rows), pattern=pat)
            cert["error_bound"] = rb.error_bound
            if rb.lower == ncols:
                cert["by"] = "zero forcing (lam != 0) and a Weyl bound at lam = 0"
                witness["certificate"] = cert
                return verdict(Status.HOLDS)
            cert["note"] = f"lam = 0: sigma_min(P(0)) = {rb.singular_values[-1]:.3g} is not above the certified error bound {rb.error_bound:.3g}"
        else:
            cert["note"] = (
                "no zero was found, but floating point cannot prove full column rank for every lam: zero forcing leaves "
                f"{n - len(forced)} agent(s) unforced"
            )
        witness["certificate"] = cert
        return verdict(Status.UNDECIDED)
    if status is Status.FAILS:
        zs = [w.get("lambda") for w in witness.get("zeros", []) if w.get("verified")]
        cert["note"] = (
            f"the zero(s) {zs[:3]} verify only to a small backward error, which does not prove rank loss of the exact "
            "pencil (no structural certificate)" if zs else "the rank loss has no structural certificate"
        )
        witness["certificate"] = cert
        return verdict(Status.UNDECIDED)
    cert["note"] = str(witness.get("verification", "the numeric rank decisions fell inside the tolerance band"))
    witness["certificate"] = cert
    return verdict(status)
