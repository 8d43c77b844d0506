"""Screens of the ZDA question that hold for a whole system: the separator of F from the monitors, the minor tables, lambda0 = 0.

Structural screen (proof)
    Let X be a vertex set separating F from M = M_x ∪ M_v in the graph (every path from F to
    M meets X; X may contain agents of F or M). Split the vertices into Y (reachable from M
    without meeting X), X and Z (the rest); there is no edge between Y and Z, so
    (sI + alpha L)[Y, Z] = 0. For s outside the finitely many eigenvalues of -alpha L[Y, Y],
    the solution w of (sI + alpha L) w = S_F^T u satisfies on the rows Y (none of them in F)
    (sI + alpha L)[Y, Y] w_Y + (sI + alpha L)[Y, X] w_X = 0, so w_Y, and hence
    w_M = S_M w, is a linear function of w_X: rank G(s) <= |X| with
    G(s) = S_M (sI + alpha L)^{-1} S_F^T. Since Q(s) = [[sI + alpha L, -S_F^T], [S_M, 0]]
    has normal rank N + nrank G, a separator with |X| < |F| makes the system not
    left-invertible, for every choice of the weights: a stealthy ZDA exists at every lambda0.
    By Menger's theorem the smallest separator is the largest number of vertex-disjoint paths
    from F to M (a unit-capacity maximum flow, :func:`disjoint_paths`). The screen only proves
    existence; it saves the N-sized QZ of ``stealthy.zda`` when the spec fixes lambda0 (the
    witness is then the direction at lambda0, the rule of
    :func:`glocal_verify.analysis.stealthy.zda.zda_analysis`), and gives the exact growth class
    ``unbounded`` of an audit with ``growth="verdict"``.

lambda0 = 0 (:func:`zero_exponent_status`)
    At lambda0 = 0 the velocity rows vanish, and a stealthy direction is a kernel vector of
    Q_0 = [[alpha L_1, -S_F^T], [S_{M_x}, 0]] with u0 != 0. With no monitored position and
    positive weights rank L_1 = N - c (c components), and the columns e_f add the indicators of
    the c_F components that hold an attacked agent: rank Q_0 = N - c + c_F, so a stealthy ZDA at
    0 exists iff c_F < |F| (exact, from the graph). With monitored positions, zero forcing from
    M_x on the exact graph (rows of attacked agents never force) that reaches every agent
    proves there is none, as does the rank of Q_0 modulo a prime reaching N - (components
    without a monitored position) + |F| (up to ``zero_exponent_modular_max_agents``); otherwise
    the certified rank bounds of
    :func:`~glocal_verify.analysis.stealthy.zda_certificate.u_direction_certificate` decide, up to
    ``config.get("zero_exponent_dense_max_agents")`` agents.
"""

from __future__ import annotations

from collections.abc import MutableMapping, Sequence
from fractions import Fraction
from typing import Any

import numpy as np

from glocal_verify import config
from glocal_verify.analysis.laplacian.blocks import block_cut_tree
from glocal_verify.analysis.laplacian.twins import laplacian_entries
from glocal_verify.analysis.unobservable.subspace import rational_unobservable_candidates
from glocal_verify.derived import Kind
from glocal_verify.model import System
from glocal_verify.numerics.symmetry import equitable_differences
from glocal_verify.numerics.minors import (
    GroundedTables,
    grounded_tables,
    verified_invariant_subspace,
)
from glocal_verify.results import Status
from glocal_verify.spec.types import NORMAL_MODE, Label

__all__ = ["disjoint_paths", "global_tables", "invisible_inside_f", "minor_tables_affordable", "minor_tables_seconds", "zero_exponent_status"]


#: derived results this module keeps on the system (glocal_verify.derived)
_AUDIT_KIND: Kind[Any] = Kind("audit", __name__, "Any")


def disjoint_paths(system: System, F: Sequence[Label]) -> int:
    """Largest number of vertex-disjoint paths from F to M (Menger; the structural screen).

    A unit-capacity maximum flow on the vertex-split graph (every agent v becomes v_in -> v_out
    of capacity 1, every edge both ways out -> in), from a source feeding F to a sink fed by M,
    with ``scipy.sparse.csgraph.maximum_flow``; the split graph is built once per system.

    Parameters
    ----------
    system : System
    F : sequence of labels
        The actuators.

    Returns
    -------
    int
        When smaller than |F| the system is not left-invertible for any weights (module docstring).
    """
    import scipy.sparse
    from scipy.sparse.csgraph import maximum_flow

    if not system.monitored:
        return 0
    if len(set(F)) <= 2:
        return _few_disjoint_paths(system, F)
    n = system.n
    data, indices, indptr = _AUDIT_KIND.get(system, ("split-graph",), lambda: _split_graph(system))
    # the source is the last vertex: its row (arcs to every f_in) is the only per-set part
    Fi = np.unique(np.asarray(system.idx(F), dtype=np.int32))
    cap = scipy.sparse.csr_matrix(
        (np.concatenate([data, np.ones(Fi.size, np.int32)]), np.concatenate([indices, Fi]), np.append(indptr, indptr[-1] + Fi.size)),
        shape=(2 * n + 2, 2 * n + 2),
    )
    return int(maximum_flow(cap, 2 * n + 1, 2 * n).flow_value)


def invisible_inside_f(system: System, F: Sequence[Label]) -> str | None:
    """An exact proof that the system is not left-invertible by a direction inside F, or None.

    A nonzero xi supported on the unmonitored attacked agents F' = F minus M with L_1 xi
    supported on F, i.e. xi in ker L_1[V minus F, F'] over Q, gives for every s = lambda^2 +
    gamma lambda the input u = ((s I + alpha L_1) xi)_F with (s I + alpha L_1) xi = S_F^T u and
    S_M xi = 0: a stealthy ZDA at every lambda0 where u != 0 (every lambda0 but at most two),
    so the pencil loses column rank for every lambda. This is the rank drop that exact
    weights make and the graph does not (twin attacked agents with equal links: e_a - e_r),
    which :func:`disjoint_paths` cannot see. Only the rows of the neighbours of F' are nonzero;
    the rank is computed over Q (python-flint).

    Parameters
    ----------
    system : System
    F : sequence of labels
        The actuators.

    Returns
    -------
    str or None
        The proof, one line (the dimension of the kernel); None proves nothing.
    """
    import flint

    Fset = set(system.idx(F))
    free = sorted(Fset - set(system.idx(system.monitored)))
    if not free:
        return None
    col = {j: k for k, j in enumerate(free)}
    rows: dict[int, dict[int, Fraction]] = {}
    for (i, j), v in laplacian_entries(system, NORMAL_MODE).items():
        if j in col and i not in Fset and v != 0:
            rows.setdefault(i, {})[col[j]] = v
    if not rows:
        dim = len(free)
    else:
        mat = flint.fmpq_mat(len(rows), len(free))
        for r, (_, entries) in enumerate(sorted(rows.items())):
            for c, v in entries.items():
                mat[r, c] = flint.fmpq(v.numerator, v.denominator)
        dim = len(free) - int(mat.rank())
    if dim <= 0:
        return None
    return (f"ker L_1[V \\ F, F \\ M] has dimension {dim} over Q: a direction on the unmonitored attacked agents that "
            "the links out of F do not see is a stealthy ZDA at every lambda0 (not left-invertible; exact)")


def _few_disjoint_paths(system: System, F: Sequence[Label]) -> int:
    """:func:`disjoint_paths` for |F| <= 2 from the block-cut tree of G + t (t joined to M).

    A vertex x != t meets every path from v to t iff x = v or x is a cut vertex of G + t on
    the block-cut tree path from v to t; call that set C(v). Then one vertex separates F
    from M iff the C(f), f in F, share a vertex, and no path exists iff some C(f) is
    undefined (f not connected to t). By Menger's theorem the count of vertex-disjoint
    paths is |F| unless one of these holds.
    """
    dom = _AUDIT_KIND.get(system, ("dominators",), lambda: _dominators(system))
    sets = [dom.get(f) for f in dict.fromkeys(F)]
    if any(c is None for c in sets):
        return 0 if len(sets) == 1 else (0 if all(c is None for c in sets) else 1)
    if len(sets) == 1:
        return 1
    a, b = sets
    assert a is not None and b is not None
    return 1 if a & b else 2


def _dominators(system: System) -> dict[Label, frozenset[Label]]:
    """C(v) of :func:`_few_disjoint_paths` for every agent connected to the monitors."""
    import networkx as nx

    sink = ("__sink__",)
    G = nx.Graph()
    G.add_nodes_from(system.labels)
    G.add_edges_from(tuple(k) for k in system.edges())
    G.add_edges_from((m, sink) for m in system.monitored)
    comp = nx.node_connected_component(G, sink)
    tree = block_cut_tree(comp, G.subgraph(comp).edges(), root=sink)
    out: dict[Label, frozenset[Label]] = {}
    if sink not in tree.home:  # no monitor: nothing reaches t
        return out
    memo: dict[Any, frozenset[Label]] = {tree.home[sink]: frozenset()}

    def above(node: Any) -> frozenset[Label]:
        chain = []
        while node not in memo:
            chain.append(node)
            node = tree.parent[node]
        acc = memo[node]
        for nd in reversed(chain):
            acc = acc | ({nd[1]} if nd[0] == "c" and nd[1] != sink else set())
            memo[nd] = acc
        return acc

    for v in system.labels:
        if v in comp:
            out[v] = above(tree.home[v]) | {v}
    return out


def _split_graph(system: System) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """CSR arrays (rows 0 .. 2N) of the vertex-split graph with unit capacities: v_in = v ->
    v_out = v + N per agent, u_out -> v_in both ways per edge, m_out -> sink = 2N per monitor."""
    import scipy.sparse

    n = system.n
    us, vs = [], []
    for key in system.edges():
        a, b = (system.index[x] for x in tuple(key))
        us += [a + n, b + n]
        vs += [b, a]
    ar = np.arange(n, dtype=np.int32)
    M = np.asarray(system.idx(system.monitored), dtype=np.int32)
    r = np.concatenate([ar, np.asarray(us, np.int32), M + n])
    c = np.concatenate([ar + n, np.asarray(vs, np.int32), np.full(M.size, 2 * n, np.int32)])
    g = scipy.sparse.csr_matrix((np.ones(r.size, np.int32), (r, c)), shape=(2 * n + 1, 2 * n + 2))
    g.sum_duplicates()
    g.sort_indices()
    g.data[:] = 1
    return g.data.astype(np.int32), g.indices.astype(np.int32), g.indptr.astype(np.int32)


def minor_tables_seconds(n: int) -> float:
    """Seconds of the minor certificate's tables on N agents (a characteristic polynomial modulo a
    prime of the N-sized pencil): ``zda_certificate_seconds_n3`` N^3 (:mod:`glocal_verify.config`).

    Parameters
    ----------
    n : int
        Agents.
    """
    return float(config.get("zda_certificate_seconds_n3")) * float(n) ** 3


def minor_tables_affordable(n: int) -> bool:
    """Whether the minor certificate's tables fit their time share, ``zda_certificate_max_seconds``.

    The one answer for ``decide_zda`` (which tries them after an uncertified numeric zero set)
    and for ``verify``'s escalation scheduler (which learns the exact ZDA path from them).

    Parameters
    ----------
    n : int
        Agents.
    """
    return minor_tables_seconds(n) <= float(config.get("zda_certificate_max_seconds"))


def global_tables(system: System) -> GroundedTables | None:
    """The numerator tables of the normal mode's reduced ZDA pencil (outputs M = M_x ∪ M_v).

    The unobservable modes the certificate divides out come from floating point (eigenvectors
    of L_1 that vanish on M to 1e-9), rationalised, and are used only after
    :func:`~glocal_verify.numerics.minors.verified_invariant_subspace` proves them exactly.
    """
    entries = laplacian_entries(system, NORMAL_MODE)
    M = system.idx(system.monitored)
    cands = _unobservable_candidates(system, M)
    tables = grounded_tables(system.n, entries, Fraction(system.alpha_q), M, cands) if cands else None
    if tables is not None and not tables.unobservable_factor and cands:
        # the whole candidate space did not verify: keep the groups that do, one by one
        kept: list[list[Fraction]] = []
        for group in _unobservable_candidates(system, M, grouped=True):
            if verified_invariant_subspace(system.n, entries, M, kept + group) is not None:
                kept += group
        tables = grounded_tables(system.n, entries, Fraction(system.alpha_q), M, kept or None)
    return tables if tables is not None else grounded_tables(system.n, entries, Fraction(system.alpha_q), M)


def _unobservable_candidates(system: System, M: Sequence[int], grouped: bool = False) -> Any:
    """Rationalised reduced-echelon bases of E_mu ∩ ker S_M per eigenvalue group (floating point), and one group of
    exact differences of the equitable partition with M kept apart (identical clusters, twins:
    :func:`~glocal_verify.numerics.symmetry.equitable_differences`), whose eigenvectors are irrational."""
    sp = system.spectrum()
    U = np.asarray(sp.vectors)
    out = [rows for g in sp.clusters if (rows := rational_unobservable_candidates(U[:, list(g)], M))]
    sym = equitable_differences(system.n, laplacian_entries(system, NORMAL_MODE), M)
    if sym:
        out.append(sym)
    if grouped:
        return out
    return [r for grp in out for r in grp]


def _full_rank_at_zero_mod_p(system: System, F: Sequence[int], Mx: Sequence[int], free: int) -> int | None:
    """The prime p when the rank of Q_0 modulo p proves that no stealthy ZDA exists at lambda0 = 0, else None.

    .. math::

        Q_0 = \\begin{bmatrix} \\alpha L_1 & -S_F^T \\\\ S_{M_x} & 0 \\end{bmatrix},
        \\qquad
        \\operatorname{rank} Q_0 \\ge N - \\text{free} + m
        \\;\\Rightarrow\\; \\text{no kernel vector } (\\xi, u_0) \\text{ with } u_0 \\ne 0 .

    The kernel of [alpha L_1; S_Mx] is spanned by the indicators of the ``free`` components of
    G_1 without a monitored position, so its rank is N - free, and a kernel vector of Q_0 with
    an input part exists iff rank Q_0 < (N - free) + m. Reduction modulo a prime p that divides
    no denominator is a ring homomorphism, so every minor nonzero modulo p is nonzero over Q:
    rank_p Q_0 <= rank_Q Q_0, and a modular rank reaching N - free + m proves the absence
    exactly, with no rounding (where the Weyl bounds fail on weights of very different
    scales). The prime also divides no numerator (:func:`~glocal_verify.numerics.minors.prime_for`),
    which only avoids needless failures. An unlucky prime proves nothing (None); it never
    proves a false absence. Cost: one dense rank modulo p of an (N + |M_x|) x (N + m) matrix.

    Parameters
    ----------
    system : System
    F : sequence of int
        Indices of the attacked agents (m = len(F)).
    Mx : sequence of int
        Indices of the monitored positions.
    free : int
        Components of G_1 without a monitored position.

    Returns
    -------
    int or None
        The prime of the proof, or None.
    """
    from flint import nmod_mat

    from glocal_verify.numerics.minors import prime_for

    N, m = system.n, len(F)
    a = Fraction(system.alpha_q)
    ent = {k: a * v for k, v in laplacian_entries(system, NORMAL_MODE).items() if v != 0}
    p = prime_for(list(ent.values()))
    rows, cols = N + len(Mx), N + m
    flat = [0] * (rows * cols)
    for (i, j), v in ent.items():
        flat[i * cols + j] = (v.numerator % p) * pow(v.denominator % p, -1, p) % p
    for k, f in enumerate(F):
        flat[f * cols + N + k] = (flat[f * cols + N + k] - 1) % p
    for t, r in enumerate(Mx):
        flat[(N + t) * cols + r] = 1
    return p if int(nmod_mat(rows, cols, flat, p).rank()) >= N - free + m else None


def zero_exponent_status(system: System, F: Sequence[Label], memo: MutableMapping[Any, Any] | None = None) -> tuple[Status, str]:
    """Whether a stealthy ZDA at lambda0 = 0 exists for the actuators F, and what proves it (module docstring).

    Parameters
    ----------
    system : System
    F : sequence of labels
    memo : mutable mapping, optional
        Per-run store (the components and the exact neighbour lists are kept there).

    Returns
    -------
    (Status, str)
        ``HOLDS`` / ``FAILS`` with the proof, or ``UNDECIDED`` with the reason.
    """
    store: MutableMapping[Any, Any] = memo if memo is not None else {}
    m = len(F)
    if "component-of" not in store:
        store["component-of"] = {a: ci for ci, c in enumerate(system.components()) for a in c}
    comp = store["component-of"]
    if not system.monitored_positions:
        c_f = len({comp[a] for a in F})
        if c_f < m:
            return Status.HOLDS, (f"no monitored position and the {m} attacked agents lie in {c_f} component(s) of G_1: "
                                  f"rank [alpha L_1, -S_F^T] = N - c + {c_f} < N - c + {m} (a persistent ZDA; exact, from the graph)")
        return Status.FAILS, f"no monitored position and each of the {m} attacked agents lies in its own component of G_1: rank [alpha L_1, -S_F^T] = N - c + {m} (exact)"
    from glocal_verify.analysis.local.cluster_pencil import intra_neighbours, zero_forcing_closure

    if "exact-neighbours" not in store:
        store["exact-neighbours"] = intra_neighbours(system.laplacian_exact())
    Fi, Mx = system.idx(F), system.idx(system.monitored_positions)
    if len(zero_forcing_closure(store["exact-neighbours"], Mx, Fi)) == system.n:
        return Status.FAILS, "zero forcing from M_x on the exact graph reaches every agent: ker Q_0 = {0}"
    mx = set(Mx)
    free = sum(1 for c in system.components() if not any(system.index[a] in mx for a in c))
    if system.n <= config.get("zero_exponent_modular_max_agents") and (p := _full_rank_at_zero_mod_p(system, Fi, Mx, free)) is not None:
        return Status.FAILS, (f"rank Q_0 = N - {free} + {m} modulo the prime {p}, the most rank [alpha L; S_Mx] + m can be "
                              "(the indicators of the components without a monitored position span its kernel): no kernel vector of Q_0 with an input part")
    if system.n > (limit := config.get("zero_exponent_dense_max_agents")):
        return Status.UNDECIDED, f"zero forcing from M_x leaves agents unforced, and certified rank bounds are not tried above {limit} agents"
    from glocal_verify.analysis.stealthy.zda_certificate import exact_q_rows, u_direction_certificate

    rows0, pat0 = exact_q_rows(system, Fi, Mx, Fraction(0))
    at0, bound = u_direction_certificate(rows0, pat0, system.n, m, xi_upper=system.n - free)
    if at0 is True:
        return Status.HOLDS, f"Weyl/structural rank bounds at lambda0 = 0 (error bound {bound:.3g}): rank Q_0 < rank [alpha L; S_Mx] + m (a persistent ZDA)"
    if at0 is False:
        return Status.FAILS, f"Weyl/structural rank bounds at lambda0 = 0 (error bound {bound:.3g}): no kernel vector of Q_0 with an input part"
    return Status.UNDECIDED, f"the certified rank bounds at lambda0 = 0 do not separate (error bound {bound:.3g})"
