"""Zero-dynamics attacks: ``stealthy.zda`` (Proposition II.4 (ii), Definition II.2) and
``switching.avoids-attack`` (Remark III.3.1).

A ZDA at lam0 is [x~0; u0] with u0 != 0 in the kernel of the Rosenbrock pencil
[[lam0 I - A_1, -B], [C, 0]]. With x~0 = [xi; lam0 xi] and s = lam0^2 + gamma lam0 the first
block row vanishes identically and the rest reads

    (s I + alpha L_1) xi = S_F^T u0,   S_Mx xi = 0,   lam0 S_Mv xi = 0.

Certificate ``zda``: lam0 is the variable t of Q[t]/(g) (``g = t - lam0`` for a rational
lam0), xi and u0 have entries in Q[t]/(g); the equations are checked modulo g, so they hold
at every root of g, and u0 has an entry prime to g, so u0 != 0 at every root. The velocity
equation is dropped only when g = t (lam0 = 0).
"""

from __future__ import annotations

from typing import Any

from flint import fmpq, fmpq_poly

from glocal_check.algebra import Field, minor_of, prime, require, unit
from glocal_check.context import Context

__all__ = ["avoids_attack", "zda_exists"]


def zda_exists(ctx: Context, cert: dict[str, Any]) -> tuple[Field, list[fmpq_poly]]:
    """Check a ``zda`` certificate; return its field and xi."""
    sp = ctx.spec
    require(sp.attack is not None, "no [attack] in the spec")
    K = Field(cert.get("field"), "field")
    xi = K.vector(cert.get("xi"), sp.idx, sp.n, "xi")
    u0 = K.vector(cert.get("u0"), sp.idx, sp.n, "u0")
    F = set(sp.attack["actuators"])
    require(all(u0[a] == 0 for a in range(sp.n) if a not in F), "u0 acts on an agent outside F")
    require(any(K.nonzero_everywhere(u0[a]) for a in F), "u0 may vanish at a root of g (no entry prime to g)")
    t = K.t
    s = K.reduce(t * t + sp.gamma * t)
    Lxi = K.apply(ctx.lap("normal"), xi)
    for a in range(sp.n):
        require(K.is_zero(s * xi[a] + sp.alpha * Lxi[a] - u0[a]), f"(s I + alpha L_1) xi != S_F^T u0 at agent {sp.labels[a]}")
    out = list(sp.positions)
    if K.g != fmpq_poly([0, 1]):
        out += list(sp.velocities)
    require(all(K.is_zero(xi[a]) for a in out), "xi is nonzero on a monitored agent (C x~0 != 0)")
    return K, xi


def _spec_lambda0(ctx: Context) -> fmpq_poly:
    """The monic minimal polynomial of the spec's lambda0 over Q."""
    lam = ctx.spec.attack["lambda0"] if ctx.spec.attack else None
    require(lam is not None, "the spec gives no attack.lambda0")
    re, im = lam
    if im == 0:
        return fmpq_poly([-re, 1])
    return fmpq_poly([re * re + im * im, -2 * re, 1])


def avoids_attack(ctx: Context, scope: dict[str, Any], status: str, cert: dict[str, Any]) -> None:
    """Remark III.3.1 at the spec's lambda0 (the rule's exponent whenever a ZDA exists there,
    which the certificate's ZDA shows).

    ``holds``: the ZDA has dL_q xi = 0 (the switch leaves it untouched).
    ``fails`` (real lambda0 only): every stealthy direction at lambda0 is touched, i.e. the
    kernel of G = [[s I + alpha L_1, -S_F^T], [S_out, 0], [dL_q, 0]] has u0 = 0. Certified by
    rank(G) >= r (an r x r minor nonzero modulo a prime) and dim ker G_xi >= k (k exact kernel
    vectors of the xi-columns, independent by a k x k minor modulo the prime) with
    r = (N - k) + |F|: then rank G = rank G_xi + |F|, so G [xi; u0] = 0 forces u0 = 0.
    """
    sp = ctx.spec
    m = ctx.mode(scope.get("mode"))
    K, xi = zda_exists(ctx, cert.get("zda", {}))
    require(K.g == _spec_lambda0(ctx), "the ZDA is not at the spec's lambda0")
    dL = sp.delta_laplacian(m)
    if status == "holds":
        moved = K.apply(dL, xi)
        require(all(K.is_zero(x) for x in moved), "dL_q xi != 0: the switch touches this direction")
        return
    lam0 = K.root_if_rational()
    require(lam0 is not None, "a touch certificate needs a real lambda0")
    s = lam0 * lam0 + sp.gamma * lam0
    n = sp.n
    F = list(sp.attack["actuators"])
    out = list(sp.positions) if lam0 == 0 else sp.monitored
    L = ctx.lap("normal")
    cols = {f"xi:{sp.labels[j]}": j for j in range(n)}
    cols.update({f"u:{sp.labels[f]}": n + k for k, f in enumerate(F)})
    rows: dict[str, dict[int, fmpq]] = {}
    for a in range(n):
        r = {j: sp.alpha * x for j, x in L[a].items()}
        r[a] = r.get(a, fmpq(0)) + s
        for k, f in enumerate(F):
            if f == a:
                r[n + k] = fmpq(-1)
        rows[f"L:{sp.labels[a]}"] = r
        if dL[a]:
            rows[f"dL:{sp.labels[a]}"] = dict(dL[a])
    for a in out:
        rows[f"out:{sp.labels[a]}"] = {a: fmpq(1)}
    p = prime(cert.get("prime"))
    rk, ck = cert.get("rows", []), cert.get("cols", [])
    require(all(isinstance(x, str) and x in rows for x in rk), "a minor row is not a row of G")
    require(all(isinstance(x, str) and x in cols for x in ck), "a minor column is not a column of G")
    sub = [[rows[r].get(cols[c], fmpq(0)) for c in ck] for r in rk]
    d = minor_of(sub, list(range(len(rk))), list(range(len(ck))), p) if rk else 1
    unit(d, cert.get("det"), p, "the minor of G")
    Z = [sp.vector(z, "kernel") for z in cert.get("kernel", [])]
    for z in Z:
        for key, r in rows.items():
            require(sum((x * z[j] for j, x in r.items() if j < n), fmpq(0)) == 0, f"a kernel vector is not in ker G_xi (row {key})")
    if Z:
        zr = [sp.idx(a, "kernel_rows") for a in cert.get("kernel_rows", [])]
        require(len(zr) == len(Z), "kernel_rows must pick one row per kernel vector")
        kd = minor_of([[z[a] for z in Z] for a in range(n)], zr, list(range(len(Z))), p)
        unit(kd, cert.get("kernel_det"), p, "the minor of the kernel vectors")
    require(len(rk) == (n - len(Z)) + len(F), f"rank {len(rk)} of G does not reach (N - {len(Z)}) + |F|")

