"""How a certificate writes numbers, vectors and number fields, and the residues modulo a
prime its minors state (the finder's side of the arithmetic the checker redoes)."""

from __future__ import annotations

from fractions import Fraction
from typing import Any, Iterable, Mapping, Sequence

import numpy as np
from flint import fmpq, fmpq_poly, nmod_mat

from glocal_verify.model import System
from glocal_verify.numerics.minors import prime_for

__all__ = [
    "EMIT_PRIME_LIMIT",
    "charpoly_claim",
    "cholesky_upper",
    "lyapunov_claim",
    "schur_claim",
    "stability_claim",
    "state_matrix_exact",
    "field",
    "krylov_residue",
    "laplacian_mod",
    "mod_residues",
    "pivots_mod",
    "q",
    "system_prime",
    "unit",
    "vector",
]

#: primes of certificates lie below this (2^25: sparse products modulo p stay in int64)
EMIT_PRIME_LIMIT = 2**25


def q(x: Any) -> str:
    """An exact rational as text (``"3"``, ``"-1/3"``); a float is taken exactly."""
    if isinstance(x, float):
        x = Fraction(x)
    return str(x)


def vector(system: System, v: Sequence[Any] | Mapping[Any, Any]) -> dict[str, Any]:
    """A vector over the agents as ``{label: value}`` without its zeros; values are rationals
    (text) or polynomials (lists of rational texts, lowest degree first)."""
    items = v.items() if isinstance(v, Mapping) else zip(system.labels, v)
    out: dict[str, Any] = {}
    for lab, x in items:
        if isinstance(x, fmpq_poly):
            if x != 0:
                out[str(lab)] = [q(c) for c in x.coeffs()]
        elif x != 0:
            out[str(lab)] = q(x)
    return out


def field(modulus: fmpq_poly) -> dict[str, Any]:
    """The ring Q[t]/(modulus) as a certificate writes it."""
    return {"modulus": [q(c) for c in modulus.coeffs()]}


def system_prime(system: System, limit: int = EMIT_PRIME_LIMIT) -> int:
    """The largest prime below ``limit`` dividing no denominator of the gains or weights."""
    values = [system.alpha_q, system.gamma_q] + [w for m in system.modes for w in system.edges(m).values()]
    return prime_for(values, limit)


def unit(r: int, p: int) -> list[int]:
    """A nonzero residue as a certificate states it: ``[r, r^-1 mod p]``."""
    return [int(r), pow(int(r), -1, p)]


def mod_residues(values: Iterable[Fraction | fmpq], p: int) -> list[int]:
    out = []
    for x in values:
        x = Fraction(int(x.p), int(x.q)) if isinstance(x, fmpq) else Fraction(x)
        out.append(x.numerator * pow(x.denominator, -1, p) % p)
    return out


def laplacian_mod(system: System, mode: str, p: int) -> Any:
    """L_q modulo p as a scipy CSR matrix of int64 residues."""
    import scipy.sparse

    idx = system.index
    rows, cols, vals = [], [], []
    deg = [Fraction(0)] * system.n
    for key, w in system.edges(mode).items():
        a, b = (idx[x] for x in key)
        rows += [a, b]
        cols += [b, a]
        vals += [-w, -w]
        deg[a] += w
        deg[b] += w
    rows += list(range(system.n))
    cols += list(range(system.n))
    vals += deg
    return scipy.sparse.csr_matrix((np.array(mod_residues(vals, p), dtype=np.int64), (rows, cols)), shape=(system.n, system.n))


def krylov_residue(system: System, mode: str, start: Sequence[int], length: int, p: int, drop_last_column: bool = False) -> int:
    """det modulo p of the rows ``b^T L_q^j`` (j < ``length``), without the last column when
    asked: the number a ``krylov`` certificate states (sparse products modulo p)."""
    L = laplacian_mod(system, mode, p)
    rows = []
    v = np.array([x % p for x in start], dtype=np.int64)
    for _ in range(length):
        rows.append(v)
        v = (L @ v) % p
    cols = system.n - 1 if drop_last_column else system.n
    flat = [int(x) for r in rows for x in r[:cols]]
    return int(nmod_mat(cols, cols, flat, p).det()) if cols else 1


def charpoly_claim(A: Sequence[Sequence[Fraction]], K: np.ndarray, cols: Sequence[int], p: int, zero_rows: Iterable[int] = (), drop_zeros: int = 0) -> dict[str, Any]:
    """``{"prime", "charpoly"}`` of F = A - K C over Q (rows ``zero_rows`` of A cleared first,
    C the selection of the state columns ``cols``, K binary floating-point numbers taken
    exactly), as residues modulo p, lowest degree first, divided by t^``drop_zeros``: the
    characteristic polynomial of F reduced modulo p (p divides no denominator), computed there."""
    n = len(A)
    zero = set(zero_rows)
    rows = [[Fraction(0) if i in zero else x for x in A[i]] for i in range(n)]
    flat: list[int] = []
    for i in range(n):
        r = list(rows[i])
        for k, c in enumerate(cols):
            r[c] = r[c] - Fraction(float(K[i, k]))
        flat += mod_residues(r, p)
    cp = [int(c) for c in nmod_mat(n, n, flat, p).charpoly().coeffs()]
    if any(cp[:drop_zeros]):
        raise ValueError("the characteristic polynomial has fewer zero roots than the quotient removes")
    return {"prime": p, "charpoly": cp[drop_zeros:]}


def lyapunov_claim(F: np.ndarray) -> dict[str, Any]:
    """``{"lyapunov": {"P", "shift_P", "shift_Q", "R_P", "R_Q"}}`` for a Hurwitz matrix F
    (floating point): P solves F^T P + P F = -I (:func:`_lyapunov_entries`). The checker proves
    P > 0 and Q = -(F^T P + P F) > 0 for the exact F (``glocal_check.algebra.lyapunov``)."""
    import scipy.linalg

    P = scipy.linalg.solve_continuous_lyapunov(F.T, -np.eye(len(F)))
    return {"lyapunov": _lyapunov_entries(P, -(F.T @ P + P @ F))}


def _lyapunov_entries(P: np.ndarray, Q: np.ndarray) -> dict[str, Any]:
    """P (symmetrised, scaled integers), the shifts (half the smallest eigenvalues of P and Q)
    and the Cholesky factors of P - c_P I and Q - c_Q I (``dyadic_upper``)."""
    P = (P + P.T) / 2
    Q = (Q + Q.T) / 2
    shift_P = float(np.linalg.eigvalsh(P)[0]) / 2
    shift_Q = float(np.linalg.eigvalsh(Q)[0]) / 2
    if not (shift_P > 0 and shift_Q > 0):
        raise ValueError("no Lyapunov matrix found in floating point")
    Pd = dyadic_upper(P)
    Pr = np.array([[0.0] * i + [float(x) / 2 ** Pd["scale"] for x in row] for i, row in enumerate(Pd["upper"])])
    Pr = np.triu(Pr) + np.triu(Pr, 1).T  # the P the checker reads
    return {
        "P": Pd,
        "shift_P": q(Fraction(repr(shift_P))),
        "shift_Q": q(Fraction(repr(shift_Q))),
        "R_P": cholesky_upper(Pr - shift_P * np.eye(len(P))),
        "R_Q": cholesky_upper(Q - shift_Q * np.eye(len(Q))),
    }


def dyadic_upper(M: np.ndarray) -> dict[str, Any]:
    """The upper triangle of M as integers scaled by 2^-scale (about 50 significant bits)."""
    top = float(np.max(np.abs(M))) or 1.0
    b = max(0, 50 - int(np.frexp(top)[1]))
    return {"scale": b, "upper": [[int(round(float(x) * 2.0**b)) for x in M[i, i:]] for i in range(len(M))]}


def cholesky_upper(M: np.ndarray) -> dict[str, Any]:
    """R (upper, ``dyadic_upper``) with R^T R = M in floating point (M positive definite)."""
    try:
        L = np.linalg.cholesky((M + M.T) / 2)
    except np.linalg.LinAlgError:
        raise ValueError("no Cholesky factor in floating point") from None
    return dyadic_upper(L.T)


def schur_claim(F: np.ndarray) -> dict[str, Any]:
    """``{"P", "shift_P", "shift_Q"}`` for a Schur-stable F (floating point): P solves
    P - F^T P F = I (a Stein matrix; the checker proves P > 0 and P - F^T P F > 0 exactly)."""
    import scipy.linalg

    P = scipy.linalg.solve_discrete_lyapunov(F.T, np.eye(len(F)))
    return _lyapunov_entries(P, P - F.T @ P @ F)


def stability_claim(A: Sequence[Sequence[Fraction]], K: np.ndarray, cols: Sequence[int], p: int, zero_rows: Iterable[int] = ()) -> dict[str, Any]:
    """What proves F = A - K C Hurwitz (rows ``zero_rows`` of A cleared): its characteristic
    polynomial modulo p up to ``certificate_max_states`` states (the checker encloses its
    roots), a Lyapunov matrix above (or the polynomial up to twice as many states when no
    Lyapunov matrix is found in floating point)."""
    from glocal_verify import config

    if len(A) <= config.get("certificate_max_states"):
        return charpoly_claim(A, K, cols, p, zero_rows)
    zero = set(zero_rows)
    F = np.array([[0.0 if i in zero else float(x) for x in A[i]] for i in range(len(A))])
    F[:, list(cols)] -= np.asarray(K, dtype=float)
    try:
        return lyapunov_claim(F)
    except ValueError:
        if len(A) <= 2 * config.get("certificate_max_states"):
            return charpoly_claim(A, K, cols, p, zero_rows)  # slower to check, but exact without a Lyapunov matrix
        raise


def state_matrix_exact(L: Sequence[Sequence[Fraction]], alpha: Fraction, gamma: Fraction) -> list[list[Fraction]]:
    """A = [[0, I], [-alpha L, -gamma I]] over Q."""
    n = len(L)
    A = [[Fraction(0)] * (2 * n) for _ in range(2 * n)]
    for i in range(n):
        A[i][n + i] = Fraction(1)
        for j, x in enumerate(L[i]):
            A[n + i][j] = -alpha * x
        A[n + i][n + i] = -gamma
    return A


def pivots_mod(rows: Sequence[Sequence[int]], ncols: int, p: int) -> tuple[list[int], list[int]]:
    """(pivot rows, pivot columns) of a matrix of residues: a nonsingular square submatrix of
    the size of its rank modulo p."""
    if not rows or ncols == 0:
        return [], []
    M = nmod_mat(len(rows), ncols, [int(x) for r in rows for x in r], p)
    cols = _pivots(M)
    T = nmod_mat(ncols, len(rows), [int(rows[i][j]) for j in range(ncols) for i in range(len(rows))], p)
    return _pivots(T), cols


def _pivots(M: nmod_mat) -> list[int]:
    R, r = M.rref()
    out = []
    lst = R.tolist()
    for i in range(int(r)):
        out.append(next(j for j, x in enumerate(lst[i]) if int(x) != 0))
    return out
