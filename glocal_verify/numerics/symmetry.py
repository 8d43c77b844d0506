"""Exact invariant subspaces of a Laplacian from its symmetries: twin agents and equitable partitions.

- :func:`twin_modes` -- agents with equal rows off themselves give exact eigenvectors e_a - e_r;
- :func:`equitable_cells` -- the coarsest equitable partition with some agents kept apart (colour
  refinement): twins, mirror-image branches, identical clusters hanging off the same agents;
- :func:`equitable_differences` -- the exact basis e_c - e_r of the invariant complement of its
  cell indicators (unobservable modes when the outputs are kept apart).

Pure functions of the exact entries; no knowledge of a system.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping, Sequence
from fractions import Fraction
from typing import Any

__all__ = ["equitable_cells", "equitable_differences", "twin_modes"]

#: the shared rational zero of the rows below (Fractions are immutable)
_ZERO = Fraction(0)


def equitable_cells(n: int, lap: Mapping[tuple[int, int], Fraction], special: Iterable[int]) -> list[int]:
    """The coarsest equitable partition refining the one that puts each ``special`` agent alone: the cell of every agent.

    A partition of the agents into cells C_1, ..., C_k is *equitable* for a symmetric matrix L
    when every member a of a cell C_i has the same row sum over every cell C_j:

    .. math::

        \\sum_{b \\in C_j} L_{ab} = q_{ij} \\quad \\text{for all } a \\in C_i ,

    so L P = P Q for the cell indicators P = [1_{C_1}, ..., 1_{C_k}]: span P is L-invariant,
    and (L symmetric) so is its orthogonal complement. Colour refinement computes it: each
    agent's signature is its cell, its diagonal entry and the multiset of (cell, entry) over
    its neighbours, until the number of cells stops growing (at most n rounds of
    O(nnz log deg) each). It puts twins, mirror-image branches and identical clusters hanging
    off the same agents in common cells. The partition is equitable by construction (the
    signatures of a stable colouring agree on every (cell, entry) multiset); the callers that
    rely on it check it exactly, or prove what they derive from it exactly.

    Parameters
    ----------
    n : int
        The size of the matrix.
    lap : mapping
        Nonzero entries ``{(i, j): v}`` of a symmetric matrix (exact).
    special : iterable of int
        Agents kept in cells of their own (the outputs, the attacked agents).

    Returns
    -------
    list of int
        The cell of each agent ``0 .. n - 1`` (cells numbered from 0 in the order of their
        first member's signature).
    """
    sp = set(special)
    rows: list[dict[int, Fraction]] = [{} for _ in range(n)]
    for (i, j), v in lap.items():
        if v != 0:
            rows[i][j] = v
    colour = [(-1 - a) if a in sp else 0 for a in range(n)]
    cells = len(set(colour))
    # the entries as small integers (one per distinct rational), so that the signatures hash and sort fast
    value_id: dict[Fraction, int] = {}
    diag_id = [value_id.setdefault(rows[a].get(a, Fraction(0)), len(value_id)) for a in range(n)]
    off = [[(b, value_id.setdefault(v, len(value_id))) for b, v in rows[a].items() if b != a] for a in range(n)]
    for _ in range(n):
        sig = [(colour[a], diag_id[a], tuple(sorted((colour[b], v) for b, v in off[a]))) for a in range(n)]
        ids: dict[object, int] = {}
        colour = [ids.setdefault(x, len(ids)) for x in sig]
        if len(ids) == cells:
            break
        cells = len(ids)
    return colour


def equitable_differences(n: int, lap: Mapping[tuple[int, int], Fraction], special: Iterable[int]) -> list[list[Fraction]]:
    """Exact rational rows e_c - e_r of the equitable partition of :func:`equitable_cells` (r the first member of c's cell).

    For the cell indicators P of an equitable partition, L P = P Q, so span P is L-invariant
    and, L being symmetric, so is its orthogonal complement

    .. math::

        W = (\\operatorname{span} P)^\\perp = \\operatorname{span}\\{ e_c - e_r : c \\ne r \\text{ in one cell} \\} ,
        \\qquad \\dim W = n - k .

    The differences vanish on the ``special`` agents (each alone in its cell). With the outputs
    M as ``special``, W lies in the unobservable subspace of (L, S_M) and has an exact basis
    even where the eigenvectors of L are irrational (identical clusters hanging off the same
    agents, twins). Nothing here is a proof: a caller proves span(rows) invariant and zero on
    M exactly (:func:`~glocal_verify.numerics.minors.verified_invariant_subspace`) before
    using it.

    Parameters
    ----------
    n, lap, special
        As for :func:`equitable_cells` (``special``: the outputs).

    Returns
    -------
    list of list of Fraction
        n - k rows of length n, one per agent that is not the first of its cell; empty when
        every cell is a single agent.
    """
    colour = equitable_cells(n, lap, special)
    first: dict[int, int] = {}
    rows: list[list[Fraction]] = []
    for a in range(n):
        r = first.setdefault(colour[a], a)
        if r != a:
            row = [_ZERO] * n
            row[a], row[r] = Fraction(1), Fraction(-1)
            rows.append(row)
    return rows


def twin_modes(size: int, laplacian: Mapping[tuple[int, int], Fraction], measured: Sequence[int]) -> tuple[tuple[Fraction, tuple[tuple[int, int], ...]], ...]:
    """Exact eigenvectors e_a - e_r of L that vanish on M (twin agents), grouped by eigenvalue.

    Agents a != r are twins when their rows of L agree off {a, r} and L_aa = L_rr; then
    L (e_a - e_r) = (L_aa - L_ar)(e_a - e_r) exactly. A class of twins C (one representative r)
    gives |C| - 1 independent modes; classes are disjoint, so their modes are independent.
    Only agents outside M count (the mode must vanish on M).

    Parameters
    ----------
    size : int
    laplacian : mapping
        Nonzero entries of the symmetric matrix (exact).
    measured : sequence of int
        M.

    Returns
    -------
    tuple
        ``((mu, ((a, r), ...)), ...)``: the eigenvalue and the pairs of each family.
    """
    M = set(measured)
    rows: list[dict[int, Fraction]] = [{} for _ in range(size)]
    for (i, j), v in laplacian.items():
        if v != 0:
            rows[i][j] = v

    def twins(a: int, r: int) -> bool:
        if rows[a].get(a, 0) != rows[r].get(r, 0):
            return False
        ka = {j: v for j, v in rows[a].items() if j not in (a, r)}
        kr = {j: v for j, v in rows[r].items() if j not in (a, r)}
        return ka == kr

    groups: dict[Any, list[int]] = {}
    for a in range(size):
        if a in M:
            continue
        groups.setdefault(("open", rows[a].get(a, 0), frozenset((j, v) for j, v in rows[a].items() if j != a)), []).append(a)
    parent = list(range(size))

    def find(x: int) -> int:
        while parent[x] != x:
            parent[x] = parent[parent[x]]
            x = parent[x]
        return x

    for a in range(size):
        for b in rows[a]:
            if b > a and a not in M and b not in M and twins(a, b):
                parent[find(b)] = find(a)
    for a in range(size):
        if a not in M and find(a) != a:
            groups.setdefault(("closed", find(a)), []).append(a)
    out: dict[Fraction, list[tuple[int, int]]] = {}
    for key, members in groups.items():
        r = key[1] if key[0] == "closed" else members[0]
        if r not in members:
            members = [r] + members
        pairs = [(a, r) for a in members if a != r and twins(a, r)]
        mus = {rows[r].get(r, Fraction(0)) - rows[r].get(a, Fraction(0)) for a, _ in pairs}
        if len(mus) != 1:
            continue  # a class whose pairs disagree is not used
        out.setdefault(mus.pop(), []).extend(pairs)
    return tuple((mu, tuple(sorted(pairs))) for mu, pairs in sorted(out.items()))
