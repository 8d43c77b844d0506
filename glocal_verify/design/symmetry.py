"""Safe modes that break a symmetry of the normal graph: several links with chosen weights.

A symmetry of the weighted normal graph (twin agents, clusters a rotation maps onto each
other) repeats eigenvalues of L_1. A one-link mode cannot meet Theorem III.3 there, and the
number of links a mode needs follows from the interlacing bound.

The interlacing bound (proof)
    Let mu be an eigenvalue of L_1 of multiplicity m with eigenspace E, and let the mode change
    links so that dL_q = L_q - L_1 has rank r. Every v in E ∩ ker dL_q (a subspace of dimension
    at least m - r) satisfies L_q v = mu v, so mu keeps multiplicity at least m - r in L_q.

    * (ii) therefore needs r >= m - 1.
    * (i) reads rank(S_M dL_q) = rank(dL_q); S_M dL_q has |M| rows, so r <= |M ∩ D| <= |M|:
      the mode needs at least m - 1 monitored agents in its switching components.
    * (iii), for changes of one sign on a forest of links (what the search proposes): dL_q =
      B D B^T with B of full column rank and D definite, so dL_q v = 0 iff B^T v = 0, i.e. v
      takes equal values at the two ends of every changed link. So E ∩ ker B^T = {0} is
      needed, which asks for at least m links whose difference vectors U_E[i] - U_E[j] span
      R^m; and by (i) for m monitored agents.

    So no safe mode meets (i)-(iii) when m - 1 exceeds the number of agents that can be
    monitored, whatever its links and weights (:func:`symmetry_obstacle`; the multiplicity is
    read from the exact characteristic polynomial, so the statement is proven).

The search (guided by the eigenvectors of the repeated eigenvalues)
    Links are chosen one at a time, greedily: first the rank each adds to the matrices
    [U_E[i] - U_E[j]] of the repeated eigenspaces still deficient (one rank-one update of
    L_1 lowers the multiplicity of mu iff its vector is not orthogonal to E), then the fewest
    velocity monitors (i) asks for, then the attack directions it touches. Changes are
    positive (added links, raised weights), on a forest, and never join two twins (a link
    between twins keeps them twins: every other eigenvector is equal at both). The weights
    are generic, distinct rationals: a unit weight on links a symmetry maps onto each other
    keeps that symmetry, and with it the repeated eigenvalue.

    Each proposal is decided by the rule functions of Theorem III.3
    (:func:`~glocal_verify.analysis.switching.image_kernel.image_kernel_verdict`,
    :func:`~glocal_verify.analysis.switching.eigenstructure.distinct_eigenvalues_verdict`,
    :func:`~glocal_verify.analysis.switching.eigenstructure.eigenvector_differences_verdict`);
    several weightings are decided on one system, whose safe-mode spectra are rank-one
    updates of the one eigendecomposition of L_1 when a mode changes few links. A pair the
    rule names as failing (iii) bans the link at it, and the plan is drawn again.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from fractions import Fraction
from typing import Any

import numpy as np

from glocal_verify import config
from glocal_verify.analysis.switching.eigenstructure import distinct_eigenvalues_verdict, eigenvector_differences_verdict
from glocal_verify.analysis.switching.image_kernel import image_kernel_verdict
from glocal_verify.design.multilink import link_forest
from glocal_verify.model import System
from glocal_verify.numerics import exact as ex
from glocal_verify.results import Status
from glocal_verify.spec.types import EdgeSpec, Label, ModeSpec, MonitorSpec, SystemSpec

__all__ = [
    "GENERIC_WEIGHTS",
    "BrokenSymmetry",
    "Eigenspace",
    "LinkPlan",
    "blocking_reason",
    "repeated_obstacle",
    "SymmetryTarget",
    "break_symmetry",
    "candidate_pool",
    "exact_multiplicity",
    "forest_monitors",
    "plan_links",
    "repeated_eigenspaces",
    "split_normal_weights",
    "symmetry_obstacle",
    "theorem_verdicts",
    "weighted_mode",
    "with_monitors",
]

#: weights of the changed links of a symmetry-breaking mode, tried in rotation (distinct and
#: not in the ratio of the unit weights a symmetry maps onto each other)
GENERIC_WEIGHTS = (Fraction(3, 2), Fraction(5, 3), Fraction(7, 4), Fraction(4, 3), Fraction(5, 2), Fraction(7, 3),
                   Fraction(9, 4), Fraction(6, 5), Fraction(11, 4), Fraction(8, 5), Fraction(13, 6), Fraction(10, 7))
#: a candidate adds rank to an eigenspace when its projection off the chosen rows exceeds this (relative)
RANK_TOL = 1e-7


@dataclass(frozen=True)
class Eigenspace:
    """A repeated eigenvalue of L_1 and an orthonormal basis of its eigenspace (floating point).

    Attributes
    ----------
    value : float
    basis : ndarray (N, m)
    """

    value: float
    basis: np.ndarray

    @property
    def multiplicity(self) -> int:
        """m, the number of basis vectors."""
        return int(self.basis.shape[1])


def repeated_eigenspaces(system: System) -> tuple[Eigenspace, ...]:
    """The eigenvalues of L_1 the certified radius cannot separate, with their eigenvectors.

    A guide for the search, not a verdict: a cluster of the spectrum may hold distinct exact
    eigenvalues (then breaking it costs nothing more). :func:`exact_multiplicity` proves one.
    """
    sp = system.spectrum()
    out = []
    for c in sp.clusters:
        if len(c) > 1:
            out.append(Eigenspace(float(np.mean(sp.values[list(c)])), np.asarray(sp.columns(list(c)))))
    return tuple(out)


def exact_multiplicity(system: System) -> int:
    """The largest multiplicity of an eigenvalue of L_1, from its exact characteristic polynomial.

    p = prod f_k^{e_k} over Q with f_k irreducible and squarefree; a root of f_k is an
    eigenvalue of algebraic (= geometric, L_1 symmetric) multiplicity e_k.
    """
    p = ex.charpoly(system.laplacian_exact())
    num = p.numer() if hasattr(p, "numer") else p
    return max((int(e) for _, e in num.factor()[1]), default=1)


def symmetry_obstacle(system: System, monitor_room: int, max_links: int | None) -> str:
    """A proof that no safe mode meets Theorem III.3 (ii)-(iii), or ``""`` when the counts allow one.

    With m the largest multiplicity of an eigenvalue of L_1 (exact), (ii) needs rank(dL_q) >=
    m - 1, while (i) bounds rank(dL_q) by the monitored agents (at most |M| + ``monitor_room``)
    and a change of s links has rank at most s: no mode at all. For the modes the search
    proposes (one sign, a forest), (iii) needs m links and m monitored agents: none of them
    (module docstring).

    Parameters
    ----------
    system : System
    monitor_room : int
        Velocity monitors the design may still add.
    max_links : int, optional
        Largest number of links of one mode (None: no bound).
    """
    if not repeated_eigenspaces(system):
        return ""
    m = exact_multiplicity(system)
    if m <= 1:
        return ""
    can_monitor = len(system.monitored) + max(monitor_room, 0)
    out = []
    if m - 1 > can_monitor:
        out.append(f"(i) allows rank(dL_q) <= |M| = {can_monitor} (the {len(system.monitored)} monitored agents and {max(monitor_room, 0)} more within the budget)")
    if max_links is not None and m - 1 > max_links:
        out.append(f"a mode of at most {max_links} link(s) has rank(dL_q) <= {max_links}")
    if not out and max_links == 1:
        # one link: dL_q = delta b b^T, and E ∩ b^perp (dimension >= m - 1 >= 1) stays an eigenspace with v_i = v_j
        return (f"proven: L_1 has an eigenvalue of multiplicity {m} (exact characteristic polynomial), and a one-link mode (dL_q = delta b b^T, "
                f"b = e_i - e_j) keeps every eigenvector v of it with v_i = v_j (a subspace of dimension >= {m - 1}), so Theorem III.3 (ii) or (iii) "
                "fails for every link and weight; modes of several links (--max-links), or changed weights of the normal graph, remove the obstacle")
    if not out:
        few = []
        if m > can_monitor:
            few.append(f"{m} monitored agents in their components (at most {can_monitor} can be monitored)")
        if max_links is not None and m > max_links:
            few.append(f"{m} links (at most {max_links})")
        if not few:
            return ""
        return (f"proven for the modes the design proposes (changes of one sign on a forest of links): L_1 has an eigenvalue of multiplicity {m} "
                f"(exact characteristic polynomial); such a change keeps every eigenvector v of it with equal values across each changed link "
                f"unless the links' vectors U_E[i] - U_E[j] span its eigenspace, and Theorem III.3 (i) then asks "
                + " and ".join(few) + "; more monitors, or changed weights of the normal graph (--normal-weights), remove the obstacle")
    return (f"proven: L_1 has an eigenvalue of multiplicity {m} (exact characteristic polynomial), and a mode whose dL_q has rank r leaves it "
            f"multiplicity >= {m} - r, so Theorem III.3 (ii) needs rank(dL_q) >= {m - 1}; but " + " and ".join(out)
            + "; more monitors, or changed weights of the normal graph, remove the obstacle")


def forest_monitors(pairs: Sequence[tuple[int, int]], monitored: set[int], prefer: Callable[[int], float] | None = None) -> set[int] | None:
    """The fewest unmonitored agents to monitor so that Theorem III.3 (i) holds for positive changes on a forest.

    A tree component of c links, its changes of one sign, is the Laplacian of a connected
    graph: rank c, and any c of its c + 1 rows are independent, so (i) holds iff c of its
    agents are monitored. None if ``pairs`` is not a forest.

    Parameters
    ----------
    pairs : sequence of (int, int)
    monitored : set of int
    prefer : callable, optional
        Score of an agent (higher first) among a component's unmonitored agents.
    """
    comps = link_forest(list(pairs))
    if comps is None:
        return None
    add: set[int] = set()
    for c in comps:
        free = [a for a in c if a not in monitored]
        need = len(c) - 1 - (len(c) - len(free))
        if need > 0:
            free.sort(key=lambda a: -(prefer(a) if prefer is not None else 0.0))
            add.update(free[:need])
    return add


@dataclass(frozen=True)
class LinkPlan:
    """The links of a symmetry-breaking mode (agent indices), before weights.

    Attributes
    ----------
    pairs : tuple of (int, int)
    existing : tuple of bool
        Per pair: a link of the normal graph (its weight is raised) or a new one.
    monitors : tuple of int
        Agents to monitor for Theorem III.3 (i).
    deficient : int
        Eigenspace dimensions the links leave unbroken (0: the plan meets the interlacing bound).
    """

    pairs: tuple[tuple[int, int], ...]
    existing: tuple[bool, ...]
    monitors: tuple[int, ...]
    deficient: int


def _twins(L: np.ndarray, i: int, j: int) -> bool:
    keep = np.ones(L.shape[0], dtype=bool)
    keep[[i, j]] = False
    return bool(np.array_equal(L[i, keep], L[j, keep]))


def plan_links(
    system: System,
    spaces: Sequence[Eigenspace],
    monitored: set[int],
    pool: Sequence[tuple[int, int]],
    touches: Callable[[np.ndarray, np.ndarray], np.ndarray],
    *,
    room: int,
    max_links: int,
    banned: set[tuple[int, int]] = frozenset(),  # type: ignore[assignment]
) -> LinkPlan | None:
    """Greedy links (module docstring): rank on the deficient eigenspaces, then monitors, then touched targets.

    Parameters
    ----------
    system : System
    spaces : sequence of Eigenspace
        The repeated eigenspaces to break (may be empty: then links are chosen for the targets).
    monitored : set of int
    pool : sequence of (int, int)
        Candidate pairs (i < j), new or existing links.
    touches : callable
        ``touches(I, J)`` -> per candidate the number of targets left that a link i-j touches.
    room : int
        Velocity monitors that may be added.
    max_links : int
    banned : set of (int, int)
        Pairs never chosen.

    Returns
    -------
    LinkPlan or None
        None when no link can be chosen.
    """
    L = system.laplacian()
    edges = {frozenset(system.idx(tuple(k))) for k in system.edges()}
    cand = [p for p in pool if p not in banned and not _twins(L, *p)]
    if not cand:
        return None
    I = np.array([p[0] for p in cand], dtype=np.intp)
    J = np.array([p[1] for p in cand], dtype=np.intp)
    diffs = [s.basis[I] - s.basis[J] for s in spaces]  # per space: (P, m)
    scale = [max(float(np.max(np.linalg.norm(d, axis=1), initial=0.0)), 1e-300) for d in diffs]
    chosen_rows: list[list[np.ndarray]] = [[] for _ in spaces]
    need = [s.multiplicity for s in spaces]
    touched = touches(I, J).astype(float)
    sel: list[int] = []
    mon = set(monitored)
    while len(sel) < max_links:
        gain = np.zeros(len(cand))
        for k, d in enumerate(diffs):
            if need[k] <= 0:
                continue
            R = d
            if chosen_rows[k]:
                Q = np.linalg.qr(np.array(chosen_rows[k]).T)[0]  # (m, r)
                R = d - (d @ Q) @ Q.T
            gain += np.linalg.norm(R, axis=1) > RANK_TOL * scale[k]
        deficient = any(x > 0 for x in need)
        best, best_key = -1, None
        for p in range(len(cand)):
            if p in sel:
                continue
            if deficient and gain[p] <= 0:
                continue
            if not deficient and touched[p] <= 0:
                continue
            pairs = [cand[q] for q in sel] + [cand[p]]
            extra = forest_monitors(pairs, mon)
            if extra is None or len(extra) > room:
                continue
            key = (gain[p], -len(extra), touched[p], -p)
            if best_key is None or key > best_key:
                best, best_key = p, key
        if best < 0:
            break
        if not deficient and sel and best_key is not None and best_key[1] < 0:
            break  # after the bound: only links that need no monitor
        sel.append(best)
        extra = forest_monitors([cand[q] for q in sel], mon) or set()
        room -= len(extra)
        mon |= extra
        for k, d in enumerate(diffs):
            if need[k] > 0 and gain[best] > 0:
                row = d[best]
                R = row
                if chosen_rows[k]:
                    Q = np.linalg.qr(np.array(chosen_rows[k]).T)[0]
                    R = row - (row @ Q) @ Q.T
                if np.linalg.norm(R) > RANK_TOL * scale[k]:
                    chosen_rows[k].append(row)
                    need[k] -= 1
        touched[best] = 0.0
        if not any(x > 0 for x in need) and not np.any(touched[[q for q in range(len(cand)) if q not in sel]] > 0):
            break
    if not sel:
        return None
    chosen_pairs = tuple(cand[q] for q in sel)
    return LinkPlan(chosen_pairs, tuple(frozenset(p) in edges for p in chosen_pairs), tuple(sorted(mon - set(monitored))), int(sum(max(x, 0) for x in need)))


def weighted_mode(system: System, plan: LinkPlan, name: str, weights: Sequence[Fraction], description: str = "") -> ModeSpec:
    """The plan as a mode: a new link gets its weight, an existing one its weight raised by it (removed and added again)."""
    add: list[EdgeSpec] = []
    remove: list[tuple[Label, Label]] = []
    edges = system.edges()
    for (i, j), old, w in zip(plan.pairs, plan.existing, weights):
        u, v = system.labels[i], system.labels[j]
        if old:
            remove.append((u, v))
            add.append(EdgeSpec(u, v, edges[frozenset((u, v))] + w))
        else:
            add.append(EdgeSpec(u, v, w))
    return ModeSpec(name, tuple(add), tuple(remove), description)


def with_monitors(spec: SystemSpec, labels: Sequence[Label]) -> SystemSpec:
    """``spec`` with velocity monitors added at ``labels`` (none at positions is changed)."""
    if not labels:
        return spec
    order = {a: k for k, a in enumerate(spec.nodes)}
    vel = sorted(set(spec.monitor.velocities) | set(labels), key=order.__getitem__)
    return dataclasses.replace(spec, monitor=MonitorSpec(spec.monitor.positions, tuple(vel)))


def theorem_verdicts(system: System, mode: str) -> dict[str, Status]:
    """Theorem III.3 (i)-(iii) of one mode by the rule functions (certified numeric), in order, stopping at the first that does not hold."""
    out: dict[str, Status] = {}
    for cid, rule in (("switching.image-kernel", image_kernel_verdict), ("switching.distinct-eigenvalues", distinct_eigenvalues_verdict),
                      ("switching.eigenvector-differences", eigenvector_differences_verdict)):
        v = rule(system, mode)
        out[cid] = v.status
        if v.status is not Status.HOLDS:
            out["pair"] = v.witness.get("pair") if isinstance(v.witness, dict) else None  # type: ignore[assignment]
            break
    return out


@dataclass(frozen=True)
class SymmetryTarget:
    """An attack set to expose and its stealthy kernel at the exponent the design targets.

    Attributes
    ----------
    F : tuple of labels
    X : ndarray (N, r)
        xi-orthonormal basis of the possible stealthy kernel.
    B : ndarray (m, r)
        Its input part.
    """

    F: tuple[Label, ...]
    X: np.ndarray
    B: np.ndarray


@dataclass(frozen=True)
class BrokenSymmetry:
    """A symmetry-breaking mode the rules admitted and the confirmations kept.

    Attributes
    ----------
    links : tuple of (u, v, weight, old weight or None)
        Each changed link: a new link of ``weight`` (old None) or an existing one raised from
        ``old`` to ``weight``.
    monitors : tuple of labels
        Velocity monitors it adds for Theorem III.3 (i).
    exposes : tuple of attack sets
    verification : mapping
        Condition id -> status from the confirmation.
    """

    links: tuple[tuple[Label, Label, Fraction, Fraction | None], ...]
    monitors: tuple[Label, ...]
    exposes: tuple[tuple[Label, ...], ...]
    verification: Mapping[str, str]


#: confirm(links, name, claimed sets, monitors) -> (confirmed sets, Theorem III.3 statuses)
Confirm = Callable[[Sequence[tuple[Label, Label, Fraction, Fraction | None]], str, Sequence[tuple[Label, ...]], Sequence[Label]], tuple[list[tuple[Label, ...]], Mapping[str, str]]]


def candidate_pool(system: System, distance: int) -> list[tuple[int, int]]:
    """Pairs i < j: the links of the normal graph (raised weights) and new links between agents at distance 2..``distance`` (all pairs when None-like large)."""
    import networkx as nx

    G = system.graph()
    out = {tuple(sorted(system.idx(tuple(k)))) for k in system.edges()}
    for u in system.labels:
        for v, d in nx.single_source_shortest_path_length(G, u, cutoff=distance).items():
            if d >= 2:
                out.add(tuple(sorted((system.index[u], system.index[v]))))
    return sorted(out)  # type: ignore[arg-type]


def _touch_counts(targets: Sequence[SymmetryTarget], left: Sequence[int], thr: float) -> Callable[[np.ndarray, np.ndarray], np.ndarray]:
    """``touches(I, J)``: per candidate link, the targets in ``left`` one of whose stealthy directions it touches."""

    def touches(I: np.ndarray, J: np.ndarray) -> np.ndarray:
        out = np.zeros(len(I))
        for t in left:
            X = targets[t].X
            if X.shape[1] == 0 or float(np.linalg.norm(targets[t].B)) <= thr:
                continue
            out += np.any(np.abs(X[I] - X[J]) > thr, axis=1)
        return out

    return touches


def break_symmetry(
    system: System,
    targets: Sequence[SymmetryTarget],
    todo: set[int],
    *,
    slots: int,
    max_links: int | None,
    room: int,
    confirm: Confirm,
    thr: float,
    first: int = 1,
    say: Callable[[str], None] | None = None,
) -> tuple[list[BrokenSymmetry], set[int], list[str]]:
    """Modes of several links with generic weights for the targets in ``todo`` (module docstring, "The search").

    Parameters
    ----------
    system : System
    targets : sequence of SymmetryTarget
    todo : set of int
        Indices of the targets to expose.
    slots : int
        Largest number of modes.
    max_links : int, optional
        Largest number of links of a mode (None: the tunable ``symmetry_max_links``).
    room : int
        Velocity monitors the modes may add in all.
    confirm : callable
        Re-verification of a proposal (Theorem III.3 by the checkers, each claimed set by the
        rule of ``switching.avoids-attack``).
    thr : float
        Zero threshold of the touch tests.
    first : int
        Number of the first mode's name (``designed-<first>``).
    say : callable, optional
        Progress lines.

    Returns
    -------
    (modes, covered target indices, notes)
    """
    from glocal_verify.design.multilink import touch_cover

    cap = int(config.get("symmetry_max_links")) if max_links is None else max_links
    spaces = repeated_eigenspaces(system)
    monitored = set(system.idx(system.monitored))
    out: list[BrokenSymmetry] = []
    covered: set[int] = set()
    notes: list[str] = []
    pools = [candidate_pool(system, d) for d in (2, 3)] + ([[(i, j) for i in range(system.n) for j in range(i + 1, system.n)]] if system.n <= 200 else [])
    while todo - covered and len(out) < slots:
        left = sorted(todo - covered)
        touches = _touch_counts(targets, left, thr)
        name = f"designed-{first + len(out)}"
        made: BrokenSymmetry | None = None
        banned: set[tuple[int, int]] = set()
        for _ in range(int(config.get("symmetry_plan_tries"))):
            plan = None
            for pool in pools:
                plan = plan_links(system, spaces, monitored, pool, touches, room=room, max_links=cap, banned=banned)
                if plan is not None and not plan.deficient:
                    break
            if plan is None or plan.deficient:
                if plan is not None:
                    notes.append(f"no forest of at most {cap} links with monitored agents within the budget breaks every repeated eigenvalue of L_1 "
                                 f"({plan.deficient} eigenspace dimension(s) left)")
                break
            mons = [system.labels[a] for a in plan.monitors]
            tries = weight_tries()
            modes = [weighted_mode(system, plan, f"try-{t}", [GENERIC_WEIGHTS[(t + k) % len(GENERIC_WEIGHTS)] for k in range(len(plan.pairs))])
                     for t in range(tries)]
            T = System(dataclasses.replace(with_monitors(system.spec, mons), modes=tuple(modes), switching=None))
            pair = None
            I = np.array([[p[0] for p in plan.pairs]], dtype=np.intp)
            J = np.array([[p[1] for p in plan.pairs]], dtype=np.intp)
            claim = [targets[t].F for t in left if touch_cover([(targets[t].X, targets[t].B)], I, J, thr)[0, 0]]
            for m in modes:
                got = theorem_verdicts(T, m.name)
                if any(st is not Status.HOLDS for k, st in got.items() if k != "pair"):
                    pair = got.get("pair") or pair
                    continue
                if not claim:
                    break
                links = tuple((e.u, e.v, e.weight, system.edges().get(e.key)) for e in m.add)
                if say is not None:
                    say(f"checking {name} ({len(links)} links breaking the symmetry of L_1) against the {len(claim)} attack sets it should expose")
                sets, statuses = confirm(links, name, claim, mons)
                if sets:
                    made = BrokenSymmetry(links, tuple(mons), tuple(sets), dict(statuses))
                break
            if made is not None:
                break
            # ban a link at the pair the rule named, else the plan's last link, and plan again
            culprit = plan.pairs[-1]
            if pair is not None:
                at = set(system.idx(tuple(pair)))
                culprit = next((p for p in plan.pairs if set(p) & at), culprit)
            banned.add(culprit)
        if made is None:
            break
        out.append(made)
        exposed = set(made.exposes)  # once: it holds the deferred claims too, thousands at N = 200
        covered |= {t for t in left if targets[t].F in exposed}
        monitored |= set(system.idx(made.monitors))
        room -= len(made.monitors)
    return out, covered, notes


def split_normal_weights(system: System, tries: int = 4) -> tuple[dict[tuple[Label, Label], Fraction], str]:
    """Weights of links of the normal graph whose change splits every repeated eigenvalue of L_1, and a line saying so.

    Changing the weight of link i-j by delta adds delta (e_i - e_j)(e_i - e_j)^T: on an
    eigenspace E it acts through U_E[i] - U_E[j], so an eigenvalue of multiplicity m needs
    m - 1 changed links whose vectors have rank m - 1 on E (the interlacing bound of the module
    docstring). The links are chosen greedily by that rank, the weights raised by generic
    amounts, and the result is accepted when the certified spectrum of the new L_1 has no
    cluster (every eigenvalue certified simple).

    Returns
    -------
    (mapping, str)
        ``(u, v)`` -> new weight (empty when L_1 is already simple or no choice was found) and
        a line for the design's notes.
    """
    spaces = [dataclasses.replace(e, basis=e.basis) for e in repeated_eigenspaces(system)]
    if not spaces:
        return {}, ""
    need = {k: e.multiplicity - 1 for k, e in enumerate(spaces)}
    pool: list[tuple[int, int]] = sorted((min(a, b), max(a, b)) for a, b in (system.idx(tuple(k)) for k in system.edges()))
    rows: dict[int, list[np.ndarray]] = {k: [] for k in need}
    chosen: list[tuple[int, int]] = []
    for _ in range(sum(need.values())):
        best, gain_best = None, 0
        for p in pool:
            if p in chosen:
                continue
            gain = 0
            for k, e in enumerate(spaces):
                if need[k] <= 0:
                    continue
                d = e.basis[p[0]] - e.basis[p[1]]
                R = d
                if rows[k]:
                    Q = np.linalg.qr(np.array(rows[k]).T)[0]
                    R = d - Q @ (Q.T @ d)
                gain += float(np.linalg.norm(R)) > RANK_TOL
            if gain > gain_best:
                best, gain_best = p, gain
        if best is None:
            break
        chosen.append(best)
        for k, e in enumerate(spaces):
            d = e.basis[best[0]] - e.basis[best[1]]
            if need[k] > 0:
                R = d if not rows[k] else d - (Q := np.linalg.qr(np.array(rows[k]).T)[0]) @ (Q.T @ d)
                if float(np.linalg.norm(R)) > RANK_TOL:
                    rows[k].append(d)
                    need[k] -= 1
    edges = system.edges()
    for t in range(tries):
        new = {}
        for k, (i, j) in enumerate(chosen):
            u, v = system.labels[i], system.labels[j]
            new[(u, v)] = edges[frozenset((u, v))] + GENERIC_WEIGHTS[(t + k) % len(GENERIC_WEIGHTS)] - 1
        spec = dataclasses.replace(system.spec, edges=tuple(
            dataclasses.replace(e, weight=next((w for (u, v), w in new.items() if frozenset((u, v)) == e.key), e.weight)) for e in system.spec.edges))
        if chosen and all(len(c) == 1 for c in System(spec).spectrum().clusters):
            text = ", ".join(f"{u}-{v} ({edges[frozenset((u, v))]} -> {w})" for (u, v), w in new.items())
            return new, f"changed the normal graph's link weights {text}: every eigenvalue of L_1 is now certified simple"
    return {}, "no change of the normal graph's link weights found that makes every eigenvalue of L_1 simple"


def repeated_obstacle(system: System) -> str:
    """Why the one-link search cannot start on a repeated spectrum of L_1, and which weight change would break the symmetry.

    A repeated eigenvalue of L_1 comes from a symmetry of the weighted graph (a rotation of a
    ring, twin leaves of a hub ...). Changing the weight of a link i-j adds a multiple of
    (e_i - e_j)(e_i - e_j)^T, which on the eigenspace U_g is the rank-one (U_g[i] - U_g[j])
    outer product: it splits the eigenvalue iff U_g[i] != U_g[j]. The link named is one of the
    normal graph that splits the most repeated eigenvalues (floating point: a suggestion to try,
    not a verdict).
    """
    sp = system.spectrum()
    groups = [g for g in sp.clusters if len(g) > 1]
    U = np.asarray(sp.vectors)
    w = np.asarray(sp.values)
    shown = ", ".join(f"{float(w[g[0]]):.4g} (multiplicity {len(g)})" for g in groups[:4]) + (f" and {len(groups) - 4} more" if len(groups) > 4 else "")
    best, count = None, -1
    for key in system.edges():
        i, j = (system.index[a] for a in key)
        c = sum(1 for g in groups if float(np.linalg.norm(U[i, list(g)] - U[j, list(g)])) > 1e-6)
        if c > count:
            best, count = tuple(sorted(key, key=system.index.__getitem__)), c
    hint = ""
    if best is not None and count > 0:
        hint = (f"; changing the weight of the normal graph's link {best[0]}-{best[1]} would split {count} of these {len(groups)} "
                "(a weight change of link i-j splits an eigenvalue whose eigenvectors differ at i and j), after which the design can run")
    return (
        f"L_1 has repeated eigenvalues ({shown}), the mark of a symmetry of the weighted graph (e.g. a rotation of a ring with equal "
        "weights): the one-link search needs a simple spectrum, and Theorem III.3 (ii) asks every safe mode for distinct eigenvalues" + hint
    )


def blocking_reason(system: System, cands: Sequence[Any], err: np.ndarray | None) -> str:
    """Why no one-link candidate (``LinkCandidate``) meets (i)-(iii): the reason met most often, with its eigenvector (``err``: :func:`~glocal_verify.design.safe_modes.eigenvector_error`)."""
    if err is None:
        return repeated_obstacle(system)
    M = set(system.monitored)
    near = [c for c in cands if c.u in M or c.v in M]
    if not near:
        return "no candidate link has a monitored endpoint, so Theorem III.3 (i) fails for every one-link mode"
    U = np.asarray(system.spectrum().vectors)
    counts = np.zeros(system.n, dtype=int)
    for c in near[:4096]:
        z = np.abs(U[system.index[c.u], 1:] - U[system.index[c.v], 1:])
        counts[1:] += z <= err[1:]
    k = int(np.argmax(counts))
    if counts[k] == 0:
        return "every candidate with a monitored endpoint is a bridge removal"
    supp = [system.labels[i] for i in np.flatnonzero(np.abs(U[:, k]) > 1e-8)]
    return (
        f"Theorem III.3 (iii): eigenvector {k + 1} of L_1 (eigenvalue {float(system.spectrum().values[k]):.6g}) has equal entries at "
        f"{counts[k]} of the {min(len(near), 4096)} candidate pairs with a monitored endpoint (it lives on agents {supp[:12]}); a one-link "
        "mode keeps it, so only links touching its support can meet (iii)"
    )


def weight_tries() -> int:
    """Weightings tried per plan (the tunable ``symmetry_weight_tries``)."""
    return int(config.get("symmetry_weight_tries"))
