"""The invariant-zero polynomial of a left-invertible selection system over Q, proved without V*.

System: A (n x n, rational, given by its nonzero entries), B = S_F^T (input i acts on state
F_i), C = S_M (output j reads state M_j), D = 0, with the Rosenbrock pencil

    P(s) = [[s I - A, -B], [C, 0]]        ((n + p) x (n + m)).

When P has full normal column rank (left-invertible) its zero polynomial z (the monic
characteristic polynomial of A + B K on V*, what
:func:`~glocal_verify.numerics.pencil_exact.analyze_pencil_exact` returns) is the product of
the invariant factors of P, i.e. the monic gcd of its maximal minors, D_{n+m}(P). The dense
V* iteration over Q costs O(n^4) rational operations with coefficient growth (hours at
n = 200). Here z is *proved* from both sides instead.

Upper bound (modulo one prime)
    Every maximal minor of P, and every combination det(X P(s)) with X an integer matrix
    (Cauchy-Binet), is divisible by z over Z_(p)[s] (Gauss's lemma, the data's denominators
    being units modulo p). If one of them, mu, has an exactly known degree that its reduction
    keeps, the primitive gcd of all minors has a unit leading coefficient, so z mod p divides
    h_p = gcd of the reductions and deg z <= deg h_p. The exact minors used are
    mu_R(s) = det(S_R adj(sI - A) B) / det(sI - A)^(m-1) for m-subsets R of the outputs
    (rows: all states and the outputs R), from the transfer numerators over Q. The
    combinations are det([[sI - A + Y C, -B], [Z C, 0]]) for random Y, Z modulo p (output
    injection and a squaring-down), each one characteristic polynomial of an n x n matrix
    over F_p (:func:`_compression_mod_p`); they break the common factors of the mu_R that
    are not zeros (input-decoupling modes, at which every mu_R vanishes).

Lower bound (exact, over Q)
    z divides h_Q = gcd_Q(mu_R). For an irreducible factor g of h_Q, with k_g the dimension of
    ker P over the field Q[s]/(g), every invariant factor that vanishes at a root of g
    contributes at least one to ord_g(z), so ord_g(z) >= k_g. Off the poles (g coprime to
    det(sI - A)) ker P = {(adj(sI - A) B u / det(sI - A), u) : S_M adj(sI - A) B u = 0}, a
    p x m rank over Q[s]/(g); at a rational pole s0, the rank of P(s0) over Q. A verified
    A-invariant subspace W of ker C (the twin modes) lies in V*, so the characteristic
    polynomial of A on W divides z as well. Hence z_low = prod g^min(ord_g h_Q, bound_g)
    divides z, and deg z_low = deg h_p closes the proof: z = z_low.

Both bounds are exact statements; the random choices only decide whether they meet. When
they do not (unlucky choices, a Jordan chain at a zero, a zero at an irrational pole) the
function returns None and the caller runs the dense method.
"""

from __future__ import annotations

import itertools
import random
from dataclasses import dataclass
from fractions import Fraction
from typing import Any, Mapping, Sequence

import flint

from glocal_verify import config
from glocal_verify.numerics.pencil_exact import rank_over_field

__all__ = ["ZeroPolynomialProof", "left_invertible_zero_polynomial", "poly_det"]


@dataclass(frozen=True, slots=True)
class ZeroPolynomialProof:
    """The zero polynomial of a left-invertible system and what proves it.

    Attributes
    ----------
    zero_polynomial : fmpq_poly
        z(s), monic (1 when the system has no invariant zero).
    prime : int
        The prime of the upper bound.
    degree_minor : tuple of int
        The output subset R whose exact minor mu_R kept its degree modulo the prime.
    factors : tuple of (fmpq_poly, int, int)
        (g, ord_g z, the lower bound that proved it) for every irreducible factor of z.
    """

    zero_polynomial: Any
    prime: int
    degree_minor: tuple[int, ...]
    factors: tuple[tuple[Any, int, int], ...]


def poly_det(M: Sequence[Sequence[Any]]) -> Any:
    """Determinant of a square matrix of ``fmpq_poly`` by fraction-free (Bareiss) elimination.

    Every division is exact in Q[s] (Sylvester's identity), so the result is exact.

    Parameters
    ----------
    M : rows of fmpq_poly
    """
    k = len(M)
    if k == 0:
        return flint.fmpq_poly(1)
    A = [list(r) for r in M]
    sign = 1
    prev = flint.fmpq_poly(1)
    for c in range(k - 1):
        piv = next((i for i in range(c, k) if not A[i][c].is_zero()), None)
        if piv is None:
            return flint.fmpq_poly(0)
        if piv != c:
            A[c], A[piv] = A[piv], A[c]
            sign = -sign
        for i in range(c + 1, k):
            for j in range(c + 1, k):
                q, r = divmod(A[c][c] * A[i][j] - A[i][c] * A[c][j], prev)
                if not r.is_zero():  # pragma: no cover - Sylvester's identity
                    raise ArithmeticError("Bareiss division is not exact; please report")
                A[i][j] = q
        prev = A[c][c]
    return A[k - 1][k - 1] * sign


def _prime(values: Sequence[Fraction], avoid: set[int], rng: random.Random) -> int:
    """A random prime in [2^60, 2^61) dividing no denominator of ``values`` (proven prime: flint)."""
    dens = [abs(v.denominator) for v in values if v.denominator != 1]
    while True:
        q = _next_prime(rng.randrange(2**60, 2**61))
        if q not in avoid and all(d % q for d in dens):
            return q


def _next_prime(q: int) -> int:
    q |= 1
    while not flint.fmpz(q).is_prime():
        q += 2
    return q


def _mod(x: Fraction, p: int) -> int:
    return (x.numerator % p) * pow(x.denominator % p, -1, p) % p


def _poly_mod(f: Any, p: int) -> Any:
    """The reduction of an fmpq_poly modulo p (its denominators must be units)."""
    return flint.nmod_poly([_mod(Fraction(int(c.p), int(c.q)), p) for c in f.coeffs()], p)


def _compression_mod_p(n: int, A: Mapping[tuple[int, int], Fraction], F: Sequence[int], M: Sequence[int], p: int, rng: random.Random) -> Any:
    """det([[sI - A + Y C, -B], [Z C, 0]]) modulo p, up to a unit, for random Y (n x |M|), Z (m x |M|).

    Expanding along the unit columns of -B leaves the n x n pencil whose rows are those of
    s I - A + Y C outside F and the m rows Z C: E s + K0, with E the identity on the rows
    outside F. With a random shift sigma making K = K0 + sigma E invertible,
    det(E t + K) = det K det(I + t K^{-1} E) = det K * sum_j c_{n-j} (-t)^j, c the
    characteristic polynomial of K^{-1} E; then t = s - sigma.
    """
    m = len(F)
    Fset = set(F)
    rows_state = [i for i in range(n) if i not in Fset]
    pos = {i: r for r, i in enumerate(rows_state)}
    Y = [[rng.randrange(p) for _ in M] for _ in range(n)]
    Z = [[rng.randrange(p) for _ in M] for _ in range(m)]
    K0 = [0] * (n * n)
    E = [0] * (n * n)
    for (i, j), v in A.items():
        if i in pos and v != 0:
            K0[pos[i] * n + j] = (K0[pos[i] * n + j] - _mod(v, p)) % p
    for i, r in pos.items():
        E[r * n + i] = 1
        for q, col in enumerate(M):
            K0[r * n + col] = (K0[r * n + col] + Y[i][q]) % p
    for k in range(m):
        for q, col in enumerate(M):
            K0[(n - m + k) * n + col] = (K0[(n - m + k) * n + col] + Z[k][q]) % p
    Em = flint.nmod_mat(n, n, E, p)
    for _ in range(8):
        sigma = rng.randrange(p)
        K = flint.nmod_mat(n, n, [(a + sigma * e) % p for a, e in zip(K0, E)], p)
        detK = K.det()
        if int(detK) != 0:
            break
    else:  # pragma: no cover - det vanishes identically or p is tiny
        return flint.nmod_poly([0], p)
    c = [int(x) for x in (K.inv() * Em).charpoly().coeffs()]
    c += [0] * (n + 1 - len(c))
    t_poly = flint.nmod_poly([(c[n - j] * (-1) ** j) % p for j in range(n + 1)], p)
    return t_poly.compose(flint.nmod_poly([(-sigma) % p, 1], p)) * int(detK)


def _pole_rank(n: int, A: Mapping[tuple[int, int], Fraction], F: Sequence[int], M: Sequence[int], s0: Fraction) -> int:
    """rank over Q of P(s0) for a rational s0."""
    m, p = len(F), len(M)
    ent = [flint.fmpq(0)] * ((n + p) * (n + m))
    w = n + m
    for (i, j), v in A.items():
        if v != 0:
            ent[i * w + j] = -flint.fmpq(v.numerator, v.denominator)
    q0 = flint.fmpq(s0.numerator, s0.denominator)
    for i in range(n):
        ent[i * w + i] += q0
    for k, f in enumerate(F):
        ent[f * w + n + k] = flint.fmpq(-1)
    for r, j in enumerate(M):
        ent[(n + r) * w + j] = flint.fmpq(1)
    return int(flint.fmpq_mat(n + p, n + m, ent).rank())


def left_invertible_zero_polynomial(
    n: int,
    A: Mapping[tuple[int, int], Fraction],
    F: Sequence[int],
    M: Sequence[int],
    charpoly: Any,
    numerators: Sequence[Sequence[Any]],
    invariant_factor: Any | None = None,
    *,
    seed: int = 0,
) -> ZeroPolynomialProof | None:
    """Prove the zero polynomial of the selection system (A, S_F^T, S_M, 0), or return None.

    .. math::

        z(s) = \\gcd\\{\\text{maximal minors of } \\begin{bmatrix} sI - A & -S_F^\\top \\\\ S_M & 0
        \\end{bmatrix}\\} = \\det(sI - (A + BK)|_{\\mathcal V^*})

    by the two bounds of the module docstring. None means "not proved here" (not left-
    invertible by the minors tried, the bounds did not meet): never a different answer.

    Parameters
    ----------
    n : int
        States.
    A : mapping
        Nonzero entries ``{(i, j): A_ij}`` (exact).
    F : sequence of int
        The state of each input (distinct).
    M : sequence of int
        The state of each output (distinct).
    charpoly : fmpq_poly
        det(sI - A).
    numerators : rows of fmpq_poly
        adj(sI - A) S_F^T (n x m).
    invariant_factor : fmpq_poly, optional
        The characteristic polynomial of A on an exactly verified A-invariant subspace of
        ker S_M (e.g. the twin modes), which divides z.
    seed : int
        Seed of the random compressions (the result does not depend on it, only whether one
        is found).

    Returns
    -------
    ZeroPolynomialProof or None
    """
    m, p_out = len(F), len(M)
    if len(set(F)) != m or len(set(M)) != p_out or p_out < m:
        return None
    rng = random.Random(seed)
    d = charpoly
    minors: list[tuple[tuple[int, ...], Any]] = []
    for R in itertools.islice(itertools.combinations(range(p_out), m), config.get("zero_polynomial_subsets")):
        num = poly_det([[numerators[M[r]][k] for k in range(m)] for r in R])
        if num.is_zero():
            continue
        if m == 0:
            mu = d
        elif m == 1:
            mu = num
        else:
            mu, rem = divmod(num, d ** (m - 1))
            if not rem.is_zero():  # pragma: no cover - the matrix determinant lemma
                raise ArithmeticError("a maximal minor is not divisible by det(sI - A)^(m-1); please report")
        minors.append((R, mu / mu.leading_coefficient()))
    if not minors:
        return None  # no nonzero minor among those tried: left-invertibility not shown here
    h_q = minors[0][1]
    for _, mu in minors[1:]:
        h_q = h_q.gcd(mu)
    values = [v for v in A.values()] + [Fraction(int(c.p), int(c.q)) for _, mu in minors for c in mu.coeffs()]
    used: set[int] = set()
    factors = [] if h_q.degree() <= 0 else [(g / g.leading_coefficient(), int(e)) for g, e in h_q.factor()[1]]
    bounds: dict[int, int] = {}
    inv = invariant_factor if invariant_factor is not None else flint.fmpq_poly(1)
    for attempt in range(config.get("zero_polynomial_retries") + 1):
        p = _prime(values, used, rng)
        used.add(p)
        R0, mu0 = next(((R, mu) for R, mu in minors if _poly_mod(mu, p).degree() == mu.degree()), (None, None))
        if R0 is None:
            continue
        h_p = _poly_mod(mu0, p)
        for _, mu in minors:
            h_p = h_p.gcd(_poly_mod(mu, p))
        for _ in range(config.get("zero_polynomial_compressions") + attempt):
            if h_p.degree() <= 0:
                break
            c = _compression_mod_p(n, A, F, M, p, rng)
            if not c.is_zero():
                h_p = h_p.gcd(c)
        z = flint.fmpq_poly(1)
        proof: list[tuple[Any, int, int]] = []
        for idx, (g, e) in enumerate(factors):
            if any(int(c.q) % p == 0 for c in g.coeffs()) or not (h_p % _poly_mod(g, p)).is_zero():
                continue  # g mod p does not divide h_p, so g does not divide z
            if idx not in bounds:
                bounds[idx] = _factor_bound(n, A, F, M, d, numerators, inv, g)
            k = min(e, bounds[idx])
            if k > 0:
                z *= g**k
                proof.append((g, k, bounds[idx]))
        if z.degree() == h_p.degree():
            return ZeroPolynomialProof(z, p, tuple(M[r] for r in R0), tuple(proof))
    return None


def _factor_bound(n: int, A: Mapping[tuple[int, int], Fraction], F: Sequence[int], M: Sequence[int], d: Any, numerators: Sequence[Sequence[Any]], inv: Any, g: Any) -> int:
    """A proved lower bound of ord_g(z): max(dim ker P over Q[s]/(g), ord_g of the invariant factor)."""
    m = len(F)
    t = 0
    q = inv
    while q.degree() > 0 and (q % g).is_zero():
        q = q // g
        t += 1
    if not (d % g).is_zero():
        rows = [[numerators[r][k] % g for k in range(m)] for r in M]
        return max(t, m - (rank_over_field(rows, g, m) if rows and m else 0))
    if g.degree() == 1:
        c = g.coeffs()
        s0 = -Fraction(int(c[0].p), int(c[0].q)) / Fraction(int(c[1].p), int(c[1].q))
        return max(t, n + m - _pole_rank(n, A, F, M, s0))
    return t
