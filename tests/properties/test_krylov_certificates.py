"""The Krylov-degree certificates of Theorem III.3 (ii) and (iii) against exact arithmetic.

A Krylov degree found modulo a prime is a lower bound on the Krylov dimension over Q (for every
prime and every projection vector), so a ``holds`` it proves must be the exact answer; on
generic graphs it succeeds, and it never claims a pair that a twin or a symmetry spoils.
"""

from __future__ import annotations

from fractions import Fraction
from typing import Any

import flint
from hypothesis import assume, example, given, settings
from hypothesis import strategies as st

from glocal_verify import System, config, loads_spec
from glocal_verify.analysis.switching.eigenstructure import distinct_eigenvalues_verdict, eigenvector_differences_verdict
from glocal_verify.analysis.laplacian.twins import distinct_eigenvalues_modular, eigenvector_differences_modular, laplacian_entries
from glocal_verify.numerics.krylov import krylov_degree_mod, krylov_rank_mod
from glocal_verify.results import Status
from tests.strategies import graphs


def _krylov_rank_over_q(n: int, entries: dict[tuple[int, int], Fraction], b: list[int]) -> int:
    A = flint.fmpq_mat(n, n)
    for (i, j), v in entries.items():
        A[i, j] = flint.fmpq(v.numerator, v.denominator)
    cols = [flint.fmpq_mat(n, 1, [flint.fmpq(x) for x in b])]
    for _ in range(n - 1):
        cols.append(A * cols[-1])
    K = flint.fmpq_mat(n, n, [cols[c][r, 0] for r in range(n) for c in range(n)])
    return int(K.rank())


def _system(n: int, edges: list[list[Any]], add: tuple[int, int]) -> System:
    text = f'format = 1\nname = "g"\n[graph]\nnodes = {n}\nedges = {edges!r}\n[[modes]]\nname = "s"\nadd = [[{add[0]}, {add[1]}]]\n[monitor]\nvelocities = [1]\n'
    return System(loads_spec(text.replace("'", '"')))


@settings(max_examples=40, deadline=None)
@given(
    st.integers(2, 9).flatmap(lambda n: st.tuples(st.just(n), st.lists(st.tuples(st.integers(0, n - 1), st.integers(0, n - 1), st.integers(-3, 3)), max_size=3 * n), st.lists(st.integers(-2, 2), min_size=n, max_size=n))),
    st.integers(0, 3),
)
def test_a_krylov_degree_modulo_a_prime_never_exceeds_the_rank_over_q(case: tuple[int, list[tuple[int, int, int]], list[int]], seed: int) -> None:
    n, raw, b = case
    entries: dict[tuple[int, int], Fraction] = {}
    for i, j, v in raw:
        if v:
            entries[(i, j)] = Fraction(v, 1 + (i + j) % 3)
    kd = krylov_degree_mod(n, entries, {i: x for i, x in enumerate(b) if x}, n, seed=seed)
    assert kd.degree <= _krylov_rank_over_q(n, entries, b)


def test_a_diagonal_matrix_has_the_krylov_degree_of_its_distinct_touched_values() -> None:
    entries = {(0, 0): Fraction(1), (1, 1): Fraction(1), (2, 2): Fraction(2), (3, 3): Fraction(5, 3)}
    assert krylov_degree_mod(4, entries, {0: 1, 1: 1, 2: 1, 3: 1}, 4).degree == 3
    assert krylov_degree_mod(4, entries, {0: 1, 2: 1}, 4).degree == 2


@settings(max_examples=40, deadline=None)
@example((4, [[1, 2, 1], [2, 3, 1], [3, 4, 1], [1, 4, 1]]), (1, 3))  # a cycle: repeated eigenvalues
@example((4, [[1, 2, 1], [1, 3, 1], [1, 4, 1]]), (2, 3))  # a star: twins 2, 3, 4
@example((3, [[1, 2, 1], [1, 3, 1]]), (2, 3))
@given(graphs(min_n=3, max_n=9), st.tuples(st.integers(1, 9), st.integers(1, 9)))
def test_what_the_krylov_certificates_prove_is_the_exact_answer(graph: tuple[int, list[list[Any]]], pair: tuple[int, int]) -> None:
    n, edges = graph
    a, b = (min(pair[0], n), min(pair[1], n))
    if a == b:
        b = a % n + 1
    assume(not any({u, v} == {a, b} for u, v, _w in edges))
    s = _system(n, edges, (a, b))
    if not s.switching_components("s"):
        return
    for fast, slow in ((eigenvector_differences_modular, eigenvector_differences_verdict), (distinct_eigenvalues_modular, distinct_eigenvalues_verdict)):
        got = fast(s, "s")
        exact = slow(System(s.spec), "s", exact=True)
        if got is not None:
            assert got.status is exact.status, (fast.__name__, got.witness, exact.witness)


def test_the_krylov_certificate_decides_a_generic_mode_without_a_characteristic_polynomial() -> None:
    s = _system(6, [[1, 2, 1], [2, 3, 2], [3, 4, 1], [4, 5, 3], [5, 6, 1], [2, 5, 1]], (1, 6))
    v = eigenvector_differences_modular(s, "s")
    assert v is not None and v.status is Status.HOLDS and "Krylov" in v.witness["certificate"]
    d = distinct_eigenvalues_modular(s, "s")
    assert d is not None and d.status is Status.HOLDS and "Krylov" in d.witness["certificate"]
    assert not any(k[0] == "charpoly-mod" for k in s.analysis.keys()) if hasattr(s.analysis, "keys") else True
    assert laplacian_entries(s, "s")


def test_an_exact_eigenvector_of_small_support_proves_a_failure_the_krylov_degree_only_hints_at() -> None:
    # two pendant paths 1-2-3 and 1-4-5 with weights 3 and 2: (0, 1, x, -1, -x) on 2..5 is an
    # exact eigenvector (eigenvalues 1 and 6: 9 + 16 = 25), zero on agents 1 and 7; 2 and 4 are
    # not twins (their rows differ off {2, 4})
    s = _system(7, [[1, 2, 3], [2, 3, 2], [1, 4, 3], [4, 5, 2], [1, 6, 1], [6, 7, 2]], (1, 7))
    with config.override(charpoly_mod_max_agents=4):  # as on a network beyond the characteristic polynomials
        v = eigenvector_differences_modular(s, "s")
    exact = eigenvector_differences_verdict(System(s.spec), "s", exact=True)
    assert exact.status is Status.FAILS
    assert v is not None and v.status is Status.FAILS and len(v.witness["eigenvector_exact"]) == 4
    L = {(i, j): w for (i, j), w in laplacian_entries(s, "s").items()}
    u = {s.index[k]: x for k, x in v.witness["eigenvector_exact"].items()}
    mu = v.witness["eigenvalue_exact"]
    for r in range(s.n):  # the witness against the definition: L_q u = mu u exactly
        assert sum(L.get((r, c), Fraction(0)) * x for c, x in u.items()) == mu * u.get(r, Fraction(0))


def _observability_rank_over_q(n: int, entries: dict[tuple[int, int], Fraction], outputs: list[dict[int, Fraction]]) -> int:
    A = flint.fmpq_mat(n, n)
    for (i, j), v in entries.items():
        A[i, j] = flint.fmpq(v.numerator, v.denominator)
    rows = []
    for out in outputs:
        r = flint.fmpq_mat(1, n, [flint.fmpq(out.get(j, Fraction(0)).numerator, out.get(j, Fraction(0)).denominator) for j in range(n)])
        for _ in range(n):
            rows.append([r[0, j] for j in range(n)])
            r = r * A
    if not rows:
        return 0
    return int(flint.fmpq_mat(len(rows), n, [x for row in rows for x in row]).rank())


@settings(max_examples=60, deadline=None)
@given(
    st.integers(1, 8).flatmap(
        lambda n: st.tuples(
            st.just(n),
            st.lists(st.tuples(st.integers(0, n - 1), st.integers(0, n - 1), st.integers(-3, 3)), max_size=3 * n),
            st.lists(st.lists(st.tuples(st.integers(0, n - 1), st.integers(-2, 2)), max_size=3), max_size=3),
        )
    )
)
def test_a_block_krylov_rank_modulo_a_prime_never_exceeds_the_observability_rank_over_q(case: tuple[int, list[tuple[int, int, int]], list[list[tuple[int, int]]]]) -> None:
    n, raw, outs = case
    entries: dict[tuple[int, int], Fraction] = {}
    for i, j, v in raw:
        if v:
            entries[(i, j)] = Fraction(v, 1 + (i + 2 * j) % 3)
    outputs = [{j: Fraction(v, 2) for j, v in row if v} for row in outs]
    kr = krylov_rank_mod(n, entries, outputs)
    exact = _observability_rank_over_q(n, entries, outputs)
    assert kr.rank <= exact
    # a rank that proves observability is the exact answer
    assert kr.observable <= (exact == n)


def test_the_observability_certificate_decides_a_cluster_of_a_hundred_agents_that_zero_forcing_leaves_open() -> None:
    from glocal_verify.analysis.local.cases import certify_pencil_verdict, local_cases
    from glocal_verify.analysis.local.pencil_rank_certificates import observability_certificate
    from glocal_verify.analysis.local.pencil import pencil_verdict
    from glocal_verify.design.generators import random_clustered_spec

    # the realistic family at N = 1000: in cluster P4 zero forcing leaves 93 of 100 agents unforced
    s = System(random_clustered_spec(1000, 10, seed=7, modes=1))
    case = local_cases(s, cluster="P4")[0]
    assert case.suspected == ()
    assert observability_certificate(s, case) is not None
    v = certify_pencil_verdict(s, case, pencil_verdict(s, case))
    assert v.status is Status.HOLDS
    assert "observability matrix" in v.witness["certificate"]["by"]


@settings(max_examples=25, deadline=None)
@given(st.integers(0, 10_000), st.integers(18, 30), st.integers(2, 3), st.booleans())
def test_what_the_observability_certificate_proves_exact_arithmetic_confirms(seed: int, n: int, clusters: int, attack: bool) -> None:
    from glocal_verify.analysis.local.cases import local_cases, minor_certificate
    from glocal_verify.analysis.local.pencil_rank_certificates import observability_certificate
    from glocal_verify.analysis.local.pencil import pencil_verdict_exact
    from glocal_verify.design.generators import random_clustered_spec

    s = System(random_clustered_spec(n, clusters, seed=seed, modes=1, attack=attack))
    for case in local_cases(s):
        if observability_certificate(s, case) is None:
            continue
        exact = pencil_verdict_exact(System(s.spec), case, margin=False, method="dense")
        # full column rank at every lam != 0: every exact zero, if any, is lam = 0
        for z in exact.witness.get("zeros", []):
            assert complex(z.get("lambda", 0)) == 0, (case.scope, exact.witness)
        if minor_certificate(s, case) is not None:
            assert exact.status is Status.HOLDS, (case.scope, exact.witness)
