"""Local observer placement (the future work of Remark III.2.1).

For a cluster P_i with boundary dP_i, Laplacian block L = L[P_i, P_i] and a suspected set S,
find a centre c and a measured set M (positions and velocities of every agent in M) such that

* Proposition III.2 (ii) holds: dP_i ⊆ M;
* Proposition III.2 (iii) holds for B^i = S;
* the unknown-input observer exists (implied by (ii) and (iii): the pencil with E^i alone
  then has full column rank for every lam, so (C, A_1) is observable),

with |M| as small as the search can make it.

**Reduction used by the search.** With I = S ∪ dP_i (the input agents; S ∩ dP_i = ∅, else no
placement exists, see below), a zero direction of the pencil of eq. ``pencil_uio`` is
[xi; lam xi] with xi_M = 0 and (s I + alpha L) xi vanishing on the rows R = P_i \\ I, where
s = lam^2 + gamma lam (every s is reached by some lam). So (iii) holds iff the n-sized pencil

.. math:: Q(s) = (s I + \\alpha L)[R, U], \\qquad U = P_i \\setminus M

has full column rank for every complex s. Two tests on it:

* *zero forcing* (sufficient, exact, no arithmetic): a known (measured or forced) agent r not in
  I with exactly one unknown neighbour k forces xi_k = 0; if every agent gets forced, Q(s) has
  full column rank for every s, whatever the weights;
* the *pencil test* (necessary and sufficient): Q(s) is the Rosenbrock pencil of a system with
  |R ∩ U| states, analysed by :func:`glocal_verify.numerics.pencil.analyze_pencil`.

A necessary count: |M| >= |I| (Q(s) must be tall), i.e. |M \\ dP_i| >= |S|. Both tests, and
the proofs that they decide (iii), live in :mod:`glocal_verify.analysis.local.cluster_pencil`, shared with the
structured ``local.pencil`` checker (:func:`glocal_verify.analysis.local.pencil.pencil_verdict`).

**Search.** Greedy set cover: start from M = dP_i and add the agent whose measurement forces
the most agents, until zero forcing completes (structural, no arithmetic: O(|P_i|) closures per
added agent); then drop agents (last added first) while the pencil test still holds (clusters
of at most ``full_delete_max`` (:mod:`glocal_verify.config`) agents) or while zero forcing still completes (larger ones:
no dense factorization per candidate; the full test runs once on the result). For small
clusters an exhaustive search by increasing |M| (at most ``exact_limit`` candidate sets)
proves the minimum. The centre is the agent whose closed neighbourhood covers most of M (the
rest needs extra communication, listed as ``extra_links``). Every proposal is re-verified with
the checkers' own code (:mod:`glocal_verify.conditions.local`): (ii), (iii) on the full pencil,
and the UIO design; a proposal they cannot confirm is replaced by the greedy zero-forcing set
(which the structured pencil checker decides combinatorially) before M is grown.

**Impossible requests.** A suspected boundary agent makes (iii) fail at every lam for every
measured set (two opposite columns of [-B^i, E^i]); :func:`place_observers` raises
:class:`~glocal_verify.errors.NotApplicableError` naming the agents. This is always the case
for ``suspected="all"`` (Remark III.2.1's B^i = I) when the cluster has a boundary agent;
``"interior"`` (every agent not on the boundary) is the largest set that can be protected.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass, field
from typing import Any, Iterable, Sequence

import numpy as np
from tqdm import tqdm

from glocal_verify import config
from glocal_verify.analysis.local.cluster_pencil import (
    intra_neighbours,
    reduced_pencil_holds,
    zero_forcing_closure,
)
from glocal_verify.errors import ModelError, NotApplicableError
from glocal_verify.words import counted
from glocal_verify.model import ClusterModel, LocalObserver, System
from glocal_verify.numerics.tolerance import DEFAULT_TOLERANCE, Tolerance
from glocal_verify.observers.uio_existence import uio_existence
from glocal_verify.results import Status
from glocal_verify.spec.types import NORMAL_MODE, Label

__all__ = [
    "ObserverProposal",
    "Placement",
    "place_observers",
    "place_cluster",
    "suspected_set",
    "parse_suspected",
    "connectivity_warnings",
]


@dataclass(frozen=True, slots=True)
class ObserverProposal:
    """A proposed local observer of one cluster.

    Attributes
    ----------
    cluster : str
    center : label
    measured : tuple of labels
        Agents whose position and velocity the observer measures (cluster order).
    suspected : tuple of labels
        The suspected set it was designed for.
    boundary : tuple of labels
        dP_i (all measured: condition (ii)).
    extra_links : tuple of labels
        Measured agents that are neither the centre nor its neighbours (extra communication).
    lower_bound : int
        |S ∪ dP_i|: no valid measured set is smaller.
    optimal : bool
        True when |measured| is proven minimal (exhaustive search or the lower bound met).
    method : str
        ``"greedy"`` or ``"exhaustive"``.
    verification : mapping
        Statuses of local.rank, local.pencil and local.uio on the proposal (all ``holds``).
    """

    cluster: str
    center: Label
    measured: tuple[Label, ...]
    suspected: tuple[Label, ...]
    boundary: tuple[Label, ...]
    extra_links: tuple[Label, ...]
    lower_bound: int
    optimal: bool
    method: str
    verification: dict[str, str] = field(default_factory=dict)

    def size_words(self) -> str:
        """Why the measured set has its size, without a bound that reads as a contradiction."""
        if self.optimal and len(self.measured) <= self.lower_bound:
            return f"the fewest possible: every suspected and boundary agent must be measured ({self.lower_bound})"
        if self.optimal:
            return f"the fewest possible, proven by exhaustive search: measuring only the {counted(self.lower_bound, 'suspected or boundary agent')} does not suffice"
        return f"found greedily, not proven the fewest; no valid set has fewer than {self.lower_bound}"

    def to_json(self) -> dict[str, Any]:
        return {
            "cluster": self.cluster,
            "center": self.center,
            "positions": list(self.measured),
            "velocities": list(self.measured),
            "suspected": list(self.suspected),
            "boundary": list(self.boundary),
            "extra_links": list(self.extra_links),
            "lower_bound": self.lower_bound,
            "optimal": self.optimal,
            "method": self.method,
            "verification": dict(self.verification),
        }


def _toml_label(a: Label) -> str:
    return str(a) if isinstance(a, int) else '"' + str(a).replace("\\", "\\\\").replace('"', '\\"') + '"'


def _toml_list(xs: Iterable[Label]) -> str:
    return "[" + ", ".join(_toml_label(a) for a in xs) + "]"


@dataclass(frozen=True, slots=True)
class Placement:
    """Proposals for the clusters of a system, with the TOML fragment to paste.

    ``warnings`` are one-line notes about absent premises (e.g. a disconnected graph, from
    :func:`connectivity_warnings`); the placement is still computed.
    """

    system: str
    suspected: str
    proposals: tuple[ObserverProposal, ...]
    nodes: dict[str, tuple[Label, ...]] = field(default_factory=dict)
    warnings: tuple[str, ...] = ()

    def to_toml(self) -> str:
        """``[[clusters]]`` tables (name, nodes, one observer each) to replace the spec's."""
        lines = [f"# glocal-verify place-observers: {self.system} (suspected = {self.suspected})"]
        for p in self.proposals:
            lines += ["", f"# {p.cluster}: suspected {_toml_list(p.suspected)}, boundary {_toml_list(p.boundary)}; {len(p.measured)} measured agents ({p.size_words()})"]
            if p.extra_links:
                lines.append(f"# agents measured beyond the centre's neighbours (extra links): {_toml_list(p.extra_links)}")
            lines += [
                "[[clusters]]",
                f'name = "{p.cluster}"',
                f"nodes = {_toml_list(self.nodes.get(p.cluster, ()))}",
                "[[clusters.observers]]",
                f"center = {_toml_label(p.center)}",
                f"positions = {_toml_list(p.measured)}",
                f"velocities = {_toml_list(p.measured)}",
            ]
        return "\n".join(lines) + "\n"

    def to_json(self) -> dict[str, Any]:
        return {"system": self.system, "suspected": self.suspected, "proposals": [p.to_json() for p in self.proposals], "warnings": list(self.warnings)}


# --------------------------------------------------------------------------------------------
# building blocks


def suspected_set(system: System, cluster: str, suspected: str | Sequence[Label] = "attack") -> tuple[Label, ...]:
    """Resolve a suspected-set request for one cluster.

    Parameters
    ----------
    system : System
    cluster : str
    suspected : str or sequence of labels
        ``"attack"`` (the spec's attacked actuators in the cluster; empty without an attack),
        ``"interior"`` (every agent without an inter-cluster edge), ``"all"`` (every agent,
        Remark III.2.1) or explicit labels (those outside the cluster are ignored).
    """
    cm = system.cluster_model(cluster)
    if isinstance(suspected, str):
        if suspected == "attack":
            s = set(system.attacked)
        elif suspected == "interior":
            s = set(cm.nodes) - set(cm.boundary)
        elif suspected == "all":
            s = set(cm.nodes)
        else:
            raise ModelError(f"suspected must be 'attack', 'interior', 'all' or a list of agents, not {suspected!r}")
    else:
        system.idx(suspected)
        s = set(suspected)
    return tuple(a for a in cm.nodes if a in s)


def parse_suspected(system: System, text: str) -> str | tuple[Label, ...]:
    """Read a suspected-set request: ``attack``, ``interior``, ``all`` or comma-separated labels.

    Parameters
    ----------
    system : System
        Labels are matched against its nodes (``"3"`` is node 3 when the labels are integers).
    text : str
    """
    t = text.strip()
    if t in ("attack", "interior", "all"):
        return t
    out: list[Label] = []
    for tok in (x.strip() for x in t.split(",")):
        if not tok:
            continue
        if tok in system.index:
            out.append(tok)
        elif tok.lstrip("-").isdigit() and int(tok) in system.index:
            out.append(int(tok))
        else:
            raise ModelError(f"--suspected: node {tok!r} is not in the graph (or use attack, interior, all)")
    if not out:
        raise ModelError("--suspected: empty agent list")
    return tuple(out)


def _intra_neighbours(cm: ClusterModel) -> list[list[int]]:
    return intra_neighbours(cm.L)


# --------------------------------------------------------------------------------------------
# search


@dataclass
class _Problem:
    cm: ClusterModel
    alpha: float
    nbrs: list[list[int]]
    inputs: list[int]
    base: set[int]
    tol: Tolerance
    safe: list[ClusterModel]  # cluster models of the safe modes that change this cluster


def _holds(pb: _Problem, M: set[int]) -> bool:
    """(iii) in the normal mode (zero forcing, else the reduced pencil) and UIO existence in
    every safe mode that changes the cluster ((ii) is built into M ⊇ base)."""
    if len(M) < len(set(pb.inputs)):
        return False
    if len(zero_forcing_closure(pb.nbrs, M, pb.inputs)) < len(pb.cm.nodes):
        if reduced_pencil_holds(pb.cm, pb.alpha, pb.inputs, sorted(M), pb.tol) is not Status.HOLDS:
            return False
    labels = [pb.cm.nodes[k] for k in sorted(M)]
    for cq in pb.safe:
        if uio_existence(cq.A, cq.E, cq.C(labels, labels), pb.tol).status is not Status.HOLDS:
            return False
    return True


def _zf_complete(pb: _Problem, M: set[int]) -> bool:
    """Zero forcing from M reaches every agent: (iii) in the normal mode, proved combinatorially."""
    return len(M) >= len(set(pb.inputs)) and len(zero_forcing_closure(pb.nbrs, M, pb.inputs)) == len(pb.cm.nodes)


def _closure_size_with(nbrs: list[list[int]], Z: set[int], inp: set[int], c: int) -> int:
    """|closure(Z ∪ {c})| for a zero-forcing-closed Z, by forcing only from c's neighbourhood.

    Zero forcing is monotone and idempotent, so closure(M ∪ {c}) = closure(closure(M) ∪ {c});
    in a closed Z every agent outside ``inp`` has zero or at least two unknown neighbours, so
    only c and its known neighbours can force next (then the neighbours of what they force).
    Same rule as :func:`~glocal_verify.analysis.local.cluster_pencil.zero_forcing_steps`.
    """
    if c in Z:
        return len(Z)
    added = {c}
    active = ([c] if c not in inp else []) + [j for j in nbrs[c] if j in Z and j not in inp]
    while active:
        nxt: list[int] = []
        for r in active:
            unk = [k for k in nbrs[r] if k not in Z and k not in added]
            if len(unk) == 1:
                k = unk[0]
                added.add(k)
                if k not in inp:
                    nxt.append(k)
                nxt.extend(j for j in nbrs[k] if (j in Z or j in added) and j not in inp)
        active = list(dict.fromkeys(nxt))
    return len(Z) + len(added)


def _best_addition(pb: _Problem, M: set[int]) -> int:
    """The unmeasured agent whose measurement forces the most agents (ties: fewest neighbours);
    one closure of M, then work proportional to each candidate's neighbourhood."""
    Z = zero_forcing_closure(pb.nbrs, M, pb.inputs)
    inp = set(pb.inputs)
    best, best_score = -1, (-1, 0)
    for c in range(len(pb.cm.nodes)):
        if c in M:
            continue
        size = _closure_size_with(pb.nbrs, Z, inp, c)
        score = (size, -len(pb.nbrs[c]))
        if score > best_score:
            best, best_score = c, score
    return best


def _greedy(pb: _Problem) -> tuple[list[int], list[int]]:
    """Greedy set cover (module docstring): ``(proposal, zero-forcing set)``.

    Forward, only the structural test (zero forcing, no arithmetic) decides when to stop; the
    full test (:func:`_holds`: safe-mode UIO existence too) runs once on the result and keeps
    adding agents only if it fails. The reverse delete uses the full test (reduced pencil when
    zero forcing is incomplete) for clusters of at most ``full_delete_max`` (:mod:`glocal_verify.config`) agents, and
    zero forcing alone above (the full test then runs once on the result; on failure the
    zero-forcing set is kept). The second value is the set before the reverse delete: zero
    forcing completes on it, so the checkers decide it combinatorially.
    """
    n = len(pb.cm.nodes)
    M = set(pb.base)
    order: list[int] = []
    while len(M) < n and not _zf_complete(pb, M):
        c = _best_addition(pb, M)
        M.add(c)
        order.append(c)
    while len(M) < n and not _holds(pb, M):
        c = _best_addition(pb, M)
        M.add(c)
        order.append(c)
    before = sorted(M)
    full = n <= config.get("full_delete_max")
    for c in reversed(order):
        trial = M - {c}
        if _holds(pb, trial) if full else _zf_complete(pb, trial):
            M = trial
    if not full and sorted(M) != before and not _holds(pb, M):
        M = set(before)
    return sorted(M), before


def _center(cm: ClusterModel, nbrs: list[list[int]], M: Sequence[int]) -> tuple[int, list[int]]:
    best, extra_best = 0, list(M)
    Ms = set(M)
    for c in range(len(cm.nodes)):
        closed = set(nbrs[c]) | {c}
        extra = sorted(Ms - closed)
        key = (len(extra), c not in Ms, -len(nbrs[c]), c)
        if key < (len(extra_best), best not in Ms, -len(nbrs[best]), best):
            best, extra_best = c, extra
    return best, extra_best


def _verify(system: System, cm: ClusterModel, center: Label, measured: tuple[Label, ...], suspected: tuple[Label, ...], tol: Tolerance) -> dict[str, str]:
    from glocal_verify.analysis.local.cases import LocalCase
    from glocal_verify.analysis.local.pencil import pencil_verdict
    from glocal_verify.analysis.local.structure import rank_verdict
    from glocal_verify.observers.uio_verdict import uio_verdict

    obs = LocalObserver(cm.name, center, measured, measured, None)
    case = LocalCase(cm, obs, "attack", suspected, NORMAL_MODE)
    return {
        "local.rank": rank_verdict(case, tol).status.value,
        "local.pencil": pencil_verdict(system, case, tol, margin=False).status.value,
        "local.uio": uio_verdict(system, case, tol).status.value,
    }


def place_cluster(
    system: System,
    cluster: str,
    suspected: str | Sequence[Label] = "attack",
    *,
    tol: Tolerance = DEFAULT_TOLERANCE,
    exact_limit: int | None = None,
    progress: bool = True,
) -> ObserverProposal:
    """Propose one local observer for ``cluster`` (see the module docstring).

    Parameters
    ----------
    system : System
    cluster : str
    suspected : str or sequence of labels
        See :func:`suspected_set`.
    tol : Tolerance
        Tolerance of the pencil tests and of the final verification.
    exact_limit : int, optional
        Largest number of candidate sets the exhaustive search may visit (0 disables it;
        default: the tunable ``placement_exact_limit`` of :mod:`glocal_verify.config`, 2000).
    progress : bool
        Show a tqdm bar on stderr during the exhaustive search.

    Raises
    ------
    NotApplicableError
        When no measured set can work: a suspected agent is on the boundary.
    """
    cm = system.cluster_model(cluster)
    S = suspected_set(system, cluster, suspected)
    bad = [a for a in S if a in cm.boundary]
    if bad:
        edges = [f"{u}-{v}" for u, v, _ in cm.cut_edges if u in bad]
        raise NotApplicableError(
            f"cluster {cluster!r} cannot be covered: suspected agent(s) {', '.join(map(str, bad))} "
            f"{'are' if len(bad) > 1 else 'is'} on the boundary (inter-cluster edge(s) {', '.join(edges)}); "
            "the attack enters the same velocity row as the neighbour coupling E^i, so [-B^i, E^i] has two opposite "
            "columns and Proposition III.2 (iii) fails at every lam for every measured set "
            "(use --suspected interior to protect every agent that can be protected)"
        )
    idx = {a: k for k, a in enumerate(cm.nodes)}
    nbrs = _intra_neighbours(cm)
    safe = []
    base = {idx[a] for a in cm.boundary}
    for mode in system.safe_modes:
        cq = system.cluster_model(cluster, mode)
        if cq.cut_edges != cm.cut_edges or not np.array_equal(cq.L, cm.L):
            safe.append(cq)
            base |= {idx[a] for a in cq.boundary}
    inputs = sorted({idx[a] for a in cm.boundary} | {idx[a] for a in S})
    pb = _Problem(cm, system.alpha, nbrs, inputs, base, tol, safe)
    lower = max(len(inputs), len(base))
    M, zf_set = _greedy(pb)
    method, optimal = "greedy", len(M) <= lower
    free = [k for k in range(len(cm.nodes)) if k not in base]
    if exact_limit is None:
        exact_limit = int(config.get("placement_exact_limit"))
    if not optimal and exact_limit > 0:
        kmin = max(lower - len(base), 0)
        kmax = len(M) - len(base) - 1
        total = sum(math.comb(len(free), k) for k in range(kmin, kmax + 1))
        if total <= exact_limit:
            found: list[int] | None = None
            with tqdm(total=total, desc=f"{cluster}: exhaustive search", unit="set", disable=None if progress else True, leave=False) as bar:
                for k in range(kmin, kmax + 1):
                    hits = []
                    for comb in itertools.combinations(free, k):
                        bar.update(1)
                        trial = base | set(comb)
                        if _holds(pb, trial):
                            hits.append(sorted(trial))
                    if hits:
                        found = min(hits, key=lambda h: len(_center(cm, nbrs, h)[1]))
                        break
            if found is not None:
                M = found
            method, optimal = "exhaustive", True
    # verify with the checkers' code; if they cannot confirm the set (e.g. the numeric pencil
    # test is undecided), fall back to the greedy zero-forcing set (which they decide
    # combinatorially), and only then grow M
    tried_zf = False
    while True:
        c, extra = _center(cm, nbrs, M)
        measured = tuple(cm.nodes[k] for k in M)
        ver = _verify(system, cm, cm.nodes[c], measured, S, tol)
        if all(v == "holds" for v in ver.values()) or len(M) == len(cm.nodes):
            break
        if not tried_zf and list(M) != zf_set:
            tried_zf = True
            M, method, optimal = list(zf_set), "greedy", False
            continue
        tried_zf = True
        rest = [k for k in range(len(cm.nodes)) if k not in M]
        M = sorted(set(M) | {rest[0]})
        optimal = False
    if not all(v == "holds" for v in ver.values()):
        raise NotApplicableError(f"cluster {cluster!r}: no verified placement found (measuring every agent gives {ver})")
    return ObserverProposal(
        cluster=cluster,
        center=cm.nodes[c],
        measured=measured,
        suspected=S,
        boundary=cm.boundary,
        extra_links=tuple(cm.nodes[k] for k in extra),
        lower_bound=lower,
        optimal=optimal,
        method=method,
        verification=ver,
    )


def place_observers(
    system: System,
    cluster: str | None = None,
    suspected: str | Sequence[Label] = "attack",
    *,
    tol: Tolerance = DEFAULT_TOLERANCE,
    exact_limit: int | None = None,
    progress: bool = True,
) -> Placement:
    """Propose a local observer for every cluster (or one) of ``system``.

    Parameters
    ----------
    system : System
    cluster : str, optional
        Only this cluster.
    suspected : str or sequence of labels
        See :func:`suspected_set`.
    tol : Tolerance
    exact_limit : int, optional
        See :func:`place_cluster`.
    progress : bool
        Show tqdm progress bars on stderr (only when stderr is a terminal).

    Raises
    ------
    NotApplicableError
        When the system has no clusters or a cluster cannot be covered (message explains why).
    """
    if not system.clusters:
        raise NotApplicableError("the system has no clusters: add [[clusters]] tables to the spec")
    names = [c.name for c in system.clusters] if cluster is None else [system.cluster(cluster).name]
    props = []
    for name in tqdm(names, desc="clusters", unit="cluster", disable=None if progress and len(names) > 1 else True, leave=False):
        props.append(place_cluster(system, name, suspected, tol=tol, exact_limit=exact_limit, progress=progress))
    label = suspected if isinstance(suspected, str) else ",".join(map(str, suspected))
    return Placement(system.name, label, tuple(props), {c.name: c.nodes for c in system.clusters}, connectivity_warnings(system))


def connectivity_warnings(system: System) -> tuple[str, ...]:
    """One warning per mode whose communication graph G_q is disconnected.

    Combinatorial (connected components of the spec's positive-weight edges, exact): Lemma
    III.1 assumes every G_q connected, and on a disconnected graph each component converges to
    its own average, so "the consensus value" is not one number. Returned, not emitted: the
    CLI prints them on stderr, a library caller decides.

    Returns
    -------
    tuple of str
        Empty when every mode's graph is connected.
    """
    out = []
    for mode in system.modes:
        comps = system.components(mode)
        if len(comps) > 1:
            shown = "; ".join("{" + ", ".join(map(str, c[:6])) + (", ..." if len(c) > 6 else "") + "}" for c in comps[:4])
            more = f" and {len(comps) - 4} more" if len(comps) > 4 else ""
            out.append(
                f"warning: the {mode} graph is disconnected ({len(comps)} components: {shown}{more}); "
                "Lemma III.1 assumes a connected graph and each component converges to its own average"
            )
    return tuple(out)
