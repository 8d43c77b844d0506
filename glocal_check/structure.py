"""Combinatorial conditions, decided from the spec by their definitions (certificate kind
``structure``: the facts the verdict rests on, each recomputed and compared).

Each function returns the status its condition has on the spec and the facts that decide
it; the driver compares both with the certificate.
"""

from __future__ import annotations

from typing import Any

from glocal_check.algebra import dense, rank_exact, require
from glocal_check.context import Context, LocalScope

__all__ = ["STRUCTURAL"]

Facts = tuple[str, dict[str, Any]]


def connected(ctx: Context, scope: dict[str, Any]) -> Facts:
    """Lemma III.1's assumption: G_q is connected."""
    k = len(ctx.spec.components(ctx.mode(scope.get("mode"))))
    return ("holds" if k == 1 else "fails"), {"components": k}


def kernel(ctx: Context, scope: dict[str, Any]) -> Facts:
    """Lemma III.1: [1; 0] in ker C, i.e. S_Mx 1 = 0: no monitored position."""
    mx = ctx.labels(ctx.spec.positions)
    return ("holds" if not mx else "fails"), {"position_monitors": mx}


def unobservable(ctx: Context, scope: dict[str, Any]) -> Facts:
    """Lemma III.1's conclusion: span{[1; 0]} is A_q-invariant and unobservable in every mode
    of the scope (and so for the schedule, whose exponentials fix it). L_q 1 = 0 for every
    Laplacian, so A_q [1; 0] = 0 and this holds iff C [1; 0] = 0: no monitored position."""
    for m in ctx.scope_modes(scope):
        require(all(sum(r.values()) == 0 for r in ctx.lap(m)), f"L_{m} 1 != 0")
    return kernel(ctx, scope)


def consensus_fails(ctx: Context, scope: dict[str, Any]) -> Facts:
    """Problem 1 (i), x* revealed. By the modal structure of N(A_q, C), f = [1/N 1; 0] is
    orthogonal to N(A_q, C) iff every component of G_q has a monitored position (the kernel
    of L_q is spanned by the component indicators, every other eigenvector is orthogonal to 1).
    For the schedule, N_1^m lies in N(A_first, C), so the first mode's test suffices for
    ``fails``; ``holds`` needs the vector certificate of ``privacy.consensus-value``."""
    m = ctx.first_mode(scope)
    px = set(ctx.spec.positions)
    blind = [ctx.labels(c) for c in ctx.spec.components(m) if not px & set(c)]
    return ("holds" if blind else "fails"), {"mode": m, "components_without_position_monitor": blind}


def covert(ctx: Context, scope: dict[str, Any]) -> Facts:
    """Proposition II.4 (i): a covert attack is feasible iff the attacker owns every monitored
    channel that u_a reaches. The reachable subspace of (A_1, B) is K x K with
    K = span{L^k e_f}; for positive weights (c I - L_1 is entrywise >= 0 for large c) the
    support of K is the union of the components of G_1 that contain F, so the channels reached
    are the monitored channels of those agents."""
    sp = ctx.spec
    require(sp.attack is not None, "no [attack] in the spec")
    F = set(sp.attack["actuators"])
    reached = {a for c in sp.components("normal") if F & set(c) for a in c}
    owned = set(sp.attack["sensors"])
    need = [f"x:{sp.labels[a]}" for a in sp.positions if a in reached] + [f"v:{sp.labels[a]}" for a in sp.velocities if a in reached]
    have = {f"{k}:{sp.labels[a]}" for a in owned for k in "xv"}
    missing = sorted(c for c in need if c not in have)
    return ("holds" if not missing else "fails"), {"missing": missing}


def k_connected(ctx: Context, scope: dict[str, Any]) -> Facts:
    """Proposition III.2 (i): deg(c) >= |cut edges of P_i| + |suspected agents of P_i|."""
    ls = LocalScope(ctx.spec, scope)
    deg = len(ctx.spec.neighbours("normal")[ls.observer.center])
    required = len(ls.cut) + len(ls.suspected)
    return ("holds" if deg >= required else "fails"), {"degree": deg, "inter_cluster_edges": len(ls.cut), "required": required}


def local_rank(ctx: Context, scope: dict[str, Any]) -> Facts:
    """Proposition III.2 (ii): rank(C_loc E^i) = rank(E^i). E^i = [0; S_dP^T] has one unit
    column per boundary agent and C_loc selects measured channels, so C_loc E^i keeps exactly
    the columns of the boundary agents whose velocity is measured: it holds iff every
    boundary velocity is measured."""
    ls = LocalScope(ctx.spec, scope)
    miss = [a for a in ls.boundary if a not in set(ls.observer.velocities)]
    return ("holds" if not miss else "fails"), {"boundary": ctx.labels(ls.boundary), "unmeasured_boundary": ctx.labels(miss)}


def uio_rank_fails(ctx: Context, scope: dict[str, Any]) -> Facts:
    """``local.uio`` fails when its rank condition (ii) fails (a UIO needs it)."""
    st, facts = local_rank(ctx, scope)
    return ("fails" if st == "fails" else "holds"), facts


def pencil_structural(ctx: Context, scope: dict[str, Any]) -> Facts:
    """Proposition III.2 (iii) fails at every lam when an agent is both suspected and on the
    boundary: the columns of -B^i and E^i at its velocity row are opposite."""
    ls = LocalScope(ctx.spec, scope)
    both = [a for a in ls.suspected if a in set(ls.boundary)]
    return ("fails" if both else "holds"), {"suspected_and_boundary": ctx.labels(both)}


def coverage(ctx: Context, scope: dict[str, Any]) -> Facts:
    """Lemma A.2: every switching component D_c contains a monitored agent."""
    M = set(ctx.spec.monitored)
    bad = [ctx.labels(c) for c in ctx.spec.switching_components(ctx.mode(scope.get("mode"))) if not M & set(c)]
    return ("holds" if not bad else "fails"), {"uncovered": bad}


def image_kernel(ctx: Context, scope: dict[str, Any]) -> Facts:
    """Theorem III.3 (i): Im(dL_q) meets ker S_M only in 0, i.e. rank(S_M dL_q) = rank(dL_q).
    dL_q is block diagonal over the switching components, so the ranks are compared block by
    block, in exact rational arithmetic."""
    m = ctx.mode(scope.get("mode"))
    dL = ctx.spec.delta_laplacian(m)
    M = set(ctx.spec.monitored)
    ranks = []
    for c in ctx.spec.switching_components(m):
        ranks.append([rank_exact(dense(dL, c, c)), rank_exact(dense(dL, c, [a for a in c if a in M]))])
    ok = all(a == b for a, b in ranks)
    return ("holds" if ok else "fails"), {"ranks": ranks}


#: condition id -> the rule deciding it from the spec alone
STRUCTURAL = {
    "privacy.connected": connected,
    "privacy.kernel": kernel,
    "privacy.unobservable": unobservable,
    "privacy.consensus-value": consensus_fails,
    "stealthy.covert": covert,
    "local.k-connected": k_connected,
    "local.rank": local_rank,
    "local.uio": uio_rank_fails,
    "local.pencil": pencil_structural,
    "switching.coverage": coverage,
    "switching.image-kernel": image_kernel,
}
