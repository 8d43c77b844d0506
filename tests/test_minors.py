"""The modular maximal-minor certificate proves full column rank only when it is true.

The reference is exact: every maximal minor of T(s) = [(sI + alpha L)[V \\ I, U]] (U = V \\ M)
interpolated over Q from exact determinants at deg + 1 integer points, and the gcd of all of
them over Q. A certificate must never be issued when that gcd has a root (or all minors vanish).
"""

from __future__ import annotations

import itertools
import random
from fractions import Fraction

import flint
import pytest

from glocal_verify.numerics.minors import (
    constant_full_rank_mod_p,
    residues_mod_p,
    submatrix_full_rank_mod_p,
    full_rank_certificate,
    grounded_tables,
)


def _laplacian(n: int, edges: dict[tuple[int, int], Fraction]) -> dict[tuple[int, int], Fraction]:
    L: dict[tuple[int, int], Fraction] = {}
    for (i, j), w in edges.items():
        L[(i, j)] = L.get((i, j), Fraction(0)) - w
        L[(j, i)] = L.get((j, i), Fraction(0)) - w
        L[(i, i)] = L.get((i, i), Fraction(0)) + w
        L[(j, j)] = L.get((j, j), Fraction(0)) + w
    return L


def _q(x: Fraction) -> flint.fmpq:
    return flint.fmpq(x.numerator, x.denominator)


def _maximal_minors(n: int, L: dict[tuple[int, int], Fraction], alpha: Fraction, M: list[int], inputs: list[int]) -> list[flint.fmpq_poly]:
    """Every nonzero maximal minor of T(s), interpolated over Q from exact determinants."""
    rows = [i for i in range(n) if i not in inputs]
    cols = [j for j in range(n) if j not in M]
    pts = list(range(len(cols) + 1))
    out = []
    for R in itertools.combinations(rows, len(cols)):
        vals = []
        for s in pts:
            ent = [_q((Fraction(s) if (i == j) else Fraction(0)) + alpha * L.get((i, j), Fraction(0))) for i in R for j in cols]
            vals.append(flint.fmpq_mat(len(cols), len(cols), ent).det())
        P = flint.fmpq_poly([0])
        for a, va in zip(pts, vals):  # Lagrange interpolation over Q
            term = flint.fmpq_poly([va])
            for b in pts:
                if b != a:
                    term *= flint.fmpq_poly([-b, 1]) / (a - b)
            P += term
        if P != 0:
            out.append(P)
    return out


def _gcd(polys: list[flint.fmpq_poly]) -> flint.fmpq_poly | None:
    g = None
    for P in polys:
        g = P if g is None else g.gcd(P)
    return g


def _exact_full_rank_everywhere(n: int, L: dict[tuple[int, int], Fraction], alpha: Fraction, M: list[int], inputs: list[int]) -> bool:
    """gcd over Q of all maximal minors of T(s) is a nonzero constant."""
    if n - len(inputs) < n - len(M):
        return False
    if len(M) == n:
        return True
    g = _gcd(_maximal_minors(n, L, alpha, M, inputs))
    return g is not None and g.degree() == 0


def _random_case(rng: random.Random) -> tuple[int, dict[tuple[int, int], Fraction], Fraction, list[int]]:
    n = rng.randint(4, 8)
    edges: dict[tuple[int, int], Fraction] = {}
    for i in range(1, n):  # a random tree keeps the graph connected, then extra links
        edges[(rng.randrange(i), i)] = Fraction(rng.randint(1, 4), rng.randint(1, 2))
    for i, j in itertools.combinations(range(n), 2):
        if (i, j) not in edges and rng.random() < 0.25:
            edges[(i, j)] = Fraction(rng.choice([1, 1, 2, 3]))
    M = sorted(rng.sample(range(n), rng.randint(1, 3)))
    return n, _laplacian(n, edges), Fraction(rng.choice([1, 2, 3]), rng.choice([1, 2])), M


def test_every_certificate_on_random_small_networks_is_confirmed_by_exact_minors() -> None:
    rng = random.Random(7)
    issued = 0
    for _ in range(40):
        n, L, alpha, M = _random_case(rng)
        t = grounded_tables(n, L, alpha, M)
        assert t is not None
        cache: dict[object, object] = {}
        for k in (1, 2):
            for F in itertools.combinations(range(n), k):
                cert = full_rank_certificate(t, list(F), cache)
                if cert is not None:
                    issued += 1
                    assert _exact_full_rank_everywhere(n, L, alpha, M, list(F)), (n, M, F, cert)
    assert issued > 20  # the certificate is not vacuous


def test_symmetric_twins_get_no_certificate() -> None:
    # agents 1 and 2 hang identically on 0; the monitor at 3 cannot tell them apart: with
    # inputs {1} and {2} ... the antisymmetric mode e1 - e2 is unobservable, so T(s) loses rank
    n = 4
    L = _laplacian(n, {(0, 1): Fraction(1), (0, 2): Fraction(1), (0, 3): Fraction(1)})
    t = grounded_tables(n, L, Fraction(1), [3])
    assert t is not None
    assert not _exact_full_rank_everywhere(n, L, Fraction(1), [3], [0])
    assert full_rank_certificate(t, [0], {}) is None


def test_an_input_listed_twice_is_never_certified() -> None:
    n = 3
    L = _laplacian(n, {(0, 1): Fraction(1), (1, 2): Fraction(1)})
    t = grounded_tables(n, L, Fraction(1), [0, 2])
    assert t is not None
    assert full_rank_certificate(t, [1, 1], {}) is None


@pytest.mark.parametrize("rows, full", [([[1, 2], [2, 4]], False), ([[1, 2], [3, 4], [5, 6]], True), ([[Fraction(1, 3), 1], [1, 3]], False)])
def test_the_constant_rank_test_proves_only_full_column_rank(rows: list[list[object]], full: bool) -> None:
    assert constant_full_rank_mod_p([[Fraction(x) for x in r] for r in rows]) is full


def test_a_submatrix_rank_from_stored_residues_is_the_rank_of_that_submatrix_over_q() -> None:
    import itertools

    import sympy

    rng = random.Random(5)
    A = [[Fraction(rng.randint(-3, 3), rng.randint(1, 3)) if rng.random() < 0.6 else Fraction(0) for _ in range(5)] for _ in range(6)]
    p = 1_000_003
    res = residues_mod_p(A, p)
    for r in range(0, 7):
        for rows in itertools.combinations(range(6), r):
            for cols in itertools.combinations(range(5), min(r, 3)):
                sub = [[A[i][j] for j in cols] for i in rows]
                full = bool(rows) and (not cols or sympy.Matrix(sub).rank() == len(cols))
                got = submatrix_full_rank_mod_p(res, list(rows), list(cols), p)
                # modulo p the rank can only drop: a proof of full rank is never wrong, and
                # for this small matrix p is large enough for the ranks to agree
                assert got == full
                assert got == (constant_full_rank_mod_p(sub, p) if rows else False)


def _exact_gcd_and_kernel(n: int, L: dict[tuple[int, int], Fraction], alpha: Fraction, M: list[int], inputs: list[int]) -> tuple[object, object]:
    rows = [i for i in range(n) if i not in inputs]
    cols = [j for j in range(n) if j not in M]

    def kernel_dim(s0: Fraction) -> int:
        ent = [_q((s0 if (i == j) else Fraction(0)) + alpha * L.get((i, j), Fraction(0))) for i in rows for j in cols]
        return len(cols) - flint.fmpq_mat(len(rows), len(cols), ent).rank()

    return _gcd(_maximal_minors(n, L, alpha, M, inputs)), kernel_dim


@pytest.mark.slow
def test_a_certificate_modulo_twin_modes_leaves_only_twin_modes_in_the_kernel() -> None:
    from glocal_verify.numerics.symmetry import twin_modes

    rng = random.Random(11)
    issued = 0
    for _ in range(30):
        n, L0, alpha, M = _random_case(rng)
        # two twin leaves on a random agent (exact eigenvector e_a - e_b of L)
        hub, w = rng.randrange(n), Fraction(rng.randint(1, 3))
        edges = {(i, j): -v for (i, j), v in L0.items() if i < j}
        edges[(hub, n)] = w
        edges[(hub, n + 1)] = w
        n += 2
        L = _laplacian(n, edges)
        tw = twin_modes(n, L, M)
        assert tw and all(mu == w for mu, _ in tw)
        t = grounded_tables(n, L, alpha, M)
        assert t is not None
        for F in itertools.chain(itertools.combinations(range(n), 1), itertools.combinations(range(n - 2), 2)):
            cert = full_rank_certificate(t, list(F), {}, modulo_twins=True)
            if cert is None:
                continue
            issued += 1
            g, kernel_dim = _exact_gcd_and_kernel(n, L, alpha, M, list(F))
            assert g is not None
            s0 = -alpha * w
            # every common root of the maximal minors is the twin root, where the kernel is the twin span
            rest = g
            while rest.degree() > 0 and rest(flint.fmpq(s0.numerator, s0.denominator)) == 0:
                rest = rest / flint.fmpq_poly([-flint.fmpq(s0.numerator, s0.denominator), 1])
            assert rest.degree() == 0, (n, M, F, g)
            assert kernel_dim(s0) == sum(len(p) for _, p in tw)
    assert issued > 10


def test_an_invariant_subspace_is_accepted_only_when_exactly_invariant_and_zero_on_the_outputs() -> None:
    from glocal_verify.numerics.minors import verified_invariant_subspace

    # star with centre 0 and leaves 1, 2, 3 (equal weights): e1 - e2 and e2 - e3 span an eigenspace
    L = _laplacian(4, {(0, 1): Fraction(1), (0, 2): Fraction(1), (0, 3): Fraction(1)})
    good = [[Fraction(0), Fraction(1), Fraction(-1), Fraction(0)], [Fraction(0), Fraction(0), Fraction(1), Fraction(-1)]]
    ver = verified_invariant_subspace(4, L, [0], good)
    assert ver is not None
    W, B = ver
    for w, b in zip(W, B):
        Lw = [sum((L.get((i, j), Fraction(0)) * w[j] for j in range(4)), Fraction(0)) for i in range(4)]
        assert Lw == [sum((b[t] * W[t][i] for t in range(len(W))), Fraction(0)) for i in range(4)]
    assert verified_invariant_subspace(4, L, [1], good) is None  # not zero on the output 1
    assert verified_invariant_subspace(4, L, [0], [[Fraction(0), Fraction(1), Fraction(0), Fraction(0)]]) is None  # e1 is not invariant


def _laplace_det(rows: list[list[object]]) -> object:
    if len(rows) == 1:
        return rows[0][0]
    total = None
    for c in range(len(rows)):
        term = rows[0][c] * _laplace_det([r[:c] + r[c + 1 :] for r in rows[1:]])  # type: ignore[operator]
        total = term if total is None else (total + term if c % 2 == 0 else total - term)
    return total


def test_the_random_combination_of_minors_is_the_determinant_of_the_fully_combined_rows() -> None:
    # reference: A_r = sum_q c_rq N_q over the integers, its rows I' and e A_r (e zero on I'),
    # reduced modulo p only at the end: the certificate's shortcut (e_all N_q per output row,
    # minus the rows of I') must give the same polynomial
    import numpy as np

    from glocal_verify.numerics.minors import _random_combination

    rng = random.Random(11)
    checked = 0
    for _ in range(12):
        n, L, alpha, M = _random_case(rng)
        t = grounded_tables(n, L, alpha, M)
        assert t is not None
        p, G = t.prime, len(t.grounded)
        Mp = list(range(len(t.measured)))
        for Ip in ([0], [G - 1], [0, G - 1]):
            if len(set(Ip)) < len(Ip) or len(Ip) >= G:
                continue
            for trial in (0, 1):
                k = len(Ip)
                g = np.random.default_rng((trial, p, len(Mp), k))
                cs = [g.integers(1, p, len(Mp)).tolist() for _ in range(k + 1)]
                e = g.integers(1, p, G).tolist()
                for x in Ip:
                    e[x] = 0
                entries = []
                for c in cs:
                    A = [[sum(cq * int(t.numerators[q][x][d]) for cq, q in zip(c, Mp)) for d in range(t.numerators.shape[2])] for x in range(G)]
                    comb = [sum(e[j] * A[j][d] for j in range(G)) % p for d in range(len(A[0]))]
                    entries.append([flint.nmod_poly([v % p for v in A[x]], p) for x in Ip] + [flint.nmod_poly(comb, p)])
                ref = _laplace_det(entries)
                assert _random_combination(t, {}, Ip, Mp, trial) == ref
                checked += 1
    assert checked > 30
