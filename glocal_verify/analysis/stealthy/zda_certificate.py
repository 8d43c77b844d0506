"""Certificates of the numeric ZDA verdict: what rigorous bounds or the exact support prove.

:func:`zda_certificate` decides, from the exact rows of Q(s) = [[s I + alpha L_1, -S_F^T],
[S_out, 0]] (:func:`exact_q_rows`), whether a numeric verdict of :mod:`glocal_verify.analysis.stealthy.zda`
about stealthy ZDAs is a proof about the exact system: certified rank bounds
(:func:`u_direction_certificate`), exact rational kernel vectors
(:func:`~glocal_verify.numerics.exact_subspace.rational_kernel_vector`), zero forcing and the Krawczyk test.
"""

from __future__ import annotations

from dataclasses import dataclass
from fractions import Fraction
from typing import Iterable, Sequence

import numpy as np

from glocal_verify.analysis.stealthy.zda import _actuators
from glocal_verify.model import System
from glocal_verify.numerics.exact_subspace import rational_kernel_vector, rationalised
from glocal_verify.numerics.pencil_exact import (
    rank_bounds,
    rounding_error,
    structural_rank,
)
from glocal_verify.results import Status
from glocal_verify.spec.types import NORMAL_MODE, Label

__all__ = [
    "ZdaCertificate",
    "exact_q_pattern",
    "exact_q_rows",
    "sparse_kernel_certificate",
    "u_direction_certificate",
    "zda_certificate",
]


# ------------------------------------------------------------------------------------------
# certificates of the numeric verdict (rigorous; see :func:`zda_certificate`)


@dataclass(frozen=True, slots=True)
class ZdaCertificate:
    """What floating point (with rigorous bounds) or the exact support proves about stealthy ZDAs.

    Attributes
    ----------
    status : Status or None
        ``HOLDS`` (a stealthy ZDA certainly exists), ``FAILS`` (certainly none), or None (no
        certificate: the numeric verdict must be undecided).
    by : str
        The certificate used.
    error_bound : float or None
        The floating-point error bound of the decided quantity (Weyl bounds), when one was used.
    note : str
        Which bound failed and how far, when ``status`` is None.
    lambda0 : complex or None
        For ``HOLDS`` at lambda0 = 0 (a persistent ZDA, from the graph or the rank bounds): 0.
    """

    status: Status | None
    by: str = ""
    error_bound: float | None = None
    note: str = ""
    #: the exponent at which a ``HOLDS`` certificate proves a stealthy direction, when it proves one at a known exponent
    lambda0: complex | None = None


def exact_q_pattern(system: System, F: Sequence[int], rows_out: Sequence[int]) -> np.ndarray:
    """The generic support of :func:`exact_q_rows` (``s=None``) without forming its rows.

    The same boolean matrix (the diagonal of s I + alpha L counted as nonzero), from the sparse
    exact entries of L_1 only: no N x (N + m) list of rows (0.8 GB of slots at N = 10,000)
    for a structural-rank test that reads the pattern alone.
    """
    from glocal_verify.analysis.laplacian.twins import laplacian_entries

    N, m = system.n, len(F)
    a = Fraction(system.alpha_q)
    pat = np.zeros((N + len(rows_out), N + m), dtype=bool)
    if a != 0:  # alpha L_ij is zero exactly when L_ij is
        ij = np.array([k for k, v in laplacian_entries(system, NORMAL_MODE).items() if v != 0], dtype=np.int64).reshape(-1, 2)
        pat[ij[:, 0], ij[:, 1]] = True
    pat[np.arange(N), np.arange(N)] = True
    for k, f in enumerate(F):
        pat[f, N + k] = True  # -1 (an agent listed twice adds -1 in another column)
    for t, r in enumerate(rows_out):
        pat[N + t, r] = True
    return pat


def exact_q_rows(
    system: System, F: Sequence[int], rows_out: Sequence[int], s: Fraction | None, extra: Sequence[Sequence[Fraction]] = ()
) -> tuple[list[list[Fraction]], np.ndarray]:
    """[[s I + alpha L_1, -S_F^T], [S_out, 0], [extra, 0]] as exact rows and its exact support.

    ``s=None`` gives the generic pattern (the diagonal of s I + alpha L counted as nonzero,
    entries at s = 0). ``extra`` rows (N entries each, e.g. dL_q) are padded with zeros.

    Parameters
    ----------
    system : System
    F : sequence of int
        Attacked agents (indices).
    rows_out : sequence of int
        Measured agents (indices) whose rows S_out holds.
    s : Fraction or None
    extra : rows of Fraction
    """
    from glocal_verify.analysis.laplacian.twins import laplacian_entries

    N, m = system.n, len(F)
    a = Fraction(system.alpha_q)
    sq = Fraction(0) if s is None else Fraction(s)
    zero, one = Fraction(0), Fraction(1)
    n_rows = N + len(rows_out) + len(extra)
    # built from the sparse exact entries of L_1: O(N^2) list slots, O(E) rational operations
    rows = [[zero] * (N + m) for _ in range(N)]
    cand: list[list[int]] = [[i] for i in range(N)]
    for (i, j), v in laplacian_entries(system, NORMAL_MODE).items():
        rows[i][j] = a * v
        if j != i:
            cand[i].append(j)
    if sq:
        for i in range(N):
            rows[i][i] = rows[i][i] + sq
    for k, f in enumerate(F):
        rows[f][N + k] = rows[f][N + k] - one
        cand[f].append(N + k)
    pat = np.zeros((n_rows, N + m), dtype=bool)
    for i in range(N):
        nz = [j for j in cand[i] if rows[i][j] != 0]  # exact: a diagonal entry may cancel
        pat[i, nz] = True
    for t, r in enumerate(rows_out):
        row = [zero] * (N + m)
        row[r] = one
        rows.append(row)
        pat[N + t, r] = True
    for t, ex_row in enumerate(extra):
        row = [Fraction(x) for x in ex_row] + [zero] * m
        rows.append(row)
        pat[N + len(rows_out) + t, [j for j, x in enumerate(row) if x != 0]] = True
    if s is None:
        pat[np.arange(N), np.arange(N)] = True
    return rows, pat


def u_direction_certificate(rows: Sequence[Sequence[Fraction]], pattern: np.ndarray, N: int, m: int, xi_upper: int | None = None) -> tuple[bool | None, float]:
    """Is there a kernel vector (xi, u) of the exact matrix K = [K_xi, K_u] with u != 0?

    Such a vector exists iff rank K < rank K_xi + m. With certified bounds
    (:func:`~glocal_verify.numerics.pencil_exact.rank_bounds`: Weyl lower bounds from the SVD
    backward error plus the rounding of the rational data, structural upper bounds from the
    exact support, ``xi_upper`` an extra upper bound of rank K_xi from exactly known kernel
    vectors): True when upper(K) < lower(K_xi) + m, False when lower(K) >= upper(K_xi) + m,
    None otherwise. Returns the verdict and the error bound used.

    Parameters
    ----------
    rows : exact rows of K
    pattern : exact support of K
    N, m : int
        Columns of K_xi and of K_u.
    xi_upper : int, optional
    """
    K = np.zeros((len(rows), N + m))
    ii, jj = np.nonzero(pattern)
    K[ii, jj] = [float(rows[i][j]) for i, j in zip(ii.tolist(), jj.tolist())]
    err = rounding_error(K, rows, support=pattern)
    bk = rank_bounds(K, input_error=err, pattern=pattern)
    # K_xi is a column block of K: its rounding error is at most that of K
    bx = rank_bounds(K[:, :N], input_error=err, pattern=pattern[:, :N], upper=xi_upper)
    bound = max(bk.error_bound, bx.error_bound)
    if bk.upper < bx.lower + m:
        return True, bound
    if bk.lower >= bx.upper + m:
        return False, bound
    return None, bound


def sparse_kernel_certificate(
    system: System, actuators: Sequence[Label], lam: Fraction, xi: np.ndarray, u0: np.ndarray, max_denominator: int = 10**6
) -> bool:
    """Is the computed direction (xi, u0) at the rational exponent ``lam`` an exact stealthy ZDA?

    xi is scaled so that its largest entry is 1 and rounded to the nearest fractions with
    denominator <= ``max_denominator``; then, in exact arithmetic on the sparse entries of L_1,
    (s I + alpha L_1) xi must vanish off the attacked agents, S_out xi = 0 (S_out = S_{M_x}
    at lam = 0, S_M otherwise) and the input it needs on F, u0 = S_F (s I + alpha L_1) xi,
    must be nonzero. A True answer is a proof (no tolerance); a False one proves nothing.
    O(N + |E|) rational operations (u0 is recomputed exactly, the float one is not used).

    Parameters
    ----------
    system : System
    actuators : sequence of labels
        F.
    lam : Fraction
        The exponent lambda0 (real, rational).
    xi : ndarray
        Position part of the direction (length N).
    u0 : ndarray
        Its input part (only its being nonzero is checked, exactly).
    max_denominator : int
    """
    from glocal_verify.analysis.laplacian.twins import laplacian_entries

    q = rationalised(xi, max_denominator) if np.size(xi) == system.n else None
    if q is None:
        return False
    out = system.monitored_positions if lam == 0 else system.monitored
    if any(q[i] != 0 for i in system.idx(out)):
        return False
    s = lam * lam + Fraction(system.gamma_q) * lam
    a = Fraction(system.alpha_q)
    r = [s * x for x in q]
    for (i, j), w in laplacian_entries(system, NORMAL_MODE).items():
        if q[j]:
            r[i] += a * w * q[j]
    F = set(system.idx(actuators))
    if any(r[i] != 0 for i in range(system.n) if i not in F):
        return False
    return any(r[i] != 0 for i in F)


def zda_certificate(
    system: System,
    actuators: Iterable[Label] | None = None,
    candidate: tuple[complex, np.ndarray, np.ndarray] | None = None,
    zeros: Sequence[tuple[complex, np.ndarray, np.ndarray]] = (),
) -> ZdaCertificate:
    """Certify the existence or absence of a stealthy ZDA of (A_1, B, C, 0), or say why not.

    Reduction (module docstring): a stealthy direction at lambda != 0 is a kernel vector of
    Q_M(s) = [[s I + alpha L, -S_F^T], [S_M, 0]] with u0 != 0 (s = lambda^2 + gamma lambda
    covers every complex s), at lambda = 0 one of Q_{M_x}(0). Certificates:

    * exists -- the structural rank of the generic pattern of Q_M is below N + m (not
      left-invertible: a ZDA at every lambda0), or at lambda = 0
      :func:`u_direction_certificate` proves a kernel vector with u0 != 0 (a persistent ZDA);
    * none -- zero forcing from M on the exact graph (:func:`~glocal_verify.analysis.local.cluster_pencil.zero_forcing_closure`,
      rows of attacked agents never force) reaches every agent, so ker Q_M(s) = {0} for every
      s; and lambda = 0 is settled by zero forcing from M_x or by
      :func:`u_direction_certificate` with rank [alpha L; S_{M_x}] <= N - (components without
      a position-monitored agent) (their indicator vectors are exact kernel vectors).

    * exists -- a candidate direction (lambda0, xi, u0) at a real lambda0 given exactly (the
      requested exponent) rationalises to an exact kernel vector with u0 != 0
      (:func:`~glocal_verify.numerics.exact_subspace.rational_kernel_vector`), or a computed zero (s, xi, u0) of Q_M is proved by
      the Krawczyk test in ball arithmetic (:func:`~glocal_verify.analysis.local.cluster_pencil.krawczyk_kernel`:
      an exact kernel vector of Q_M(s) = P0 + s P1 inside certified enclosures, its u0 part
      excluding 0; any s is reached by some lambda != 0).

    Anything else -- in particular a zero at an irrational lambda0 found by the deflation, or
    the absence of zeros found by QZ -- has no floating-point proof: ``status`` None and a
    note; the checker is then undecided (and the registry escalates to exact arithmetic).

    Parameters
    ----------
    system : System
    actuators : iterable of labels, optional
        F; default the spec's attacked actuators.
    """
    from glocal_verify.analysis.local.cluster_pencil import (
        intra_neighbours,
        zero_forcing_closure,
    )

    F = system.idx(_actuators(system, actuators))
    N, m = system.n, len(F)
    M = system.idx(system.monitored)
    Mx = system.idx(system.monitored_positions)
    pat = exact_q_pattern(system, F, M)
    if structural_rank(pat) < N + m:
        return ZdaCertificate(Status.HOLDS, "structural rank of the exact support of Q_M(s) < N + m: not left-invertible, a ZDA at every lambda0")
    bound: float | None
    at0: bool | None
    if not Mx:
        # lambda = 0 with no monitored position: Q(0) = [alpha L_1, -S_F^T]. With positive
        # weights rank L_1 = N - c (c components, each indicator spans ker L_1 restricted to it),
        # and the columns e_f add the indicators of the c_F components holding an attacked
        # agent, so rank Q(0) = N - c + c_F: a kernel vector with u0 != 0 exists iff c_F < m
        comp = {system.index[a]: ci for ci, c in enumerate(system.components()) for a in c}
        c_f = len({comp[f] for f in F})
        at0, bound = c_f < m, None
        if at0:
            return ZdaCertificate(Status.HOLDS, f"at lambda0 = 0 with no monitored position, {m} attacked agents lie in {c_f} component(s) of G_1: rank [alpha L_1, -S_F^T] = N - c + {c_f} < N - c + {m} (a persistent ZDA; exact, from the graph)", lambda0=0j)
    else:
        rows0, pat0 = exact_q_rows(system, F, Mx, Fraction(0))
        mx = set(Mx)
        free = sum(1 for c in system.components() if not any(system.index[a] in mx for a in c))
        at0, bound = u_direction_certificate(rows0, pat0, N, m, xi_upper=N - free)
        if at0 is True:
            return ZdaCertificate(Status.HOLDS, "Weyl/structural rank bounds at lambda0 = 0: rank Q_{M_x}(0) < rank [alpha L; S_{M_x}] + m (a persistent ZDA)", bound, lambda0=0j)
    if candidate is not None and candidate[0].imag == 0:
        lq = Fraction(candidate[0].real)
        rows_c, _ = exact_q_rows(system, F, Mx if lq == 0 else M, lq * lq + system.gamma_q * lq)
        qv = rational_kernel_vector(rows_c, np.concatenate([candidate[1], candidate[2]]))
        if qv is not None and any(x != 0 for x in qv[N:]):
            return ZdaCertificate(Status.HOLDS, f"the direction at lambda0 = {lq} rationalises to an exact kernel vector with u0 != 0 (checked over Q)")
    if zeros:
        from glocal_verify.analysis.local.cluster_pencil import krawczyk_kernel

        P0, _ = exact_q_rows(system, F, M, Fraction(0))
        P1 = [[Fraction(int(i == j and i < N)) for j in range(N + m)] for i in range(len(P0))]
        for s_val, xi, u0 in zeros[:12]:
            enc = krawczyk_kernel(P0, P1, complex(s_val), np.concatenate([xi, u0]))
            if enc is not None and enc.nonzero(range(N, N + m)):
                return ZdaCertificate(Status.HOLDS, f"Krawczyk test: Q_M(s) has an exact kernel vector with u0 != 0 at s in {enc.lam} (ball arithmetic)")
    nbrs = intra_neighbours(system.laplacian_exact())
    zf = zero_forcing_closure(nbrs, M, F)
    if len(zf) == N:
        zf0 = len(zero_forcing_closure(nbrs, Mx, F)) == N
        if zf0 or at0 is False:
            at0_by = "the components of G_1 at lambda = 0 (no monitored position; each holds at most one attacked agent)" if not Mx else "certified rank bounds at lambda = 0"
            by = "zero forcing from M on the exact graph (every lambda != 0) and " + ("from M_x (lambda = 0)" if zf0 else at0_by)
            return ZdaCertificate(Status.FAILS, by, None if zf0 else bound)
        return ZdaCertificate(None, "", bound, f"zero forcing excludes every lambda != 0, but the rank bounds at lambda = 0 do not separate (error bound {bound if bound is not None else 0:.3g})")
    return ZdaCertificate(
        None,
        "",
        bound,
        f"no structural certificate: zero forcing from M leaves {N - len(zf)} of {N} agents unforced, and the zeros (or their absence) "
        "found by the deflation are floating-point statements a small residual cannot prove",
    )
