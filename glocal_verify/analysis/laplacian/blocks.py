"""The block-cut tree of a graph: its blocks (biconnected components), cut vertices and the tree joining them.

Two questions of the analysis read it. Where does a current between attacked agents flow
(the potentials of L_1 at lambda0 = 0, :mod:`glocal_verify.analysis.switching.zero_touch`)? Only
through the blocks on the tree path between them: a part of the graph hanging off that subtree
at a cut vertex c carries no current, so every potential there equals the potential at c. Which
vertices separate an agent from the monitors (:mod:`glocal_verify.analysis.stealthy.zda_screens`)?
The cut vertices on the tree path between them.

The tree is built once per graph (networkx's biconnected components, O(V + E)); a question
about one set of terminals then costs a walk on the tree, not a new decomposition: an audit
asks it of every attack set.
"""

from __future__ import annotations

from collections.abc import Hashable, Iterable, Sequence
from dataclasses import dataclass
from typing import Any

__all__ = ["BlockCutTree", "block_cut_tree"]

#: a node of the tree: ("b", k) the k-th block, ("c", v) the cut vertex v
Node = tuple[str, Any]


@dataclass(frozen=True, eq=False)
class BlockCutTree:
    """The block-cut tree of a graph, rooted at an arbitrary node of each component.

    Attributes
    ----------
    blocks : tuple of frozenset
        The blocks (biconnected components); a bridge is a block of two vertices.
    cuts : frozenset
        The cut vertices (articulation points).
    home : dict
        The tree node of each vertex of an edge: ``("c", v)`` for a cut vertex, else
        ``("b", k)`` for the only block holding it.
    parent : dict
        Each node's parent on its component's tree (a root is its own parent).
    depth : dict
        Each node's depth (0 at a root).
    """

    blocks: tuple[frozenset[Hashable], ...]
    cuts: frozenset[Hashable]
    home: dict[Hashable, Node]
    parent: dict[Node, Node]
    depth: dict[Node, int]

    def path(self, a: Node, b: Node) -> list[Node] | None:
        """The tree nodes from ``a`` to ``b`` (both included), or None when they are in different components."""
        up_a, up_b = [a], [b]
        while self.depth[up_a[-1]] > self.depth[up_b[-1]]:
            up_a.append(self.parent[up_a[-1]])
        while self.depth[up_b[-1]] > self.depth[up_a[-1]]:
            up_b.append(self.parent[up_b[-1]])
        while up_a[-1] != up_b[-1]:
            pa, pb = self.parent[up_a[-1]], self.parent[up_b[-1]]
            if pa == up_a[-1]:  # two roots: different components
                return None
            up_a.append(pa)
            up_b.append(pb)
        return up_a + up_b[-2::-1]

    def attach_points(self, terminals: Sequence[Hashable], vertices: Iterable[Hashable]) -> dict[Hashable, Hashable]:
        """For each of ``vertices``, the vertex whose potential it shares for every current between ``terminals``.

        The current flows through the blocks of the subtree S spanning the terminals' nodes.
        A vertex of a block of S, or a cut vertex of S, attaches to itself; any other vertex
        lies in a part hanging off S and attaches to the cut vertex where that part meets S:
        the first node of S on its tree path toward S is a cut vertex c (then c), or a block
        entered through a cut vertex c just before it (then c; c itself is a vertex of that
        block, so it attaches to itself). A vertex without an edge, or
        outside the terminals' component, attaches to itself.

        Parameters
        ----------
        terminals : sequence of vertices
            At least one, all in one component.
        vertices : iterable of vertices

        Returns
        -------
        dict
            vertex -> attach point.
        """
        homes = [self.home[t] for t in terminals]
        inside: set[Node] = {homes[0]}
        for h in homes[1:]:
            p = self.path(homes[0], h)
            if p is None:
                raise ValueError("the terminals lie in different components")
            inside.update(p)
        out: dict[Hashable, Hashable] = {}
        for v in vertices:
            node = self.home.get(v)
            if node is None or node in inside:
                out[v] = v
                continue
            out[v] = self._junction(node, homes[0], inside, v)
        return out

    def _junction(self, h: Node, anchor: Node, inside: set[Node], v: Hashable) -> Hashable:
        """The cut vertex where the part holding node ``h`` meets the subtree ``inside``."""
        p = self.path(h, anchor)
        if p is None:
            return v
        prev = None
        for node in p:
            if node in inside:
                if node[0] == "c":
                    return node[1]
                assert prev is not None and prev[0] == "c"
                return prev[1]
            prev = node
        return v  # pragma: no cover - the anchor is inside


def block_cut_tree(vertices: Iterable[Hashable], edges: Iterable[tuple[Hashable, Hashable]], root: Hashable | None = None) -> BlockCutTree:
    """The block-cut tree of the graph with these vertices and edges (networkx's biconnected components).

    Parameters
    ----------
    vertices : iterable
    edges : iterable of (u, v)
    root : vertex, optional
        Root its component's tree at this vertex's node (default: an arbitrary node).

    Returns
    -------
    BlockCutTree
    """
    import networkx as nx

    G = nx.Graph()
    G.add_nodes_from(vertices)
    G.add_edges_from(edges)
    blocks = tuple(frozenset(b) for b in nx.biconnected_components(G))
    cuts = frozenset(nx.articulation_points(G))
    home: dict[Hashable, Node] = {}
    adj: dict[Node, list[Node]] = {}
    for k, b in enumerate(blocks):
        adj.setdefault(("b", k), [])
        for v in b:
            if v in cuts:
                adj.setdefault(("c", v), []).append(("b", k))
                adj[("b", k)].append(("c", v))
                home[v] = ("c", v)
            else:
                home[v] = ("b", k)
    parent: dict[Node, Node] = {}
    depth: dict[Node, int] = {}
    first = [home[root]] if root is not None and root in home else []
    for top in [*first, *adj]:
        if top in parent:
            continue
        parent[top], depth[top] = top, 0
        stack = [top]
        while stack:
            t = stack.pop()
            for x in adj[t]:
                if x not in parent:
                    parent[x], depth[x] = t, depth[t] + 1
                    stack.append(x)
    return BlockCutTree(blocks, cuts, home, parent, depth)
