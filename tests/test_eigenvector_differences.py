"""Theorem III.3 (iii): ``switching.eigenvector-differences`` on known cases, with witnesses
checked against the definition and the exact polynomial test checked against sympy."""

from __future__ import annotations

from fractions import Fraction

import networkx as nx
import numpy as np
import pytest
import sympy

from glocal_verify import System, load_example, spec_from_graph, verify
from glocal_verify.analysis.switching.eigenstructure import eigenvector_difference_polynomial
from glocal_verify.results import ConditionResult, Status

CID = "switching.eigenvector-differences"


def _system(G: nx.Graph, **kw: object) -> System:
    return System(spec_from_graph(G, **kw))  # type: ignore[arg-type]


def _one(system: System, exact: bool, mode: str | None = None) -> ConditionResult:
    rs = [r for r in verify(system, [CID], exact=exact).conditions if mode is None or r.scope["mode"] == mode]
    assert len(rs) == 1
    return rs[0]


@pytest.mark.parametrize("exact", [False, True])
def test_a_cycle_fails_distinct_eigenvalues_and_eigenvector_differences_gives_an_equal_pair(exact: bool) -> None:
    s = _system(nx.path_graph(range(1, 7)), monitor_velocities=[1], modes={"cycle": {"add": [(1, 6)]}})
    assert _one(s, exact).status is Status.FAILS
    st = [r.status for r in verify(s, ["switching.distinct-eigenvalues"], exact=exact).conditions]
    assert st == [Status.FAILS]
    r = _one(s, exact)
    assert "repeated" in r.witness["reason"] and r.margin == 0.0
    u = np.array([r.witness["eigenvector"][a] for a in s.labels])
    i, j = s.idx(r.witness["pair"])
    L = s.laplacian("cycle")
    mu = float(u @ L @ u)
    assert np.linalg.norm(L @ u - mu * u) < 1e-9 and abs(np.linalg.norm(u) - 1) < 1e-9
    assert abs(u[i] - u[j]) < 1e-12 and mu > 1e-6  # an l != 1 eigenvector with equal entries


@pytest.mark.parametrize("exact", [False, True])
def test_a_path_with_distinct_eigenvalues_still_fails_iii_on_its_two_symmetric_ends(exact: bool) -> None:
    # the safe mode is again a path, 8-1-2-...-7: distinct eigenvalues, but its ends 7 and 8 are
    # mirror images, so every even eigenvector has equal entries on the switched pair {7, 8}
    s = _system(nx.path_graph(range(1, 9)), monitor_velocities=[8], modes={"longer": {"remove": [(7, 8)], "add": [(1, 8)]}})
    assert [r.status for r in verify(s, ["switching.distinct-eigenvalues"], exact=exact).conditions] == [Status.HOLDS]
    r = _one(s, exact)
    assert r.status is Status.FAILS
    assert set(r.witness["pair"]) == {7, 8}
    w, U = s.eigh("longer")
    l = r.witness["l"] - 1
    assert l >= 1 and abs(w[l] - r.witness["eigenvalue"]) < 1e-9
    i, j = s.idx(r.witness["pair"])
    assert abs(U[i, l] - U[j, l]) < 1e-12
    if exact:
        assert "common_factor" in r.witness


@pytest.mark.parametrize("exact", [False, True])
def test_an_asymmetric_weighted_switch_meets_iii_with_a_positive_margin(exact: bool) -> None:
    G = nx.Graph()
    G.add_weighted_edges_from([(1, 2, 1), (2, 3, 2), (3, 4, 3), (4, 5, 1)])
    s = _system(G, monitor_velocities=[5], modes={"q": {"add": [(1, 5, 2)]}})
    r = _one(s, exact)
    assert r.status is Status.HOLDS and r.margin is not None and r.margin > 1e-3
    w, U = s.eigh("q")
    i, j = s.idx([1, 5])
    assert r.margin == pytest.approx(np.min(np.abs(U[i, 1:] - U[j, 1:])))


def test_paper19_meets_iii_in_cases_1_and_2_and_fails_in_case_3() -> None:
    s = System(load_example("paper19"))
    for exact in (False, True):
        rs = {r.scope["mode"]: r for r in verify(s, [CID], exact=exact).conditions}
        assert rs["case-1"].status is Status.HOLDS and rs["case-2"].status is Status.HOLDS
        assert rs["case-3"].status is Status.FAILS
        assert 0.03 < rs["case-1"].margin < 0.06 and 0.03 < rs["case-2"].margin < 0.06  # type: ignore[operator]


def _laplacian(n: int, edges: list[tuple[int, int, int]]) -> list[list[Fraction]]:
    L = [[Fraction(0)] * n for _ in range(n)]
    for u, v, w in edges:
        L[u][v] -= w
        L[v][u] -= w
        L[u][u] += w
        L[v][v] += w
    return L


def test_the_difference_polynomial_is_the_adjugate_quadratic_form() -> None:
    L = _laplacian(5, [(0, 1, 1), (1, 2, 2), (2, 3, 1), (3, 4, 3), (0, 3, 1)])
    mu = sympy.symbols("mu")
    M = sympy.Matrix(5, 5, lambda a, b: (mu if a == b else 0) - sympy.Rational(L[a][b].numerator, L[a][b].denominator))
    adj = M.adjugate()
    for i, j in [(0, 1), (1, 3), (2, 4)]:
        b = sympy.zeros(5, 1)
        b[i], b[j] = 1, -1
        want = sympy.Poly(sympy.expand((b.T * adj * b)[0]), mu)
        got = eigenvector_difference_polynomial(L, i, j)
        got_coeffs = [sympy.Rational(int(c.p), int(c.q)) for c in reversed(got.coeffs())]
        assert want.all_coeffs() == got_coeffs


def test_the_difference_polynomial_at_an_eigenvalue_is_p_prime_times_the_squared_difference() -> None:
    L = _laplacian(5, [(0, 1, 1), (1, 2, 2), (2, 3, 1), (3, 4, 3), (0, 3, 1)])
    Lf = np.array([[float(x) for x in r] for r in L])
    w, U = np.linalg.eigh(Lf)
    p = np.poly(Lf)
    dp = np.polyder(p)
    for i, j in [(0, 1), (1, 3), (2, 4)]:
        q = eigenvector_difference_polynomial(L, i, j)
        qc = [float(Fraction(int(c.p), int(c.q))) for c in reversed(q.coeffs())]
        for l in range(5):
            assert np.polyval(qc, w[l]) == pytest.approx(np.polyval(dp, w[l]) * (U[i, l] - U[j, l]) ** 2, abs=1e-8)
