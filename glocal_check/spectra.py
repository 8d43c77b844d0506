"""Eigenstructure of a safe mode: Theorem III.3 (ii) ``switching.distinct-eigenvalues`` and
(iii) ``switching.eigenvector-differences``.

L_q is symmetric, so diagonalisable, and for any vector b the dimension of the Krylov space
span{L_q^k b} is the number of eigenspaces in which b has a nonzero component.

* ``krylov`` (ii holds): det[b, L_q b, ..., L_q^(N-1) b] != 0 modulo a prime, so the Krylov
  space of b is R^N: b meets N eigenspaces, so L_q has N distinct eigenvalues.
* ``krylov-pairs`` (iii holds): G_q connected (ker L_q = span{1}) and, for every pair i != j
  of every switching component, d = e_i - e_j has a Krylov space of dimension N - 1 (the
  matrix [d, ..., L_q^(N-2) d] without its last row, whose rows sum to zero, has a nonzero
  (N-1)-minor modulo a prime). d is orthogonal to 1, so it lies in the sum of the eigenspaces
  of the nonzero eigenvalues, of total dimension N - 1, and meets N - 1 of them: each is a line
  span{u_l} and u_l^T d = u_l(i) - u_l(j) != 0 for every l != 1.
* ``eigenvectors`` (ii fails): two vectors with L_q v = mu v over Q[t]/(g) and a 2 x 2 minor
  prime to g: a repeated eigenvalue at every root of g.
* ``eigenvector`` (iii fails): L_q v = mu v with mu and an entry of v prime to g and
  v(i) = v(j) for a pair of one switching component: normalised and completed to an
  orthonormal eigenbasis, v is a column l != 1 of an admissible U_q with equal entries.
"""

from __future__ import annotations

from itertools import combinations
from typing import Any

from glocal_check.algebra import Field, krylov_det, mod, prime, require, unit
from glocal_check.context import Context

__all__ = ["distinct", "differences"]


def _eigenvector(ctx: Context, m: str, K: Field, mu: Any, v: list[Any]) -> None:
    Lv = K.apply(ctx.lap(m), v)
    require(all(K.is_zero(a - mu * b) for a, b in zip(Lv, v)), f"L_{m} v != mu v")


def distinct(ctx: Context, scope: dict[str, Any], status: str, cert: dict[str, Any]) -> None:
    sp = ctx.spec
    m = ctx.mode(scope.get("mode"))
    if status == "holds":
        require(cert.get("kind") == "krylov", "distinct eigenvalues need a krylov certificate")
        p = prime(cert.get("prime"))
        b = [mod(x, p) for x in sp.vector(cert.get("start"), "start")]
        d = krylov_det(ctx.lap_mod(m, p), b, sp.n)
        unit(d, cert.get("det"), p, "the Krylov determinant")
        return
    require(cert.get("kind") == "eigenvectors", "a repeated eigenvalue needs an eigenvectors certificate")
    K = Field(cert.get("field"))
    mu = K.element(cert.get("mu"), "mu")
    vs = [K.vector(v, sp.idx, sp.n, "vectors") for v in cert.get("vectors", [])]
    require(len(vs) == 2, "expected two eigenvectors")
    for v in vs:
        _eigenvector(ctx, m, K, mu, v)
    a, b = (sp.idx(x, "rows") for x in cert.get("rows", [None, None]))
    require(K.nonzero_everywhere(vs[0][a] * vs[1][b] - vs[0][b] * vs[1][a]), "the two eigenvectors are not shown independent")


def differences(ctx: Context, scope: dict[str, Any], status: str, cert: dict[str, Any]) -> None:
    sp = ctx.spec
    m = ctx.mode(scope.get("mode"))
    comps = sp.switching_components(m)
    if status == "holds":
        require(cert.get("kind") == "krylov-pairs", "eigenvector differences need a krylov-pairs certificate")
        require(len(sp.components(m)) == 1, f"G_{m} is not connected")
        p = prime(cert.get("prime"))
        want = {frozenset(pr) for c in comps for pr in combinations(c, 2)}
        got: dict[frozenset[int], Any] = {}
        for item in cert.get("pairs", []):
            require(isinstance(item, list) and len(item) == 3, f"bad pair entry {item!r}")
            got[frozenset((sp.idx(item[0], "pairs"), sp.idx(item[1], "pairs")))] = item[2]
        require(set(got) == want, "the pairs are not those of the switching components")
        Lp = ctx.lap_mod(m, p)
        for pr, claimed in got.items():
            i, j = sorted(pr)
            d = [0] * sp.n
            d[i], d[j] = 1, p - 1
            det = krylov_det(Lp, d, sp.n - 1, drop_last_column=True)
            unit(det, claimed, p, f"the Krylov minor of pair ({sp.labels[i]}, {sp.labels[j]})")
        return
    require(cert.get("kind") == "eigenvector", "equal entries need an eigenvector certificate")
    K = Field(cert.get("field"))
    mu = K.element(cert.get("mu"), "mu")
    require(K.nonzero_everywhere(mu), "mu may be 0 (l = 1 is excluded)")
    v = K.vector(cert.get("vector"), sp.idx, sp.n, "vector")
    require(any(K.nonzero_everywhere(x) for x in v), "v may vanish")
    _eigenvector(ctx, m, K, mu, v)
    i, j = (sp.idx(x, "pair") for x in cert.get("pair", [None, None]))
    require(i != j and any(i in c and j in c for c in comps), "the pair is not in one switching component")
    require(K.is_zero(v[i] - v[j]), "v(i) != v(j)")
