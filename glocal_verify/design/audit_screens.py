"""Set-independent screens of the audit: the separator of F from the monitors, the minor tables.

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
    :func:`glocal_verify.analysis.zda.zda_analysis`), and gives the exact growth class
    ``unbounded`` of an audit with ``growth="verdict"``.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from fractions import Fraction
from dataclasses import dataclass
from typing import Any

import numpy as np

from glocal_verify.analysis.twins import laplacian_entries
from glocal_verify.analysis.unobservable import rational_unobservable_candidates
from glocal_verify.analysis.zda import ZdaZero
from glocal_verify.analysis.zda_batch import batch_directions
from glocal_verify.derived import Kind
from glocal_verify.errors import ModelError
from glocal_verify.model import System
from glocal_verify.numerics.minors import (
    GroundedTables,
    grounded_tables,
    verified_invariant_subspace,
)
from glocal_verify.spec.types import NORMAL_MODE, Label

__all__ = ["disjoint_paths", "global_tables"]

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
    H = G.subgraph(comp)
    blocks = [frozenset(b) for b in nx.biconnected_components(H)]
    cuts = set(nx.articulation_points(H))
    T = nx.Graph()  # block-cut tree: cut vertices ("c", v) and blocks ("b", i)
    for i, blk in enumerate(blocks):
        T.add_node(("b", i))
        for v in blk & cuts:
            T.add_edge(("b", i), ("c", v))
    home = {v: ("c", v) if v in cuts else ("b", next(i for i, blk in enumerate(blocks) if v in blk)) for v in H}
    parent = nx.predecessor(T, home[sink])  # BFS tree rooted at t's node
    out: dict[Label, frozenset[Label]] = {}
    memo: dict[Any, frozenset[Label]] = {home[sink]: frozenset()}

    def above(node: Any) -> frozenset[Label]:
        chain = []
        while node not in memo:
            chain.append(node)
            node = parent[node][0]
        acc = memo[node]
        for nd in reversed(chain):
            acc = acc | ({nd[1]} if nd[0] == "c" and nd[1] != sink else set())
            memo[nd] = acc
        return acc

    for v in system.labels:
        if v in comp:
            out[v] = above(home[v]) | {v}
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
    """Rationalised reduced-echelon bases of E_mu ∩ ker S_M per eigenvalue group (floating point)."""
    sp = system.spectrum()
    U = np.asarray(sp.vectors)
    out = [rows for g in sp.clusters if (rows := rational_unobservable_candidates(U[:, list(g)], M))]
    if grouped:
        return out
    return [r for grp in out for r in grp]


def _witness_lambda(sh: Any, F: tuple[Label, ...], memo: dict[Any, Any] | None = None) -> tuple[complex, bool]:
    """The exponent of :func:`_witness_zda` for F, and whether the separator proves F not left-invertible.

    With ``memo``: the separator's answer is kept for the next call on F (which removes it).
    """
    if memo is not None and ("not-left-invertible", F) in memo:
        not_li = memo.pop(("not-left-invertible", F))
    else:
        not_li = sh.screen and disjoint_paths(sh.system, F) < len(F)
        if memo is not None:
            memo[("not-left-invertible", F)] = not_li
    return (complex(sh.lambda0) if sh.lambda0 is not None else (1.0 + 0j if not_li else 0j)), not_li


def batch_witnesses(sh: Any, sets: Sequence[tuple[Label, ...]], memo: dict[Any, Any]) -> None:
    """The witness directions of :func:`_witness_zda` for many sets at once, into ``memo``.

    Sets are grouped by their exponent and handed to
    :func:`glocal_verify.analysis.zda_batch.batch_directions` (the per-set method's decisions,
    vectorised over the sets); a set it leaves open is decided by :func:`_witness_zda` alone.
    """
    groups: dict[complex, list[tuple[Label, ...]]] = {}
    for F in sets:
        groups.setdefault(_witness_lambda(sh, F, memo)[0], []).append(F)
    for lam, Fs in groups.items():
        for F, d in zip(Fs, batch_directions(sh.system, sh.tol, lam, Fs)):
            memo[("witness-direction", F)] = d


def _without_sensors(system: System, sensors: Sequence[Label]) -> System:
    bad = [a for a in sensors if a not in system.index]
    if bad:
        raise ModelError(f"--sensors: {', '.join(map(str, bad))} not in the graph")
    s = set(sensors)
    mon = system.spec.monitor
    new = dataclasses.replace(
        mon, positions=tuple(a for a in mon.positions if a not in s), velocities=tuple(a for a in mon.velocities if a not in s)
    )
    return System(dataclasses.replace(system.spec, monitor=new))


def certified_touch(system: System, F: Sequence[Label], av: Any, exact_lambda: bool) -> Any:
    """A numeric touch verdict (``switching.avoids-attack`` of one mode) if certified for the exact system, else ``undecided``.

    As ``verify`` certifies it
    (:func:`~glocal_verify.analysis.avoidance.avoidance_certificate`: Weyl lower bounds against
    structural upper bounds at an exact real lambda0, or the avoiding direction rationalised
    to an exact kernel vector). ``exact_lambda``: the witness exponent is exact (the spec's
    lambda0, or lambda0 = 1 for a system proved not left-invertible); a computed zero is not.
    """
    from glocal_verify.analysis.avoidance import avoidance_certificate
    from glocal_verify.results import Status

    if av.status is Status.UNDECIDED:
        return av
    cand = None if av.direction is None else np.concatenate([av.direction.xi, av.direction.u0])
    ok, _, note = avoidance_certificate(system, av.mode, system.idx(F), av.lambda0, av.status, exact_lambda, cand)
    return av if ok else dataclasses.replace(av, status=Status.UNDECIDED, notes=(*av.notes, f"numeric {av.status.value} not certified: {note}"))


@dataclass
class _Zda:
    stealthy: bool | None
    growth: str
    left_invertible: bool | None
    direction: ZdaZero | None
    source: str
    exact: Any = None
    method: str = "numeric"
    screened: bool = False
    certificate: str = ""
    #: False when the zero set was not computed (``growth="verdict"``): ``direction`` is a
    #: proven stealthy ZDA but not necessarily the fastest one, and ``growth`` is only exact
    #: when it is ``unbounded``
    complete: bool = True
    #: the growth class of ``direction`` (a lower bound on the fastest ZDA) when not complete
    growth_at_least: str = ""


def single_zda_key(sh: Any, a: Label) -> tuple[Any, ...]:
    """Memo key of the ZDA part of {a} under the options of ``sh`` (growth, exactness, fallbacks)."""
    return ("single-zda", a, sh.growth, sh.exact, sh.exact_fallback, sh.zda_fallback, sh.lambda0)


def inherited_zda(sh: Any, F: tuple[Label, ...], memo: dict[Any, Any] | None, zda_part: Any) -> _Zda | None:
    """A proven stealthy ZDA of F from a single member's, or None (``growth="verdict"``).

    If (xi, u_a) is a stealthy ZDA direction of {a} at lambda0, then (xi, u) with u = u_a on a
    and 0 on F minus {a} is one of F: the pencil of F has the columns of {a} and more, and the
    extra columns meet a zero input. The single's ZDA part (memoised per agent) is reused, the
    padded direction is verified again on F's full pencil (:meth:`_Modal.verify`), and the row
    keeps the single's growth as a lower bound (the zero set of F is not computed). This spares
    the sets that hold an agent whose own zeros defeat the minor certificate the whole
    O(N^3) zero-set analysis, when no safe mode can expose them.
    """
    from glocal_verify.analysis.zda import _Modal
    from glocal_verify.numerics.tolerance import Decision

    store = memo if memo is not None else {}
    for a in F:
        key = single_zda_key(sh, a)
        if key not in store:
            store[key] = zda_part(sh, (a,), memo)
        za = store[key]
        d = za.direction
        if za.stealthy is not True or d is None or not (za.growth_at_least or za.growth) or (za.growth_at_least or za.growth) == "undecided":
            continue
        md = _Modal(sh.system, F, sh.tol)
        u = np.zeros(len(F), dtype=complex)
        u[F.index(a)] = complex(d.u0[0])
        eta = md.U.T @ np.asarray(d.xi, dtype=complex)  # modal coordinates of xi (U orthogonal up to its certified error)
        xi, u2, res, dres, du = md.verify(d.value, eta, u)
        if dres is not Decision.ZERO or du is not Decision.NONZERO:
            continue
        g = za.growth_at_least or za.growth
        z = ZdaZero(d.value, d.value * d.value + sh.system.gamma * d.value, xi, u2, res, g)
        return _Zda(True, "unbounded" if g == "unbounded" else "undecided", None, z, f"a ZDA of {{{a}}} (zero input on the other actuators; the zero set of F was not computed)",
                    complete=False, growth_at_least=g)
    return None
