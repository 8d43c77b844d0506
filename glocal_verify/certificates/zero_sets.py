"""The zero set of the ZDA pencil, certified (kind ``zero-set``): where the N-sized pencil in
s = lambda^2 + gamma lambda loses column rank, with the kernel there.

For lambda != 0 a kernel vector of the Rosenbrock pencil of (A_1, S_F^T, C) is [xi; lambda xi;
u] with xi zero on M = M_x u M_v and (s I + alpha L_1) xi = S_F^T u, so the pencil loses column
rank exactly where

    T(s) = (s I + alpha L_1)[V \\ F, U],   U = V \\ M,

does (u = ((s I + alpha L_1) xi)[F] follows from xi). Its zero polynomial z (the gcd of its
maximal minors) is found here as (i) the gcd modulo a prime p of a few maximal minors, the
first of the degree its rows allow (so deg z is at most that gcd's degree), (ii) z over Q by
the same gcd modulo more primes (Chinese remainders and rational reconstruction), factored over
Q, and (iii) for each irreducible factor g of z of multiplicity e, e independent kernel vectors
of T over Q[s]/(g) (the regular representation: a rational system d times the size). The
checker closes the count (``glocal_check.zda.zero_set``); nothing here is trusted.

Used by ``stealthy.zda`` (no ZDA: every kernel vector has u = 0; a ZDA at an irrational
exponent: a kernel vector with u prime to g) and ``switching.avoids-attack`` at a computed
lambda0 = 0 (every other zero decays, so 0 is the fastest-growing zero).
"""

from __future__ import annotations

from fractions import Fraction
from typing import Any, Sequence

import numpy as np
from flint import fmpq, fmpq_mat, fmpq_poly, nmod_mat, nmod_poly

from glocal_verify import config
from glocal_verify.certificates.encode import mod_residues, pivots_mod, q, system_prime, vector
from glocal_verify.certificates.kernels import fq, kernel_vectors, laplacian_rows, regular_rows
from glocal_verify.derived import Kind
from glocal_verify.model import System
from glocal_verify.numerics.minors import prime_for

__all__ = ["NoZeroSet", "Pencil", "zda_pencil", "zda_zero_set", "zero_set", "zero_with_kernel"]


class NoZeroSet(Exception):
    """The zero set could not be certified; the message says why."""


def _newton(xs: Sequence[int], ys: Sequence[int], p: int) -> nmod_poly:
    """The polynomial of degree < len(xs) through the points modulo p (divided differences)."""
    c = list(ys)
    for j in range(1, len(xs)):
        for i in range(len(xs) - 1, j - 1, -1):
            c[i] = (c[i] - c[i - 1]) * pow(xs[i] - xs[i - j], -1, p) % p
    out = nmod_poly([c[-1]], p)
    for i in range(len(xs) - 2, -1, -1):
        out = out * nmod_poly([-xs[i] % p, 1], p) + c[i]
    return out


class Pencil:
    """T(s) = (s I + K)[rows, U] over Q (K sparse rows ``{column: entry}`` by agent index): its
    minors modulo primes and its kernels. The ZDA pencil (rows V \\ F, U = V \\ M, K = alpha L_1)
    and the local pencil of a cluster (rows P \\ I, U the unmeasured agents of P, K = alpha
    L[P, P]) are both of this form."""

    def __init__(self, rows: Sequence[int], U: Sequence[int], K: Sequence[dict[int, fmpq]] | dict[int, dict[int, fmpq]]) -> None:
        self.rows, self.U, self.K = list(rows), list(U), K

    def minor(self, rows: Sequence[int], p: int) -> nmod_poly:
        """det T(s)[rows, U] modulo p (evaluated at 0..d, d the positions of s, and interpolated)."""
        K, J = self.residues(rows, p)
        xs = list(range(sum(1 for a in rows if a in set(self.U)) + 1))
        return _newton(xs, [int((K + J * x).det()) for x in xs], p) if rows else nmod_poly([1], p)

    def _at(self, rows: Sequence[int], x: int, p: int) -> int:
        """det T(x)[rows, U] modulo p at one point (a cheap test that a minor is not 0)."""
        K, J = self.residues(rows, p)
        return int((K + J * x).det())

    def anchor(self, p: int) -> list[int]:
        """Every row in U, and as many other rows as U has columns without a row of their own,
        chosen so that the minor has the largest degree modulo p found (the checker proves that
        degree exact over Q)."""
        Us = set(self.U)
        inner = [a for a in self.rows if a in Us]
        m = len(self.U) - len(inner)
        others = [a for a in self.rows if a not in Us]
        if m > 6 or m > len(others):
            raise NoZeroSet(f"{m} unmeasured columns without a row of their own (at most 6 are certified)")
        rng = np.random.default_rng(51)
        best, best_deg, full = None, -1, 0
        for k in range(config.get("certificate_minor_tries")):
            R = sorted(inner + (others[:m] if k == 0 else [others[i] for i in rng.choice(len(others), m, replace=False)]))
            if full >= 4 or not self._at(R, int(rng.integers(1, p)), p):
                continue
            full += 1
            d = self.minor(R, p).degree()
            if d > best_deg:
                best, best_deg = R, d
            if best_deg == len(inner):
                break
        if best is None:
            raise NoZeroSet("every minor of T(s) tried vanishes modulo the prime")
        return best

    def residues(self, rows: Sequence[int], p: int) -> tuple[nmod_mat, nmod_mat]:
        """(K[rows, U], J[rows, U]) modulo p, J the positions of s."""
        col = {c: j for j, c in enumerate(self.U)}
        K = nmod_mat(len(rows), len(self.U), [0] * (len(rows) * len(self.U)), p)
        J = nmod_mat(len(rows), len(self.U), [0] * (len(rows) * len(self.U)), p)
        for i, a in enumerate(rows):
            for j, v in self.K[a].items():
                if j in col:
                    K[i, col[j]] = mod_residues([v], p)[0]
            if a in col:
                J[i, col[a]] = 1
        return K, J

    def combination(self, extra: Sequence[int], Y: Sequence[Sequence[int]], p: int) -> nmod_poly:
        """det(T[B] + Y T[E]) modulo p (E = ``extra``, B the other rows): by Cauchy-Binet a
        combination of every maximal minor of T, so z mod p divides it."""
        E = set(extra)
        B = [a for a in self.rows if a not in E]
        KB, JB = self.residues(B, p)
        KE, JE = self.residues(list(extra), p)
        Ym = nmod_mat(len(B), len(extra), [int(x) for r in Y for x in r], p)
        A0, A1 = KB + Ym * KE, JB + Ym * JE
        xs = list(range(len(self.U) + 1))
        return _newton(xs, [int((A0 + A1 * x).det()) for x in xs], p)

    def gcd_mod(self, p: int, patience: int = 2) -> tuple[nmod_poly, list[int], list[tuple[list[int], list[list[int]]]]]:
        """The gcd modulo p of the anchor's minor and of random combinations of all maximal
        minors (:meth:`combination`), stopping when ``patience`` in a row do not lower it; with
        the anchor and the combinations that lowered it."""
        first = self.anchor(p)
        g = self.minor(first, p)
        used: list[tuple[list[int], list[list[int]]]] = []
        idle = 0
        rng = np.random.default_rng(52)
        extra = [self.rows[i] for i in sorted(rng.choice(len(self.rows), len(self.rows) - len(self.U), replace=False))]
        for _ in range(4 + patience):
            if g.degree() <= 0 or idle >= patience:
                break
            Y = [[int(x) for x in rng.integers(1, p, len(extra))] for _ in range(len(self.U))]
            h = g.gcd(self.combination(extra, Y, p))
            if h.degree() < g.degree():
                g, idle = h, 0
                used.append((extra, Y))
            else:
                idle += 1
        return g, first, used

    def kernel(self, g: fmpq_poly, count: int, p: int) -> list[list[fmpq_poly]]:
        """``count`` vectors over Q[s]/(g) in the kernel of T (supported on U), independent over
        that field (g irreducible): the rational kernel at a rational root, else (one vector)
        the maximal minors of |U| - 1 rows (:meth:`_minors_kernel`) or, when those rows lose
        rank at the roots of g, the rational kernel of the regular representation
        (:meth:`_regular_kernel`, d |U| unknowns, at most
        ``config.get("certificate_field_unknowns")``)."""
        if g.degree() == 1:
            return self._regular_kernel(g, count, p)
        if count != 1:
            raise NoZeroSet(f"a factor of degree {g.degree()} with {count} kernel vectors (one is certified)")
        try:
            return [self._minors_kernel(g, p)]
        except NoZeroSet:
            if g.degree() * len(self.U) > config.get("certificate_field_unknowns"):
                raise
        return self._regular_kernel(g, 1, p)

    def _minors_kernel(self, g: fmpq_poly, p: int) -> list[fmpq_poly]:
        """A kernel vector of T over Q[s]/(g) when its kernel there is a line: for rows R' of
        size |U| - 1 with rank |U| - 1 at the roots of g, m_i = (-1)^i det T[R', U \\ i] is
        in the kernel of T[R'] identically and nonzero at the roots, so it spans ker T there.
        Computed at |U| points (m = (-1)^j det B n, B = T[R', U \\ j], n the kernel vector
        with n_j = 1) and interpolated; kept when T m = 0 modulo g."""
        base = self.anchor(p)
        k = len(self.U)
        rng = np.random.default_rng(53)
        for drop in [base[i] for i in rng.permutation(len(base))[:6]]:
            Rp = [a for a in base if a != drop]
            for j in (k - 1, 0):
                pts: list[int] = []
                vals: list[list[fmpq]] = []
                x = 0
                while len(pts) < k and x < 3 * k + 3:
                    A = self.dense(Rp, x)
                    B = fmpq_mat(k - 1, k - 1, [A[i][c] for i in range(k - 1) for c in range(k) if c != j])
                    det = B.det()
                    if det != 0:
                        b = fmpq_mat(k - 1, 1, [-A[i][j] for i in range(k - 1)])
                        w = B.solve(b)
                        n = [w[c if c < j else c - 1, 0] if c != j else fmpq(1) for c in range(k)]
                        pts.append(x)
                        vals.append([(-1) ** j * det * y for y in n])
                    x += 1
                if len(pts) < k:
                    continue
                m = [_interpolate_q(pts, [v[i] for v in vals]) % g for i in range(k)]
                if all(y == 0 for y in m):
                    continue
                if all((z % g) == 0 for z in self.apply(m)):
                    return m
        raise NoZeroSet(f"no kernel vector of T(s) found over Q[s]/(g), g of degree {g.degree()}")

    def dense(self, rows: Sequence[int], x: int) -> list[list[fmpq]]:
        """T(x)[rows, U] over Q."""
        out = []
        for a in rows:
            r = [self.K[a].get(c, fmpq(0)) for c in self.U]
            if a in self.U:
                r[self.U.index(a)] += x
            out.append(r)
        return out

    def apply(self, v: Sequence[fmpq_poly]) -> list[fmpq_poly]:
        """T(s) v over Q[s] (v indexed like U), every row."""
        col = {c: j for j, c in enumerate(self.U)}
        s = fmpq_poly([0, 1])
        out = []
        for a in self.rows:
            acc = s * v[col[a]] if a in col else fmpq_poly(0)
            for j, x in self.K[a].items():
                if j in col and v[col[j]] != 0:
                    acc += x * v[col[j]]
            out.append(acc)
        return out

    def _regular_kernel(self, g: fmpq_poly, count: int, p: int) -> list[list[fmpq_poly]]:
        """The kernel over Q[s]/(g) from the rational kernel of the regular representation."""
        d = g.degree()
        col = {a: k for k, a in enumerate(self.U)}
        T = [{col[j]: x for j, x in self.K[a].items() if j in col} for a in self.rows]
        rows = regular_rows(T, [col.get(a) for a in self.rows], g)
        basis = kernel_vectors(rows, d * len(self.U), p)
        out: list[list[fmpq_poly]] = []
        span: list[list[fmpq]] = []
        for z in basis:
            if len(out) == count:
                break
            v = [fmpq_poly([z[k * d + i] for i in range(d)]) for k in range(len(self.U))]
            trial = span + [_flat(w, d) for w in _field_span(v, g)]
            if fmpq_mat(len(trial), len(trial[0]), [x for r in trial for x in r]).rank() == len(trial):
                span = trial  # v is independent over Q[s]/(g) of the vectors kept
                out.append(v)
        if len(out) < count:
            raise _Short(f"{len(out)} kernel vectors over Q[s]/({g}) for a factor of multiplicity {count} in the gcd of the minors tried")
        return out


def _flat(v: Sequence[fmpq_poly], d: int) -> list[fmpq]:
    out = []
    for x in v:
        cs = x.coeffs()
        out += [cs[i] if i < len(cs) else fmpq(0) for i in range(d)]
    return out


def _field_span(v: Sequence[fmpq_poly], g: fmpq_poly) -> list[list[fmpq_poly]]:
    """v, s v, .., s^(d-1) v modulo g: a Q-basis of the line Q[s]/(g) v."""
    out, w = [], list(v)
    for _ in range(g.degree()):
        out.append(w)
        w = [(x * fmpq_poly([0, 1])) % g for x in w]
    return out


def _interpolate_q(xs: Sequence[int], ys: Sequence[fmpq]) -> fmpq_poly:
    """The polynomial of degree < len(xs) through the points over Q (divided differences)."""
    c = list(ys)
    for j in range(1, len(xs)):
        for i in range(len(xs) - 1, j - 1, -1):
            c[i] = (c[i] - c[i - 1]) / (xs[i] - xs[i - j])
    out = fmpq_poly([c[-1]])
    for i in range(len(xs) - 2, -1, -1):
        out = out * fmpq_poly([-xs[i], 1]) + c[i]
    return out


def _reconstruct(residues: Sequence[int], modulus: int) -> Fraction | None:
    """The rational a/b with |a|, b < sqrt(modulus / 2) congruent to ``residues``' value, or None."""
    r0, r1 = modulus, residues[0] % modulus
    s0, s1 = 0, 1
    bound = int((modulus // 2) ** 0.5)
    while r1 > bound:
        k = r0 // r1
        r0, r1 = r1, r0 - k * r1
        s0, s1 = s1, s0 - k * s1
    if s1 == 0 or abs(s1) > bound:
        return None
    return Fraction(r1, s1)


class _Lift:
    """Chinese remainders of the monic reductions of one rational polynomial, and its rational
    reconstruction (coefficients a/b with |a|, b below the square root of half the modulus)."""

    def __init__(self, degree: int) -> None:
        self.acc, self.modulus = [0] * (degree + 1), 1

    def add(self, f: nmod_poly, p: int) -> fmpq_poly | None:
        cs = [int(c) for c in f.coeffs()]
        inv = pow(cs[-1], -1, p)
        for i, c in enumerate(cs):
            t = (c * inv - self.acc[i]) * pow(self.modulus, -1, p) % p
            self.acc[i] += self.modulus * t
        self.modulus *= p
        got = [_reconstruct([a], self.modulus) for a in self.acc]
        if any(x is None for x in got):
            return None
        return fmpq_poly([fmpq(x.numerator, x.denominator) for x in got])  # type: ignore[union-attr]


def zda_pencil(system: System) -> Pencil:
    """T(s) = (s I + alpha L_1)[V \\ F, V \\ M] of the system's attack."""
    F = set(system.idx(system.attacked))
    M = set(system.idx(system.monitored))
    alpha = fq(system.alpha_q)
    K = [{j: alpha * x for j, x in row.items()} for row in laplacian_rows(system, "normal")]
    return Pencil([a for a in range(system.n) if a not in F], [a for a in range(system.n) if a not in M], K)


def zero_set(system: System, pencil: Pencil) -> tuple[dict[str, Any], list[tuple[fmpq_poly, list[list[fmpq_poly]]]]]:
    """The ``zero-set`` certificate of ``pencil`` (the minors modulo p, and per irreducible
    factor g of its zero polynomial over Q the kernel vectors over Q[s]/(g)), and its factors
    (g, kernel vectors on U); raises :class:`NoZeroSet`. A count that does not close (the
    minors tried share a factor that is not a zero) is retried with more minors."""
    if len(pencil.rows) < len(pencil.U):
        raise NoZeroSet("fewer rows than unmeasured agents: T(s) never has full column rank")
    for patience in (2, 6):
        try:
            return _zero_set(system, pencil, patience)
        except _Short as exc:
            why = str(exc)
    raise NoZeroSet(why)


class _Short(NoZeroSet):
    """Fewer kernel vectors than the gcd of the minors tried counts."""


def zero_with_kernel(system: System, pencil: Pencil) -> tuple[fmpq_poly, list[fmpq_poly]]:
    """An irreducible factor g of the zero polynomial of the minors tried and a kernel vector of
    T over Q[s]/(g) (supported on U), the factors of lowest degree first; raises
    :class:`NoZeroSet`.

    The count of :func:`zero_set` is not closed: one kernel vector shows that T loses column
    rank at the roots of g, which is all a failing ``local.pencil`` needs (a zero set that
    cannot be closed, e.g. a factor of multiplicity 2 with one kernel vector, still has it).
    """
    p = system_prime(system)
    _, z = _zero_polynomial(system, pencil, 6)
    if z is None:
        raise NoZeroSet("the minors tried are coprime modulo the prime: T(s) has no zero")
    for g, _ in sorted(z.factor()[1], key=lambda f: f[0].degree()):
        g = g / g.leading_coefficient()
        try:
            return g, pencil.kernel(g, 1, p)[0]
        except NoZeroSet:
            continue
    raise NoZeroSet("no factor of the zero polynomial of the minors tried has a kernel vector")


def _zero_set(system: System, pencil: Pencil, patience: int) -> tuple[dict[str, Any], list[tuple[fmpq_poly, list[list[fmpq_poly]]]]]:
    cert, z = _zero_polynomial(system, pencil, patience)
    if z is None:
        return cert, []
    p, labels = cert["prime"], system.labels
    factors: list[tuple[fmpq_poly, list[list[fmpq_poly]]]] = []
    for g, e in z.factor()[1]:
        g = g / g.leading_coefficient()
        vecs = pencil.kernel(g, int(e), p)
        factors.append((g, vecs))
        cert["factors"].append({
            "field": {"modulus": [q(c) for c in g.coeffs()]},
            "kernel": [vector(system, {labels[a]: x for a, x in zip(pencil.U, v)}) for v in vecs],
            "rows": [str(labels[a]) for a in _independent_rows(pencil, vecs, g, p)],
        })
    return cert, factors


def _zero_polynomial(system: System, pencil: Pencil, patience: int) -> tuple[dict[str, Any], fmpq_poly | None]:
    """The ``zero-set`` certificate without its factors, and the zero polynomial of the minors
    tried over Q (None when they are coprime modulo the prime)."""
    p = system_prime(system)
    g_p, first, used = pencil.gcd_mod(p, patience)
    labels = system.labels
    cert: dict[str, Any] = {
        "prime": p,
        "minors": [{"rows": [str(labels[a]) for a in first], "degree": int(pencil.minor(first, p).degree())}],
        "combinations": [{"extra": [str(labels[a]) for a in E], "Y": Y, "det": [int(c) for c in pencil.combination(E, Y, p).coeffs()]} for E, Y in used],
        "factors": [],
    }
    if g_p.degree() == 0:
        return cert, None
    # z over Q: the same gcd modulo more primes, lifted (the checker needs only the factors)
    values = [system.alpha_q] + list(system.edges("normal").values())
    lift = _Lift(g_p.degree())
    z, q_ = lift.add(g_p, p), p
    for _ in range(config.get("certificate_lift_primes")):
        q_ = prime_for(values, q_ - 1)
        h = pencil.minor(first, q_)
        for E, Y in used:
            h = h.gcd(pencil.combination(E, Y, q_))  # Y read modulo q_: another combination, still a multiple of z
        if h.degree() != g_p.degree():
            continue
        cand = lift.add(h, q_)
        if cand is not None and cand == z:
            break
        z = cand
    if z is None:
        raise NoZeroSet(f"the zero polynomial (degree {g_p.degree()} modulo {p}) could not be lifted to Q")
    return cert, z


def _independent_rows(zs: Pencil, vecs: Sequence[Sequence[fmpq_poly]], g: fmpq_poly, p: int) -> list[int]:
    """Agents where the k vectors have a k x k minor prime to g (pivots modulo p at the root
    when g is linear; an entry prime to g when k = 1)."""
    k = len(vecs)
    if g.degree() == 1:
        root = -g.coeffs()[0] / g.coeffs()[1]
        vals = [[v[i](root) for v in vecs] for i in range(len(zs.U))]
        res = [mod_residues(r, p) for r in vals]
        R, _ = pivots_mod(res, k, p)
        if len(R) < k:
            raise NoZeroSet("the kernel vectors are not independent modulo the prime")
        return [zs.U[i] for i in R]
    if k != 1:
        raise NoZeroSet(f"{k} kernel vectors over a field of degree {g.degree()} (one is certified)")
    i = next((i for i, x in enumerate(vecs[0]) if x != 0 and g.gcd(x).degree() == 0), None)
    if i is None:
        raise NoZeroSet("the kernel vector has no entry prime to its modulus")
    return [zs.U[i]]


_ZDA_ZERO_SET: Kind[tuple[dict[str, Any], list[tuple[fmpq_poly, list[list[fmpq_poly]]]]] | str] = Kind("certificate-zda-zero-set", __name__, "certificate and factors, or why none")


def zda_zero_set(system: System) -> tuple[dict[str, Any], list[tuple[fmpq_poly, list[list[fmpq_poly]]]]]:
    """:func:`zero_set` of the attack's ZDA pencil (:func:`zda_pencil`), kept on the system
    (every safe mode's certificate shares it); raises :class:`NoZeroSet`."""

    def build() -> tuple[dict[str, Any], list[tuple[fmpq_poly, list[list[fmpq_poly]]]]] | str:
        most = config.get("certificate_dense_max_agents")
        if system.n > most:
            return f"more than {most} agents (the zero set of the ZDA pencil is not certified)"
        try:
            return zero_set(system, zda_pencil(system))
        except NoZeroSet as exc:
            return str(exc)

    got = _ZDA_ZERO_SET.get(system, (), build)
    if isinstance(got, str):
        raise NoZeroSet(got)
    return got
