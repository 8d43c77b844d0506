"""Exact full-column-rank certificates for the reduced system pencil, by maximal minors modulo a prime.

The pencils of eq. ``zda_cond`` (the normal mode, inputs F, outputs M) and eq. ``pencil_uio``
(a cluster, inputs the suspected and boundary agents, outputs the observer's channels) share
one form. With s = lambda^2 + gamma lambda, a kernel vector at lambda != 0 is
[xi; lambda xi; u] with S_M xi = 0 and (sI + alpha L) xi = S_I^T u (I the input agents, each
input a nonzero multiple of one unit vector e_a). So, with U = V \\ M, I' = I ∩ U and
M' = M \\ I, the kernel is isomorphic to the kernel of the tall polynomial matrix

    T(s) = [ K(s)[U \\ I', :] ; alpha L[M', U] ],     K(s) = sI + alpha L[U, U],

and the pencil has full column rank at every lambda != 0 iff T(s) has full column rank for
every complex s. Replacing the rows I' of K by k = |I'| rows of alpha L[M'', U] (M'' ⊆ M',
|M''| = k) gives a maximal minor of T; by the matrix determinant lemma it equals

    alpha^k det(N_{M'', I'}(s)) / det(K(s))^(k-1),   N_{m f}(s) = (L[m, U] adj K(s))_f,

a polynomial (k = 0: det K itself). If these minors have no common root, T(s) has full column
rank for every s: no zero of the pencil with lambda != 0, and normal full column rank.

Modulo a prime (proof)
    All data are rationals whose denominators are units modulo p, so every minor is a
    polynomial over the local ring Z_(p) and reduction modulo p is a ring homomorphism. Let
    h be a greatest common divisor over Q of the minors used, normalised to be primitive over
    Z_(p); h divides each of them over Z_(p) (Gauss's lemma), so h mod p divides each
    reduction. If one minor f has its reduction of the same degree as f itself, the leading
    coefficient of h divides that of f and is a unit, so deg(h mod p) = deg h. Hence
    deg h <= deg gcd(reductions): a gcd of degree 0 modulo p proves that the minors have
    no common root over C. The exact degree of one minor is known from an upper bound that
    is proved combinatorially (below) and attained by its reduction.

Degree bounds (proof)
    adj(sI - A) = sum_{k<n} s^k sum_{i<n-k} a_{k+i+1} A^i with det(sI - A) = sum a_j s^j,
    A = -alpha L[U, U]; the coefficient of s^(n-1-t) in N_{m f} is
    sum_{i<=t} a_{n-t+i} (r_m A^i)_f with r_m = L[m, U]. (r_m A^i)_f = 0 unless a walk of
    i + 1 edges leads from m to f with every vertex after m in U, so with d(m, f) the length
    of the shortest such walk, deg N_{m f} <= n - d(m, f) and the coefficient of s^(n-d) is
    (r_m A^(d-1))_f. For k = 2 the minor is (N_{m1 a} N_{m2 b} - N_{m1 b} N_{m2 a}) / det K,
    of degree at most max(deg N_{m1 a} + deg N_{m2 b}, deg N_{m1 b} + deg N_{m2 a}) - n;
    for general k the same bound over permutations.

Arithmetic
    The numerators of every (m, f) are computed once per pencil family from one Krylov
    sequence r_m A^i (sparse A) and the characteristic polynomial (python-flint ``nmod_mat``),
    as a Hankel product in double precision whose entries stay below 2^52 (the prime is chosen
    with n p^2 < 2^52), hence exact. Per input set only a few polynomial products, one exact
    division and a gcd over F_p (python-flint ``nmod_poly``) remain.
"""

from __future__ import annotations

from glocal_verify import config

import itertools
import math
from collections.abc import Mapping, MutableMapping, Sequence
from dataclasses import dataclass
from fractions import Fraction
from typing import Any

import numpy as np
import scipy.linalg
import scipy.sparse

from glocal_verify.numerics.symmetry import twin_modes

__all__ = [
    "GroundedTables",
    "MinorCertificate",
    "RATIONAL_ZERO",
    "charpoly_mod",
    "constant_full_rank_mod_p",
    "full_rank_certificate",
    "grounded_tables",
    "prime_for",
    "residues_mod_p",
    "submatrix_full_rank_mod_p",
]

_UNREACHABLE = 1 << 30
#: the shared rational zero (Fractions are immutable): rows that use it for their zero entries
#: are read without a comparison per entry (:func:`verified_invariant_subspace`)
RATIONAL_ZERO = Fraction(0)


@dataclass(frozen=True, eq=False)
class GroundedTables:
    """Numerators N_{m f} modulo a prime for one pencil family (fixed L, alpha and outputs M).

    Attributes
    ----------
    prime : int
        p, with every denominator of the data a unit modulo p.
    size : int
        Number of agents of the family (rows of L).
    grounded : tuple of int
        U = V \\ M (agent indices, ascending); position j in U indexes the columns below.
    position : tuple of int
        For every agent, its position in U or -1.
    measured : tuple of int
        M, the output agents (ascending).
    charpoly : ndarray of int64
        det(sI + alpha L[U, U]) modulo p, coefficients from s^0 to s^n (monic).
    numerators : ndarray of int64, shape (|M|, n, n)
        ``numerators[i, j, k]``: coefficient of s^k of N_{m_i, U_j} modulo p.
    distance : ndarray of int64, shape (|M|, n)
        d(m_i, U_j) of the module docstring (a large number when no walk exists).
    anchors : tuple of int
        Positions in U used as extra replaced rows: the row nearest to an output in every
        component of G[U] (largest first), then the neighbours of the outputs.
    twins : tuple
        :func:`~glocal_verify.numerics.symmetry.twin_modes` of (L, M): ``((mu, pairs), ...)``.
    twin_roots : tuple of (int, int)
        Their roots s0 = -alpha mu modulo p with multiplicities.
    unobservable_factor : tuple of int
        det(sI + alpha B) modulo p (low to high) for an exactly verified L-invariant subspace W
        of ker S_M with L W = W B (:func:`verified_invariant_subspace`); empty when none was
        given. It contains the twin modes when W does and replaces their factor.
    unobservable_dim : int
        dim W.
    """

    prime: int
    size: int
    grounded: tuple[int, ...]
    position: tuple[int, ...]
    measured: tuple[int, ...]
    charpoly: np.ndarray
    numerators: np.ndarray
    distance: np.ndarray
    anchors: tuple[int, ...] = ()
    twins: tuple[tuple[Fraction, tuple[tuple[int, int], ...]], ...] = ()
    twin_roots: tuple[tuple[int, int], ...] = ()
    unobservable_factor: tuple[int, ...] = ()
    unobservable_dim: int = 0


@dataclass(frozen=True, slots=True)
class MinorCertificate:
    """A proof that T(s) has full column rank for every s (module docstring).

    Attributes
    ----------
    prime : int
    minors : tuple of str
        The maximal minors used, e.g. ``"rows I' -> (7, 12)"``.
    degree : int
        Exact degree of the minor whose degree is known.
    twin_degree : int
        Degree of the twin-mode factor divided out (0: full column rank is proved).
    """

    prime: int
    minors: tuple[str, ...]
    degree: int
    twin_degree: int = 0

    def text(self) -> str:
        """One line for a witness."""
        if self.twin_degree:
            return (
                f"{len(self.minors)} maximal minor(s) of the reduced pencil, divided by the factor of {self.twin_degree} exact twin "
                f"mode(s) (u = 0), have gcd 1 modulo the prime {self.prime} (one of proved exact degree {self.degree}): "
                "no kernel vector with an input part at any lambda != 0"
            )
        return (
            f"{len(self.minors)} maximal minor(s) of the reduced pencil have gcd 1 modulo the prime {self.prime} "
            f"(one of proved exact degree {self.degree}): full column rank for every lambda != 0"
        )


# ------------------------------------------------------------------------------------------
# construction


def _is_prime(q: int) -> bool:
    if q < 2:
        return False
    for d in range(2, math.isqrt(q) + 1):
        if q % d == 0:
            return False
    return True


def _primes_below(limit: int) -> Any:
    q = limit
    while q > 2:
        if _is_prime(q):
            yield q
        q -= 1


def _mod(x: Fraction, p: int) -> int:
    return (x.numerator % p) * pow(x.denominator % p, -1, p) % p


def grounded_tables(
    size: int,
    laplacian: Mapping[tuple[int, int], Fraction],
    alpha: Fraction,
    measured: Sequence[int],
    unobservable: Sequence[Sequence[Fraction]] | None = None,
) -> GroundedTables | None:
    """The numerator tables of the module docstring for one (L, alpha, M).

    Parameters
    ----------
    size : int
        Number of agents n_V.
    laplacian : mapping
        The nonzero entries ``{(i, j): L_ij}`` of the (symmetric) Laplacian, diagonal included,
        as exact rationals.
    alpha : Fraction
        The position gain.
    measured : sequence of int
        M (rows whose xi is constrained to zero).
    unobservable : sequence of rational rows, optional
        A candidate basis of unobservable modes (e.g. rationalised from floating point); it is
        used only if :func:`verified_invariant_subspace` proves it exactly.

    Returns
    -------
    GroundedTables or None
        None when no suitable prime was found (every candidate divides a denominator).
    """
    from flint import nmod_mat

    M = tuple(sorted({int(m) for m in measured}))
    Mset = set(M)
    U = tuple(i for i in range(size) if i not in Mset)
    n = len(U)
    pos = [-1] * size
    for j, i in enumerate(U):
        pos[i] = j
    # a prime dividing no denominator (the proof) and no numerator (so no nonzero entry vanishes modulo p)
    dens = _data_factors([*laplacian.values(), alpha])
    limit = int(min(2**24, math.isqrt(2**52 // max(n, 1))))
    p = next((q for q in _primes_below(limit) if all(d % q for d in dens)), None)
    if p is None:
        return None
    a_mod = _mod(alpha, p)
    # A = -alpha L[U, U] modulo p, sparse; rows r_m = L[m, U]
    rows, cols, vals = [], [], []
    R0 = np.zeros((len(M), n))
    mi = {m: i for i, m in enumerate(M)}
    nbrs: list[list[int]] = [[] for _ in range(size)]
    for (i, j), v in laplacian.items():
        if v == 0:
            continue
        if i != j:
            nbrs[i].append(j)
        if pos[i] >= 0 and pos[j] >= 0:
            rows.append(pos[i])
            cols.append(pos[j])
            vals.append(float((-a_mod * _mod(v, p)) % p))
        elif i in mi and pos[j] >= 0:
            R0[mi[i], pos[j]] = float(_mod(v, p))
    A = scipy.sparse.csr_matrix((vals, (rows, cols)), shape=(n, n))
    AT = A.T.tocsr()
    # characteristic polynomial det(sI - A) = det(sI + alpha L[U, U])
    dense = np.zeros((n, n), dtype=np.int64)
    dense[rows, cols] = np.asarray(vals, dtype=np.int64)
    cp = nmod_mat(n, n, [int(x) for x in dense.ravel()], p).charpoly() if n else None
    a = np.zeros(n + 1, dtype=np.int64)
    if cp is not None:
        co = [int(c) for c in cp.coeffs()]
        a[: len(co)] = co
    else:
        a[0] = 1
    # Krylov rows r_m A^i, i < n (exact: entries < p, sums below 2^52)
    R = np.zeros((n, len(M), n))
    cur = R0
    for i in range(n):
        R[i] = cur
        cur = np.fmod((AT @ cur.T).T, p)
    H = scipy.linalg.hankel(a[1 : n + 1].astype(float), np.zeros(n)) if n else np.zeros((0, 0))
    num = np.zeros((len(M), n, n), dtype=np.int64)
    for k in range(len(M)):
        num[k] = np.fmod(H @ R[:, k, :], p).astype(np.int64).T
    # U-restricted distances d(m, U_j)
    dist = np.full((len(M), n), _UNREACHABLE, dtype=np.int64)
    for k, m in enumerate(M):
        frontier = [j for j in nbrs[m] if pos[j] >= 0]
        seen = set(frontier)
        d = 1
        while frontier:
            for j in frontier:
                dist[k, pos[j]] = d
            nxt = []
            for j in frontier:
                for q in nbrs[j]:
                    if pos[q] >= 0 and q not in seen:
                        seen.add(q)
                        nxt.append(q)
            frontier, d = nxt, d + 1
    # components of G[U] and their rows nearest to an output
    comp = [-1] * n
    parts: list[list[int]] = []
    for j0 in range(n):
        if comp[j0] >= 0:
            continue
        comp[j0] = len(parts)
        part, stack = [j0], [j0]
        while stack:
            j = stack.pop()
            for q in nbrs[U[j]]:
                if pos[q] >= 0 and comp[pos[q]] < 0:
                    comp[pos[q]] = len(parts)
                    part.append(pos[q])
                    stack.append(pos[q])
        parts.append(part)
    near = dist.min(axis=0) if len(M) else np.zeros(n, dtype=np.int64)
    anchors: list[int] = [min(part, key=lambda j: (int(near[j]), j)) for part in sorted(parts, key=len, reverse=True)]
    anchors += [j for j in np.argsort(near, kind="stable").tolist() if near[j] == 1 and j not in anchors]
    tw = twin_modes(size, laplacian, M)
    roots = tuple(((-a_mod * _mod(mu, p)) % p, len(pairs)) for mu, pairs in tw)
    ufac: tuple[int, ...] = ()
    udim = 0
    ver = verified_invariant_subspace(size, laplacian, M, unobservable) if unobservable else None
    if ver is not None and all(d % p for r in ver[1] for x in r for d in (abs(int(Fraction(x).denominator)),)):
        B = ver[1]
        udim = len(B)
        ent = {(i, j): -alpha * B[i][j] for i in range(udim) for j in range(udim) if B[i][j] != 0}
        ufac = tuple(int(c) for c in charpoly_mod(udim, ent, p).coeffs())
    return GroundedTables(p, size, U, tuple(pos), M, a, num, dist, tuple(int(j) for j in anchors), tw, roots, ufac, udim)


# ------------------------------------------------------------------------------------------
# one input set


def _poly(t: GroundedTables, i: int, j: int, cache: MutableMapping[Any, Any]) -> Any:
    from flint import nmod_poly

    key = ("N", t, i, j)
    if key not in cache:
        cache[key] = nmod_poly(np.asarray(t.numerators[i, j]).tolist(), t.prime)
    return cache[key]


class _PolyTable:
    """Row q of the numerator polynomials N_{m_q, U_f}, converted on first use (``table[q][f]``)."""

    def __init__(self, t: GroundedTables, cache: MutableMapping[Any, Any]) -> None:
        self.t, self.cache = t, cache
        self.rows: list[list[Any]] = [[None] * len(t.grounded) for _ in t.measured]

    def __getitem__(self, q: int) -> list[Any]:
        return self.rows[q]

    def fill(self, q: int, f: int) -> Any:
        p = self.rows[q][f] = _poly(self.t, q, f, self.cache)
        return p


def _charpoly(t: GroundedTables, cache: MutableMapping[Any, Any]) -> Any:
    from flint import nmod_poly

    key = ("K", t)
    if key not in cache:
        cache[key] = nmod_poly([int(c) for c in t.charpoly], t.prime)
    return cache[key]


def _det(entries: list[list[Any]]) -> Any:
    k = len(entries)
    if k == 1:
        return entries[0][0]
    if k == 2:
        return entries[0][0] * entries[1][1] - entries[0][1] * entries[1][0]
    total = None
    for c in range(k):
        minor = [row[:c] + row[c + 1 :] for row in entries[1:]]
        term = entries[0][c] * _det(minor)
        total = term if total is None else (total + term if c % 2 == 0 else total - term)
    return total


def full_rank_certificate(
    tables: GroundedTables,
    inputs: Sequence[int],
    cache: MutableMapping[Any, Any] | None = None,
    *,
    modulo_twins: bool = False,
    patience: int | None = None,
    extra_rows: int | None = None,
) -> MinorCertificate | None:
    """Prove that T(s) of the module docstring has full column rank for every s, or return None.

    With ``modulo_twins`` the claim is weaker and is what a stealthy ZDA needs: at every s the
    kernel of T(s) is spanned by exact twin modes (:func:`~glocal_verify.numerics.symmetry.twin_modes`, kernel vectors with
    u = 0), so no kernel vector has an input part. Proof: each twin mode family of dimension t
    at s0 lies in ker T(s0) for every input set (it is supported on U and an eigenvector of L),
    so every maximal minor is divisible by (s - s0)^t; if dim ker T(s0) exceeded the twin
    dimension, every minor would vanish to a higher order and the quotients would share the
    root s0. Quotients with gcd 1 (modulo p, as above) therefore leave only the twin modes.

    Parameters
    ----------
    tables : GroundedTables
        From :func:`grounded_tables` for the pencil family.
    inputs : sequence of int
        I, the agents with an input column (each input a nonzero multiple of one unit vector;
        an agent listed twice gives a normal-rank deficiency, never a certificate).
    cache : dict, optional
        Per-process store of the polynomials built from the tables (python-flint objects).
    modulo_twins : bool
        Divide every minor by the twin-mode factor of ``tables.twins`` first.
    patience : int or None
        Give up after this many consecutive minors that do not lower the degree of the gcd
        (a common factor that survives them is usually a genuine zero, e.g. zero dynamics
        in a part of the graph no monitor sees); None tries every candidate minor.
    extra_rows : int or None
        Try at most this many minors with an extra replaced row (the costlier (k + 1)-sized
        ones, which break factors of a part of G[U] without inputs); None: every one.

    Returns
    -------
    MinorCertificate or None
        None when the certificate does not apply (too many unmeasured inputs, fewer output
        rows than unmeasured inputs) or the minors tried share a root modulo p: nothing is
        proved then.
    """
    from flint.utils.flint_exceptions import DomainError

    if cache is None:
        cache = {}
    if len(set(inputs)) != len(inputs):
        return None
    Iset = {int(i) for i in inputs}
    Ip = [tables.position[i] for i in sorted(Iset) if tables.position[i] >= 0]
    Mp = [k for k, m in enumerate(tables.measured) if m not in Iset]
    k = len(Ip)
    n = len(tables.grounded)
    if k > config.get("minor_max_inputs") or len(Mp) < k:
        return None
    detK = _charpoly(tables, cache)

    bkey = ("bounds", tables)
    if bkey not in cache:
        cache[bkey] = np.where(tables.distance < _UNREACHABLE, n - tables.distance.astype(np.int64), -1).tolist()
    bounds: list[list[int]] = cache[bkey]

    def bound_of(r: int, f: int) -> int:
        return bounds[r][f]

    pkey0 = ("N-table", tables)
    if pkey0 not in cache:
        cache[pkey0] = _PolyTable(tables, cache)
    polys = cache[pkey0]

    def minor(replaced: Sequence[int], rows: Sequence[Any]) -> Any:
        """The maximal minor with the rows ``replaced`` of K taken from alpha L[rows, U]."""
        if rows and rows[0] == "combination":  # one more replaced row, as a random combination
            P, r = _random_combination(tables, cache, list(replaced), Mp, int(rows[1])), len(replaced) + 1
        else:
            r = len(replaced)
            if r == 0:
                return detK
            if r == 1:
                f = replaced[0]
                return polys[rows[0]][f] or polys.fill(rows[0], f)
            if r == 2:
                f0, f1 = replaced
                q0, q1 = polys[rows[0]], polys[rows[1]]
                P = (q0[f0] or polys.fill(rows[0], f0)) * (q1[f1] or polys.fill(rows[1], f1)) - (q0[f1] or polys.fill(rows[0], f1)) * (
                    q1[f0] or polys.fill(rows[1], f0)
                )
            else:
                P = _det([[polys[q][f] or polys.fill(q, f) for f in replaced] for q in rows])
        pkey = ("K^", tables, r - 1)
        if pkey not in cache:
            cache[pkey] = detK ** (r - 1)
        try:
            return P / cache[pkey]  # exact division: raises unless det K^(k-1) divides the minor
        except DomainError:
            raise ArithmeticError("a maximal minor is not divisible by det K^(k-1): the numerator tables are inconsistent") from None

    def bound(replaced: Sequence[int], rows: Sequence[Any]) -> int | None:
        """An upper bound of the degree of that minor (from the distances in G[U]); needed only
        until one minor of known exact degree is found."""
        if rows and rows[0] == "combination":
            return None
        r = len(replaced)
        if r == 0:
            return n
        if r == 1:
            b1 = bounds[rows[0]][replaced[0]]
            return b1 if b1 >= 0 else None
        if r == 2:  # the two permutations, without itertools (one call per certified set)
            (f0, f1), (q0, q1) = replaced, rows
            bq0, bq1 = bounds[q0], bounds[q1]
            d, x = bq0[f0], bq1[f1]
            e, y = bq0[f1], bq1[f0]
            terms2 = [u + v for u, v in ((d, x), (e, y)) if u >= 0 and v >= 0]
            return max(terms2) - n if terms2 else None
        terms = [
            sum(bound_of(q, replaced[c]) for q, c in zip(rows, perm))
            for perm in itertools.permutations(range(r))
            if all(bound_of(q, replaced[c]) >= 0 for q, c in zip(rows, perm))
        ]
        return max(terms) - (r - 1) * n if terms else None

    def candidates() -> Any:
        """(replaced rows, output rows) of the minors, in the order they are tried."""
        yield from ((Ip, rows) for rows in itertools.islice(itertools.combinations(Mp, k), config.get("minor_max_row_choices")))
        if k == 0:
            yield from (([int(np.argmin(tables.distance[q]))], [q]) for q in Mp[:config.get("minor_max_row_choices")])
        # one more replaced row, in another part of U: breaks factors det K_R shared by the
        # minors above (e.g. a component of G[U] that holds no input)
        if len(Mp) > k:
            extra = [j for j in tables.anchors if j not in Ip][:config.get("minor_max_extra_rows")]

            def with_extra() -> Any:
                for j in extra:  # one per component of G[U] first (each breaks that component's det K_c)
                    # the output rows nearest to j: a row that reaches j's component makes the
                    # minor nonzero (the first rows in order may not, e.g. for a leaf of one monitor)
                    near = sorted(Mp, key=lambda q: (int(tables.distance[q, j]), q))[: k + 1]
                    yield (Ip + [j], sorted(near))
                for j in extra[:config.get("minor_max_row_choices")]:
                    yield from ((Ip + [j], rows) for rows in itertools.islice(itertools.combinations(Mp, k + 1), 1, 3))

            if extra_rows is None:
                # random combinations of these minors and of every other choice of rows: with
                # high probability they keep only the common factors of all the maximal minors
                yield from ((Ip, ("combination", trial)) for trial in range(config.get("minor_random_combinations")))
            yield from (with_extra() if extra_rows is None else itertools.islice(with_extra(), extra_rows))

    last_combination = config.get("minor_random_combinations") - 1
    twin = _twin_factor(tables, cache) if modulo_twins and tables.twins else None
    twin_deg = twin.degree() if twin is not None else 0
    g = None
    used: list[tuple[Sequence[int], Sequence[int]]] = []
    first: tuple[Any, int] | None = None
    stale = 0
    # The twin factor t divides every minor, so gcd(P_1 / t, P_2 / t, ...) = gcd(P_1, P_2, ...) / t:
    # the minors are not divided one by one; t | gcd is checked once at the end (t divides every
    # minor iff it divides their gcd), and the quotients have gcd 1 iff deg gcd = deg t.
    for replaced, rows in candidates():
        P = minor(replaced, rows)
        if P.is_zero():
            continue
        if first is None:
            b = bound(replaced, rows)
            if b is not None and b - twin_deg >= 0 and P.degree() == b:
                first = (P, b - twin_deg)
        g_new = P if g is None else g.gcd(P)
        stale = stale + 1 if g is not None and g_new.degree() == g.degree() else 0
        g = g_new
        used.append((replaced, rows))
        if first is not None and g.degree() == twin_deg:
            break
        if patience is not None and stale >= patience:
            break
        if rows and rows[0] == "combination" and rows[1] == last_combination and g.degree() > twin_deg:
            # the combinations span every minor with one extra replaced row (those tried
            # below): a factor that survives them all is, with high probability, common to
            # those minors too, so trying them one by one is wasted work
            break
    if twin is not None and g is not None:
        try:
            g / twin  # exact division: raises unless the twin factor divides the gcd (every minor)
        except DomainError:
            raise ArithmeticError("a maximal minor is not divisible by its twin-mode factor: the twin modes are wrong") from None
    if first is None or g is None or g.degree() != twin_deg:
        return None
    texts = tuple(
        "det K" if not rep else (f"rows {tuple(tables.grounded[f] for f in rep)} and a random combination of the others -> random combinations of the outputs"
                                 if rows and rows[0] == "combination" else f"rows {tuple(tables.grounded[f] for f in rep)} -> {tuple(tables.measured[q] for q in rows)}")
        for rep, rows in used
    )
    return MinorCertificate(tables.prime, texts, int(first[1]), twin.degree() if twin is not None else 0)  # type: ignore[arg-type]


def _random_combination(tables: GroundedTables, cache: MutableMapping[Any, Any], Ip: list[int], Mp: Sequence[int], trial: int) -> Any:
    """det of the (k + 1) x (k + 1) matrix of numerators for the rows I' and one random combination e of the other rows of K,
    against k + 1 random combinations c_r of the output rows M' (modulo p, times det K^k).

    The maximal minor with replaced rows I' ∪ {j} and output rows (q_0, .., q_k) is
    det[N_{q_r, x}] / det K^k, x in I' ∪ {j}. It is linear in the row taken for j and, row by
    row, in the output rows, so sum_j e_j sum_q c_{0 q_0} .. c_{k q_k} (minor) is the
    determinant with N_{q_r, x} replaced by A_r[x] = sum_q c_{r q} N_{q, x} and the column j by
    sum_j e_j A_r[j]: a combination of maximal minors with coefficients in F_p. Every common
    factor of the minors, reduced modulo p, divides it, so it may enter the gcd of
    :func:`full_rank_certificate`; and with random coefficients it has, with high probability,
    no common root with them except theirs (it broke every leftover factor of the singles of
    the 1000-agent benchmark network, whose chosen minors kept a factor s + 1 or s + 3).
    The coefficients come from a generator seeded by the trial, the prime and the output rows.
    """
    from flint import nmod_poly

    p, k = tables.prime, len(Ip)
    key = ("combined-rows", tables, tuple(Mp), trial, k)
    if key not in cache:
        rng = np.random.default_rng((trial, p, len(Mp), k))
        c = np.array([rng.integers(1, p, len(Mp)) for _ in range(k + 1)], dtype=np.int64)
        e_all = rng.integers(1, p, len(tables.grounded))
        # e_all N_q for every output row q (not the combined rows A_r themselves): A_r is
        # needed only on the k rows I' and through e A_r = sum_q c_rq (e_all N_q - sum_{x in I'} e_all[x] N_q[x])
        W = np.stack([_row_combination(e_all, tables.numerators[q], p) for q in Mp])
        cache[key] = (c, e_all, W)
    c, e_all, W = cache[key]
    entries = []
    for r in range(k + 1):
        rows = np.zeros((k, W.shape[1]), dtype=np.int64)  # A_r[x] = sum_q c_rq N_q[x], x in I'
        comb = np.zeros(W.shape[1], dtype=np.int64)  # e_all A_r, then minus the rows of I' (e is zero there)
        for cq, q, w in zip(c[r].tolist(), Mp, W):
            rows = (rows + cq * tables.numerators[q][Ip]) % p  # entries < p^2 < 2^52
            comb = (comb + cq * w) % p
        for i, x in enumerate(Ip):
            comb = (comb - int(e_all[x]) * rows[i]) % p
        entries.append([nmod_poly(rows[i].tolist(), p) for i in range(k)] + [nmod_poly(comb.tolist(), p)])
    return _det(entries)


def _row_combination(e: np.ndarray, rows: np.ndarray, p: int) -> np.ndarray:
    """``e @ rows`` modulo p (entries in [0, p), p < 2^24), in blocks whose partial sums stay below 2^63."""
    out = np.zeros(rows.shape[1], dtype=np.int64)
    for lo in range(0, len(e), 4096):  # 4096 products < 2^48 each
        out = (out + e[lo : lo + 4096] @ rows[lo : lo + 4096]) % p
    return out


def _twin_factor(tables: GroundedTables, cache: MutableMapping[Any, Any]) -> Any:
    from flint import nmod_poly

    key = ("T", tables)
    if key not in cache:
        if tables.unobservable_factor:
            f = nmod_poly(list(tables.unobservable_factor), tables.prime)
        else:
            f = nmod_poly([1], tables.prime)
            for root, mult in tables.twin_roots:
                f *= nmod_poly([(-root) % tables.prime, 1], tables.prime) ** mult
        cache[key] = f
    return cache[key]


def verified_invariant_subspace(
    size: int, laplacian: Mapping[tuple[int, int], Fraction], measured: Sequence[int], rows: Sequence[Sequence[Fraction]]
) -> tuple[list[list[Fraction]], list[list[Fraction]]] | None:
    """Prove that span(rows) is L-invariant and vanishes on M, exactly; return (W, B) or None.

    W is the reduced row echelon basis of span(rows) (pivot entries 1) and B the matrix with
    L w_i = sum_j B_ij w_j, checked in exact rationals for every basis vector (residual exactly
    0, and w_i = 0 on every agent of M). Then W lies in the unobservable subspace of (L, S_M)
    and, L being symmetric, det(sI + alpha B) = prod (s + alpha mu)^dim(W ∩ E_mu).

    Parameters
    ----------
    size : int
    laplacian : mapping
        Nonzero entries of L (exact).
    measured : sequence of int
        M.
    rows : sequence of rational rows
        Candidate spanning vectors (length ``size``).
    """
    from flint import fmpq, fmpq_mat

    if not rows:
        return None
    X = fmpq_mat(len(rows), size)
    for i, r in enumerate(rows):  # the candidates are mostly zero: set the nonzeros only
        for j, x in enumerate(r):
            if x is not RATIONAL_ZERO and x:  # the shared zero is skipped without a comparison
                q = x if isinstance(x, Fraction) else Fraction(x)
                X[i, j] = fmpq(q.numerator, q.denominator)
    R, rank = X.rref()
    if rank == 0:
        return None
    # sparse rows of the echelon basis: twin modes and most verified modes have few nonzeros
    sparse: list[dict[int, Fraction]] = []
    for row_q in R.tolist()[:rank]:
        sparse.append({j: Fraction(int(x.p), int(x.q)) for j, x in enumerate(row_q) if x})
    piv = [min(r) for r in sparse]
    measured_set = set(measured)
    if any(measured_set.intersection(r) for r in sparse):
        return None
    needed = {j for r in sparse for j in r}  # L w reads the columns of L on the supports only
    cols: dict[int, list[tuple[int, Fraction]]] = {}
    for (i, j), v in laplacian.items():
        if j in needed and v:
            cols.setdefault(j, []).append((i, v))
    zero = RATIONAL_ZERO
    B: list[list[Fraction]] = []
    for w in sparse:
        Lw: dict[int, Fraction] = {}
        for j, x in w.items():
            for i, v in cols.get(j, ()):
                Lw[i] = Lw.get(i, zero) + v * x
        # W is in reduced echelon form: L w lies in span(W) iff L w = sum_t (L w)[piv_t] w_t
        c = [Lw.get(p_, zero) for p_ in piv]
        res = {k: x for k, x in Lw.items() if x != 0}
        for t, ct in enumerate(c):
            if ct != 0:
                for k, x in sparse[t].items():
                    res[k] = res.get(k, zero) - ct * x
        if any(x != 0 for x in res.values()):
            return None
        B.append(c)
    W = [[r.get(j, zero) for j in range(size)] for r in sparse]
    return W, B


def constant_full_rank_mod_p(rows: Sequence[Sequence[Fraction]], prime: int | None = None) -> bool:
    """True when the rational matrix has full column rank, proved by its rank modulo a prime.

    rank_p(A mod p) <= rank_Q(A) for every prime not dividing a denominator (a nonzero minor
    modulo p is nonzero over Q), so full column rank modulo p proves it over Q. False means
    "not proved" (never "rank deficient").

    Parameters
    ----------
    rows : sequence of sequences of Fraction
    prime : int, optional
        Default: a prime near 2^30 that divides no denominator.
    """
    from flint import nmod_mat

    if not rows:
        return False
    ncols = len(rows[0])
    if ncols == 0:
        return True
    if len(rows) < ncols:
        return False
    p = prime if prime is not None else prime_for([x for r in rows for x in r if x])
    ent = [_mod(Fraction(x), p) for r in rows for x in r]
    return int(nmod_mat(len(rows), ncols, ent, p).rank()) == ncols


def residues_mod_p(rows: Sequence[Sequence[Fraction]], prime: int) -> list[list[int]]:
    """The entries of a rational matrix modulo ``prime`` (which must divide no denominator),
    for :func:`submatrix_full_rank_mod_p` on many of its submatrices."""
    return [[_mod(Fraction(x), prime) if x else 0 for x in r] for r in rows]


def submatrix_full_rank_mod_p(residues: Sequence[Sequence[int]], rows: Sequence[int], cols: Sequence[int], prime: int) -> bool:
    """:func:`constant_full_rank_mod_p` of the submatrix ``[rows, cols]`` of a matrix given by
    its :func:`residues_mod_p` (the same proof: full column rank modulo p is full column rank
    over Q; False means "not proved")."""
    from flint import nmod_mat

    if not rows:
        return False
    if not cols:
        return True
    if len(rows) < len(cols):
        return False
    ent = [residues[i][j] for i in rows for j in cols]
    return int(nmod_mat(len(rows), len(cols), ent, prime).rank()) == len(cols)


def _data_factors(values: Sequence[Any]) -> set[int]:
    """The denominators and nonzero numerators (absolute values above 1) of rational data: a
    prime dividing none keeps every entry defined and every nonzero entry nonzero modulo p."""
    out: set[int] = set()
    for v in values:
        q = v if isinstance(v, Fraction) else Fraction(v)
        out.add(abs(int(q.denominator)))
        out.add(abs(int(q.numerator)))
    return out - {0, 1}


def prime_for(values: Sequence[Fraction], limit: int = 2**30) -> int:
    """The largest prime below ``limit`` that divides no denominator and no nonzero numerator of ``values``.

    Only the denominators matter for the proofs (reduction modulo p is then a ring
    homomorphism); a prime that divides a numerator would turn a nonzero entry into zero
    modulo p and make a certificate fail for nothing (weights such as p^2 / 10^6 chosen
    against the first primes tried), so it is passed over too.

    Parameters
    ----------
    values : sequence of Fraction
    limit : int
    """
    dens = _data_factors(values)
    return next(q for q in _primes_below(limit) if all(d % q for d in dens))


def charpoly_mod(size: int, entries: Mapping[tuple[int, int], Fraction], prime: int) -> Any:
    """det(mu I - A) modulo ``prime`` (python-flint ``nmod_poly``) for a rational matrix given by its nonzero entries.

    Parameters
    ----------
    size : int
    entries : mapping
        ``{(i, j): A_ij}``, exact; denominators must be units modulo ``prime``.
    prime : int
    """
    from flint import nmod_mat

    flat = [0] * (size * size)
    for (i, j), v in entries.items():
        flat[i * size + j] = _mod(Fraction(v), prime)
    return nmod_mat(size, size, flat, prime).charpoly()
