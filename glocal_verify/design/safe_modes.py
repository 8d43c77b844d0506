"""Design safe modes (Theorem III.3) that expose every stealthy attack of an audit.

A candidate safe mode changes one link of the normal graph (or, for the attacks no such
mode exposes, a few links: "Multi-link modes" below): it adds a link {i, j} with a
weight w from a small set, or removes an existing link of weight w. Then
dL = delta b b^T with b = e_i - e_j and delta = +w (addition) or -w (removal): a rank-one
update of L_1. Nothing here computes a fresh eigendecomposition per candidate.

Theorem III.3 for one link, from the rank-one structure (proof)
    Write L_1 = U diag(mu) U^T (mu_1 = 0 < mu_2 < ... < mu_N, certified distinct) and
    z = U^T b, so z_k = u_k(i) - u_k(j) and z_1 = 0 (u_1 is constant). In the basis U,
    L_q = diag(mu) + delta z z^T. Suppose z_k != 0 for every k >= 2.

    * (ii) Golub's secular equation: the eigenvalues of L_q other than the deflated 0 are the
      roots x of f(x) = 1 + delta sum_{k>=2} z_k^2 / (mu_k - x). For delta > 0 they interlace
      strictly, mu_2 < x_2 < mu_3 < ... < mu_N < x_N, so L_q has N distinct eigenvalues. For
      delta < 0 the roots satisfy x_2 < mu_2 < x_3 < ... < x_N < mu_N, and f decreases from 1
      on (-inf, mu_2), so x_2 > 0 = x_1 iff f(0) = 1 - w b^T L_1^+ b > 0, i.e. the removed link
      is not a bridge (w R_eff(i, j) < 1).
    * (iii) The eigenvector for the root x_l is v_l = U (diag(mu) - x_l)^{-1} z, and
      v_l(i) - v_l(j) = b^T v_l = z^T (diag(mu) - x_l)^{-1} z = -1 / delta != 0 by the
      secular equation: every eigenvector but the constant one separates i and j, for every
      weight.
    * Conversely, z_k = 0 for some k >= 2 keeps u_k an eigenvector of L_q with u_k(i) = u_k(j):
      (iii) fails (or (ii), when its eigenvalue is no longer simple).
    * (i) Im(dL) = span(b) meets ker S_M only in 0 iff i or j is monitored; then Lemma A.2's
      coverage holds too.

    So a one-link mode meets (i)-(iii) iff an endpoint is monitored, z_k != 0 for k >= 2 (and,
    for a removal, w R_eff < 1): O(N) per candidate once U is known, whatever the weight. The
    screen lets a candidate through when |z_k| exceeds its bound 2 s_k + sqrt(2) eta + 4 eps
    (s_k the Davis-Kahan bound on the angle of u_k, :meth:`Spectrum.subspace_sine`, vectorised
    here with the same constants; eta the loss of orthonormality). It is a filter that states
    no verdict: a candidate is admitted only when the rule functions of (i)-(iii) hold for it
    (:class:`_OneLinkRules`, decided when the greedy cover picks it).

Exposure (Remark III.3.1, ``switching.avoids-attack``)
    For an attack set F with exponent lambda0 (the audit's), the stealthy kernel Z at lambda0
    is computed once (:func:`glocal_verify.analysis.switching.avoidance.stealthy_bases`, the possible
    kernel, orthonormalised in xi). A one-link mode gives dL xi = delta b (b^T xi), so the
    switch is avoidable iff some c with (b^T X) c = 0 has a nonzero input part B c. For
    dim Z = 1 this is b^T x = 0; in general one SVD of size dim Z.

Multi-link modes (attacks no one-link mode exposes)
    A mode changing s candidate links at once has dL = B D B^T, B = [b_1 .. b_s] and
    D = diag(delta_1 .. delta_s): a rank-s update of L_1. Only forests of links are
    searched (no repeated pair, no cycle), so B has full column rank and rank dL = s.

    * (i) rank(S_M dL) = rank(S_M B) (B^T has full row rank, D is invertible), decided over
      Q from the incidence entries. A tree component with c links needs c monitored agents
      among its c + 1, so every link needs a monitored endpoint (a pre-filter).
    * Exposure: dL X c = B D (B^T X) c = 0 iff (B^T X) c = 0, so the switch is unavoidable
      iff every c in ker(X[I] - X[J]) (an s x r matrix) has B c = 0: one batched SVD over
      all changes. For dim Z = 1 a change exposes iff one of its links touches the direction;
      two links can then help only by making (ii)-(iii) hold where each link alone fails
      them. For dim Z = 2 two links may pin the kernel where one cannot.
    * (ii)-(iii) screen: s successive rank-one updates in the eigenbasis of L_1 (the secular
      equation above, deflating z_k = 0, which is how one link failing (iii) on u_k can be
      repaired by a second link with z_k != 0), carrying the coordinates of every difference
      e_i - e_j of a pair in one switching component; O(s N^2) per bisection step, no fresh
      eigendecomposition. The screen is not a proof; it only orders the proposals
      (:mod:`glocal_verify.design.multilink` holds this machinery and its thresholds).

    Changes are scored against the remaining attacks (at most ``safe_modes_max_combinations`` per size,
    size 2 first, then up to ``max_links``), and the best-scoring ones are screened (at most
    ``safe_modes_max_screens`` per chosen mode, fewer for large N: ``safe_modes_max_screen_work``) and re-verified as below: so a multi-link mode is
    proposed only for attacks no one-link mode exposes, with as few links as the search finds.

Modes that break a symmetry (attacks no one- or two-link mode exposes)
    A repeated eigenvalue of L_1 of multiplicity m needs a change of rank >= m - 1 for (ii),
    and m links with monitored agents for (iii): :mod:`glocal_verify.design.symmetry` chooses
    them by the eigenvectors of the repeated eigenvalues, with generic weights and the
    velocity monitors (i) asks for (``monitor_room``), or proves that none can exist.

Search and verification
    Greedy set cover over the admissible candidates (each covers the attacks it exposes),
    at most ``budget`` modes, so the number of modes is within a factor H(n) = 1 + 1/2 + ... +
    1/n of the fewest one-link modes that expose the n attacks. Every proposed mode is then
    re-verified on the spec with that mode, exactly over Q when ``exact`` (default for
    N <= 40): Theorem III.3 by its checkers (``switching.image-kernel``,
    ``-distinct-eigenvalues``, ``-eigenvector-differences``; once per mode, no attack enters
    them), and each claimed attack by the rule of ``switching.avoids-attack`` at the audit's
    lambda0 for that set (one system with the mode for all the sets: O(targets) checks of
    milliseconds each, no fresh system and no exact re-decision per set). A claim that is not
    confirmed is dropped and the search continues without it.
"""

from __future__ import annotations

import dataclasses
import math
import time
from dataclasses import dataclass, field
from fractions import Fraction
from typing import Any, Callable, Iterable, Mapping, Sequence

import numpy as np

from glocal_verify import config
from glocal_verify.analysis.switching.avoidance import avoiding_subspace, decide_avoidance, split_basis, stealthy_bases
from glocal_verify.analysis.stealthy.zda import ModalPencil
from glocal_verify.analysis.stealthy.zda_verdict import ZdaOptions, decide_zda
from glocal_verify.conditions.catalogue import THEOREM_III3_IDS as THEOREM_IDS
from glocal_verify.conditions.registry import check_conditions
from glocal_verify.design.symmetry import SymmetryTarget, blocking_reason, break_symmetry, symmetry_obstacle, theorem_verdicts, with_monitors
from glocal_verify.design.one_link import eigenvector_error, one_link_screen
from glocal_verify.design.multilink import (
    image_kernel_holds,
    link_forest,
    screen_changes,
    touch_cover,
)
from glocal_verify.errors import NotApplicableError
from glocal_verify.model import System
from glocal_verify.numerics.tolerance import DEFAULT_TOLERANCE, Tolerance
from glocal_verify.results import Status
from glocal_verify.spec.types import AttackSpec, EdgeSpec, Label, ModeSpec, SystemSpec

__all__ = [
    "LinkCandidate",
    "ProposedMode",
    "SafeModeDesign",
    "default_candidates",
    "eigenvector_error",
    "design_safe_modes",
    "with_modes",
    "with_attack",
]

DEFAULT_WEIGHTS = (Fraction(1), Fraction(2), Fraction(3))
#: attack sets between two progress reports of a mode's confirmation
CONFIRM_CHUNK = 50
#: a proposed mode none of whose first this many claimed sets is confirmed is dropped (the
#: rest is not checked), so a misjudged candidate costs a bounded number of checks
CONFIRM_GIVE_UP = 200


@dataclass(frozen=True, slots=True)
class LinkCandidate:
    """One admissible link change: add {u, v} with ``weight`` (``remove=False``), remove it, or
    (``was`` set) raise the weight of the normal graph's link {u, v} from ``was`` to ``weight``."""

    u: Label
    v: Label
    weight: Fraction
    remove: bool = False
    was: Fraction | None = None

    def describe(self) -> str:
        """``add 4-7 (w=1)``, ``remove 4-7`` or ``reweight 4-7 (1 -> 5/2)``."""
        if self.remove:
            return f"remove {self.u}-{self.v}"
        if self.was is not None:
            return f"reweight {self.u}-{self.v} ({self.was} -> {self.weight})"
        return f"add {self.u}-{self.v} (w={self.weight})"


@dataclass(frozen=True, slots=True)
class ProposedMode:
    """A designed safe mode and what the checkers confirmed about it.

    Attributes
    ----------
    name : str
    link : LinkCandidate
        The (first) link change.
    exposes : tuple of attack sets
        Attacks for which the checkers confirmed (i)-(iii) and ``switching.avoids-attack`` fails.
    verification : mapping
        Condition id -> status on the designed mode (the first attack's spec).
    method : str
        ``exact`` or ``numeric``.
    also : tuple of LinkCandidate
        Further link changes of a multi-link mode (empty for one link).
    monitors : tuple of labels
        Velocity monitors the mode added for Theorem III.3 (i) (a symmetry-breaking mode).
    """

    name: str
    link: LinkCandidate
    exposes: tuple[tuple[Label, ...], ...]
    verification: Mapping[str, str] = field(default_factory=dict)
    method: str = "exact"
    also: tuple[LinkCandidate, ...] = ()
    monitors: tuple[Label, ...] = ()

    @property
    def links(self) -> tuple[LinkCandidate, ...]:
        """Every link change of the mode: ``link`` first, then ``also``."""
        return (self.link,) + tuple(self.also)

    def describe(self) -> str:
        """The changes, e.g. ``add 4-7 (w=1) + remove 2-3``."""
        return " + ".join(c.describe() for c in self.links)

    def mode_spec(self) -> ModeSpec:
        """The mode as a spec table entry."""
        desc = f"{self.describe()}: Theorem III.3 (i)-(iii) hold and the switch touches {len(self.exposes)} audited attack(s)"
        add = tuple(EdgeSpec(c.u, c.v, c.weight) for c in self.links if not c.remove)
        remove = tuple((c.u, c.v) for c in self.links if c.remove or c.was is not None)
        return ModeSpec(self.name, add=add, remove=remove, description=desc)


@dataclass(frozen=True, slots=True)
class SafeModeDesign:
    """The result of :func:`design_safe_modes`.

    Attributes
    ----------
    modes : tuple of ProposedMode
    targets : tuple of attack sets
        The attacks the design had to expose.
    unexposed : mapping
        Attack set (as a string) -> why no admissible candidate within the budget exposes it.
    candidates : int
        Candidate link changes evaluated.
    evaluations_per_second : float
        Candidate evaluations ((i)-(iii) and the touch test against every target) per second.
    admissible : int
        Candidates meeting (i)-(iii).
    combinations : int
        Multi-link changes (2..``max_links`` candidates) scored against the targets no
        one-link mode exposes (0 when the one-link search sufficed).
    combinations_per_second : float
        Multi-link changes scored per second (the touch test against every remaining target).
    screened : int
        Multi-link changes whose (i)-(iii) were screened with the low-rank update.
    monitors : tuple of labels
        Velocity monitors the modes added (Theorem III.3 (i) of symmetry-breaking modes).
    notes : tuple of str
    """

    modes: tuple[ProposedMode, ...]
    targets: tuple[tuple[Label, ...], ...]
    unexposed: Mapping[str, str]
    candidates: int
    evaluations_per_second: float
    admissible: int
    combinations: int = 0
    combinations_per_second: float = 0.0
    screened: int = 0
    monitors: tuple[Label, ...] = ()
    notes: tuple[str, ...] = ()

    @property
    def complete(self) -> bool:
        """Every target is exposed by a verified mode."""
        return not self.unexposed

    def to_json(self) -> dict[str, Any]:
        """JSON form."""
        return {
            "modes": [
                {
                    "name": m.name,
                    "change": m.describe(),
                    "links": len(m.links),
                    "exposes": [list(F) for F in m.exposes],
                    "verification": dict(m.verification),
                    "method": m.method,
                }
                for m in self.modes
            ],
            "targets": [list(F) for F in self.targets],
            "unexposed": dict(self.unexposed),
            "candidates": self.candidates,
            "admissible": self.admissible,
            "evaluations_per_second": self.evaluations_per_second,
            "combinations": self.combinations,
            "combinations_per_second": self.combinations_per_second,
            "screened": self.screened,
            "monitors": list(self.monitors),
        }


# ------------------------------------------------------------------------------------------
# spec helpers


def with_modes(spec: SystemSpec, modes: Sequence[ModeSpec], *, keep: bool = True) -> SystemSpec:
    """``spec`` with ``modes`` appended (``keep``) or replacing its safe modes.

    Parameters
    ----------
    spec : SystemSpec
    modes : sequence of ModeSpec
    keep : bool
        Keep the spec's own safe modes.
    """
    base = tuple(spec.modes) if keep else ()
    sw = spec.switching
    if sw is not None and not keep:
        sw = None
    return dataclasses.replace(spec, modes=base + tuple(modes), switching=sw)


def with_attack(spec: SystemSpec, actuators: Sequence[Label]) -> SystemSpec:
    """``spec`` with a ZDA on ``actuators`` (the spec's lambda0 kept).

    Parameters
    ----------
    spec : SystemSpec
    actuators : sequence of labels
    """
    lam = spec.attack.lambda0 if spec.attack is not None else None
    return dataclasses.replace(spec, attack=AttackSpec("zda", tuple(actuators), lambda0=lam))


def default_candidates(system: System, weights: Sequence[Fraction] = DEFAULT_WEIGHTS, *, distance: int = 2, removals: bool = True) -> list[LinkCandidate]:
    """Default candidates: add a link between agents at graph distance 2..``distance``, or remove one.

    Parameters
    ----------
    system : System
    weights : sequence of Fraction
        Weights tried for an added link.
    distance : int
        Largest distance of the endpoints of an added link.
    removals : bool
        Also propose removing each existing link.
    """
    import networkx as nx

    G = system.graph()
    out: list[LinkCandidate] = []
    order = system.index
    for u in system.labels:
        near = nx.single_source_shortest_path_length(G, u, cutoff=distance)
        for v, d in near.items():
            if d >= 2 and order[v] > order[u]:
                out += [LinkCandidate(u, v, Fraction(w)) for w in weights]
    if removals:
        for key, w in system.edges().items():
            a, b = sorted(key, key=order.__getitem__)
            out.append(LinkCandidate(a, b, w, True))
    return out


# ------------------------------------------------------------------------------------------
# the search


def _targets(system: System, attacks: Sequence[Sequence[Label]], lambdas: Mapping[tuple[Label, ...], complex], tol: Tolerance) -> list[SymmetryTarget]:
    out = []
    for F in attacks:
        Ft = tuple(F)
        md = ModalPencil(system, Ft, tol)
        _, zp = stealthy_bases(md, complex(lambdas[Ft]))
        sp = split_basis(zp.x, zp.u, None, [], np.zeros((0, 0)), 0.0)
        out.append(SymmetryTarget(Ft, sp.Xo, sp.B))
    return out


def _exposes(t: SymmetryTarget, i: int, j: int, thr: float) -> bool:
    """Every stealthy direction with an input has xi_i != xi_j (the switch cannot be avoided):
    the touch test of ``switching.avoids-attack`` (:func:`~glocal_verify.analysis.switching.avoidance.avoiding_subspace`)
    for the one-link change i-j, with the screen's threshold."""
    a = t.X[i, :] - t.X[j, :]
    if a.shape[0] == 0 or float(np.linalg.norm(t.B)) <= thr:
        return False
    _, su, _ = avoiding_subspace(a.reshape(1, -1), t.B, thr)
    return bool(su.size == 0 or su[0] <= thr)


class _OneLinkRules:
    """Theorem III.3 (i)-(iii) of one-link candidates by the rule functions, decided once each.

    Candidates are decided in batches on one system holding them as modes, so the
    eigendecomposition of L_1 is shared and each mode's spectrum is one rank-one update of it.
    """

    def __init__(self, system: System, cands: Sequence[LinkCandidate]) -> None:
        self.system = system
        self.cands = cands
        self.known: dict[int, bool] = {}

    def decide(self, ks: Iterable[int], batch: int = 64) -> None:
        """Decide the candidates ``ks`` not decided yet."""
        todo = [k for k in dict.fromkeys(ks) if k not in self.known]
        for a in range(0, len(todo), batch):
            part = todo[a : a + batch]
            modes = [ProposedMode(f"c{k}", self.cands[k], ()).mode_spec() for k in part]
            T = System(with_modes(self.system.spec, modes, keep=False))
            for k, m in zip(part, modes):
                self.known[k] = all(st is Status.HOLDS for cid, st in theorem_verdicts(T, m.name).items() if cid != "pair")

    def holds(self, k: int) -> bool:
        """(i)-(iii) hold for candidate ``k`` by the rule functions."""
        self.decide([k])
        return self.known[k]


def _admissible(system: System, cands: Sequence[LinkCandidate], err: np.ndarray | None, chunk: int = 2048) -> np.ndarray:
    """Boolean mask: (i)-(iii) hold by the rule functions, decided for the candidates the one-link screen lets through."""
    ok = one_link_screen(system, cands, err, chunk)
    rules = _OneLinkRules(system, cands)
    rules.decide(np.flatnonzero(ok).tolist())
    return np.array([bool(ok[k]) and rules.known[k] for k in range(len(cands))], dtype=bool)


def _cover(system: System, cands: Sequence[LinkCandidate], ok: np.ndarray, tg: Sequence[SymmetryTarget], thr: float) -> list[set[int]]:
    """For every candidate, the targets it exposes (vectorised for one-dimensional kernels)."""
    cover: list[set[int]] = [set() for _ in cands]
    idx = [int(k) for k in np.flatnonzero(ok)]
    if len(idx) == 0 or not tg:
        return cover
    I = np.array([system.index[cands[k].u] for k in idx], dtype=np.int64)
    J = np.array([system.index[cands[k].v] for k in idx], dtype=np.int64)
    one = [t for t, x in enumerate(tg) if x.X.shape[1] == 1 and float(np.linalg.norm(x.B)) > thr]
    if one:
        X1 = np.column_stack([tg[t].X[:, 0] for t in one])
        hit = np.abs(X1[I] - X1[J]) > thr
        for row, k in enumerate(idx):
            cover[k].update(one[c] for c in np.flatnonzero(hit[row]))
    multi = [t for t, x in enumerate(tg) if x.X.shape[1] > 1]
    for t in multi:
        for row, k in enumerate(idx):
            if _exposes(tg[t], int(I[row]), int(J[row]), thr):
                cover[k].add(t)
    return cover


class _Confirmations:
    """Re-verification of proposed modes (module docstring, "Search and verification").

    Theorem III.3 (i)-(iii) are properties of the mode alone (no attack enters them): the
    checkers decide them once per mode. Whether the switch exposes each claimed attack is the
    rule of ``switching.avoids-attack`` (:func:`~glocal_verify.analysis.stealthy.zda_verdict.decide_zda`,
    then :func:`~glocal_verify.analysis.switching.avoidance.decide_avoidance`, as its checker calls
    them) at the set's own lambda0 from the audit, the exponent the design targeted: given,
    a rational lambda0 lets the numeric touch test be certified, where a computed one (the
    fastest zero found) could not be and went to an exact re-decision of up to 30 s per set.
    One system with the mode serves every set (its spectra computed once, where a checker run
    per set built a fresh one). An attack left undecided is not claimed; a mode none of whose
    first ``CONFIRM_GIVE_UP`` claims is confirmed is dropped unchecked beyond them. With a
    ``limit``, only the first ``limit`` claims of a mode are checked: a mode with a confirmed
    claim is kept, its unchecked claims are ``deferred`` (never counted as exposed: the caller
    audits them, as ``design`` does with the whole design).
    """

    def __init__(self, system: System, exact: bool, lambdas: Mapping[tuple[Label, ...], complex], tol: Tolerance, tick: Callable[[int, int], None] | None,
                 limit: int | None = None) -> None:
        self.system = system
        self.exact = exact
        self.lambdas = lambdas
        self.tol = tol
        self.tick = tick
        self.limit = limit
        #: attack set -> why its exposure by a proposed mode was left undecided
        self.undecided: dict[tuple[Label, ...], str] = {}
        #: claims of kept modes left for the caller's audit
        self.deferred: set[tuple[Label, ...]] = set()

    def __call__(self, links: Sequence[LinkCandidate], name: str, attacks: Sequence[tuple[Label, ...]], monitors: Sequence[Label] = ()) -> tuple[list[tuple[Label, ...]], dict[str, str]]:
        """The attacks the mode changing ``links`` (with velocity monitors added at ``monitors``) is confirmed to expose, and its Theorem III.3 statuses."""
        if not attacks:
            return [], {}
        mode = ProposedMode(name, links[0], (), also=tuple(links[1:])).mode_spec()
        base = with_modes(with_monitors(self.system.spec, monitors), [mode], keep=False)
        th = check_conditions(System(with_attack(base, attacks[0])), list(THEOREM_IDS), exact=self.exact).conditions
        statuses = {r.id: r.status.value for r in th}
        if not all(r.status is Status.HOLDS for r in th):
            return [], statuses
        msys = System(base)
        confirmed: list[tuple[Label, ...]] = []
        rest = list(attacks[self.limit:]) if self.limit is not None else []
        attacks = attacks[: self.limit] if self.limit is not None else attacks
        for c, F in enumerate(attacks):
            z = decide_zda(msys, F, ZdaOptions(lambda0=self.lambdas.get(F), tol=self.tol, exact=self.exact))
            v = decide_avoidance(msys, name, z, tol=self.tol)
            if v.status is Status.FAILS:
                confirmed.append(F)
                self.undecided.pop(F, None)
            elif v.status is Status.UNDECIDED:
                why = v.certificate.get("note") if v.certificate else None
                self.undecided[F] = str(why or z.note or "switching.avoids-attack is undecided")
            if self.tick is not None and ((c + 1) % CONFIRM_CHUNK == 0 or c + 1 == len(attacks)):
                self.tick(c + 1, len(attacks))
            if not confirmed and c + 1 >= CONFIRM_GIVE_UP < len(attacks):
                break  # the touch test misjudged this mode: drop it without checking thousands more
        if confirmed:
            self.deferred.update(rest)
        return confirmed, statuses

    def settled(self, got: Iterable[tuple[Label, ...]]) -> set[tuple[Label, ...]]:
        """The sets a kept mode takes off the search: its confirmed claims and the deferred ones."""
        return set(got) | self.deferred


# ------------------------------------------------------------------------------------------
# multi-link changes (module docstring, "Multi-link modes")

#: the multi-link changes scored (``safe_modes_max_combinations``) and screened per chosen mode
#: (``safe_modes_max_screens``, ``safe_modes_max_screen_work`` entry operations of 64 s N^2 each),
#: and the batches of the screen (``safe_modes_screen_batch`` changes, about
#: ``safe_modes_screen_batch_entries`` array entries B (N - 1)^2 per temporary) are tunables of
#: :mod:`glocal_verify.config`, read when used


def _pairs(system: System, links: Sequence[LinkCandidate]) -> list[tuple[int, int]]:
    return [(system.index[c.u], system.index[c.v]) for c in links]


def _multi_combinations(system: System, cands: Sequence[LinkCandidate], tg: Sequence[SymmetryTarget], todo: Sequence[int], size: int, thr: float) -> list[tuple[int, ...]]:
    """Forests of ``size`` candidates, each with a monitored endpoint, at least one touching a target in ``todo``."""
    import itertools

    M = set(system.monitored)
    pool = [k for k, c in enumerate(cands) if c.u in M or c.v in M]
    touch = set()
    for k in pool:
        i, j = system.index[cands[k].u], system.index[cands[k].v]
        if any(float(np.linalg.norm(tg[t].X[i] - tg[t].X[j])) > thr for t in todo):
            touch.add(k)
    out: list[tuple[int, ...]] = []
    for a in sorted(touch):  # a is the smallest touching candidate of the combination
        others = [k for k in pool if k != a and (k not in touch or k > a)]
        for rest in itertools.combinations(others, size - 1):
            combo = tuple(sorted((a,) + rest))
            if link_forest(_pairs(system, [cands[k] for k in combo])) is None:
                continue
            out.append(combo)
            if len(out) >= config.get("safe_modes_max_combinations"):
                return out
    return out


def _multi_search(
    system: System,
    cands: Sequence[LinkCandidate],
    tg: Sequence[SymmetryTarget],
    todo: set[int],
    slots: int,
    max_links: int,
    thr: float,
    exact: bool,
    confirm: _Confirmations | None,
    first: int,
) -> tuple[list[ProposedMode], set[int], int, float, int]:
    """Greedy cover of ``todo`` by changes of 2..``max_links`` links: modes, covered targets, scored, rate, screened."""
    modes: list[ProposedMode] = []
    covered: set[int] = set()
    scored, screened, elapsed = 0, 0, 0.0
    U, values = np.asarray(system.spectrum().vectors), np.asarray(system.spectrum().values)
    monitored = {system.index[a] for a in system.monitored}
    for size in range(2, max_links + 1):
        left = sorted(todo - covered)
        if not left or len(modes) >= slots:
            break
        t0 = time.perf_counter()
        combos = _multi_combinations(system, cands, tg, left, size, thr)
        if not combos:
            elapsed += time.perf_counter() - t0
            continue
        I = np.array([[system.index[cands[k].u] for k in cb] for cb in combos], dtype=np.int64)
        J = np.array([[system.index[cands[k].v] for k in cb] for cb in combos], dtype=np.int64)
        C = touch_cover([(tg[t].X, tg[t].B) for t in left], I, J, thr)
        elapsed += time.perf_counter() - t0
        scored += len(combos)
        remaining = np.ones(len(left), dtype=bool)
        tried: set[int] = set()
        while remaining.any() and len(modes) < slots:
            counts = C[:, remaining].sum(axis=1)
            order = iter([int(p) for p in np.argsort(-counts, kind="stable") if counts[p] > 0 and int(p) not in tried])
            chosen = None
            budget = int(min(config.get("safe_modes_max_screens"), max(8, config.get("safe_modes_max_screen_work") / (64 * size * system.n**2))))
            while budget > 0 and chosen is None:
                batch: list[int] = []
                for p in order:
                    if image_kernel_holds(_pairs(system, [cands[k] for k in combos[p]]), monitored):
                        batch.append(p)
                    else:
                        tried.add(p)
                    if len(batch) >= min(config.get("safe_modes_screen_batch"), budget, max(1, int(config.get("safe_modes_screen_batch_entries") // system.n**2))):
                        break
                if not batch:
                    break
                budget -= len(batch)
                screened += len(batch)
                signed = [[-float(cands[k].weight) if cands[k].remove else float(cands[k].weight) for k in combos[p]] for p in batch]
                passed = screen_changes(U, values, [(_pairs(system, [cands[k] for k in combos[p]]), w) for p, w in zip(batch, signed)])
                tried.update(p for p, ok in zip(batch, passed) if not ok)
                for p in (q for q, ok in zip(batch, passed) if ok):
                    tried.add(p)
                    links = [cands[k] for k in combos[p]]
                    claim = [tg[left[c]].F for c in np.flatnonzero(C[p] & remaining)]
                    name = f"designed-{first + len(modes)}"
                    got, statuses = confirm(links, name, claim) if confirm is not None else (claim, {})
                    if got:
                        chosen = ProposedMode(name, links[0], tuple(got), statuses, "exact" if exact else "numeric", tuple(links[1:]))
                        break
            if chosen is None:
                break
            modes.append(chosen)
            hit = confirm.settled(chosen.exposes) if confirm is not None else set(chosen.exposes)
            for c, t in enumerate(left):
                if tg[t].F in hit:
                    remaining[c] = False
                    covered.add(t)
    return modes, covered, scored, scored / max(elapsed, 1e-9) if scored else 0.0, screened


def design_safe_modes(
    system: System,
    attacks: Iterable[Sequence[Label]] | None = None,
    candidate_links: Sequence[LinkCandidate] | None = None,
    budget: int = 3,
    *,
    weights: Sequence[Fraction] = DEFAULT_WEIGHTS,
    lambdas: Mapping[tuple[Label, ...], complex] | None = None,
    tol: Tolerance = DEFAULT_TOLERANCE,
    exact: bool | None = None,
    verify_designs: bool = True,
    max_links: int | None = None,
    monitor_room: int = 0,
    confirm_limit: int | None = None,
    progress: Callable[[str], None] | None = None,
    tick: Callable[[int, int], None] | None = None,
) -> SafeModeDesign:
    """Safe modes of as few link changes as the search finds that meet Theorem III.3 (i)-(iii) and expose the attacks.

    One-link modes first (greedy set cover); the attacks no one-link mode exposes are then
    covered greedily by changes of 2..``max_links`` candidate links (module docstring,
    "Multi-link modes"). Every proposal is re-verified by the checkers.

    Parameters
    ----------
    system : System
    attacks : iterable of label sequences, optional
        Attack sets to expose; default the ``undetected`` sets of :func:`glocal_verify.design.audit.audit`
        with k = 2.
    candidate_links : sequence of LinkCandidate, optional
        Allowed changes; default :func:`default_candidates` (distance <= 2, ``weights``, removals).
    budget : int
        Largest number of safe modes proposed.
    weights : sequence of Fraction
        Weights of added links in the default candidates.
    lambdas : mapping, optional
        Exponent per attack set (default: the audit's ``lambda0``, i.e. ``stealthy.zda``'s).
    tol : Tolerance
    exact : bool, optional
        Re-verify over Q (default: N <= 40).
    verify_designs : bool
        Re-verify every proposal with the checkers (turn off only for benchmarks).
    max_links : int, optional
        Largest number of link changes in one mode (1: one-link modes only). None: changes of
        two links for the combinatorial search, and as many as the interlacing bound asks
        (up to the tunable ``symmetry_max_links``) for symmetry-breaking modes.
    monitor_room : int
        Velocity monitors the symmetry-breaking modes may add for Theorem III.3 (i)
        (:mod:`glocal_verify.design.symmetry`); the result lists them in ``monitors``.
    confirm_limit : int, optional
        Re-verify at most this many claims of each proposed mode; the rest are neither exposed
        nor unexposed in the result (``design`` audits them with the whole design).
    progress : callable, optional
        Called with one line as each proposed mode is checked against the attacks it should
        expose.
    tick : callable, optional
        Called with (attack sets checked, attack sets claimed) during each check.

    Returns
    -------
    SafeModeDesign
        ``unexposed`` says, per attack, why no mode within the budget exposes it.

    Raises
    ------
    NotApplicableError
        An empty candidate set, budget < 1, or max_links < 1.
    """
    from glocal_verify.design.audit import audit

    if budget < 1:
        raise NotApplicableError(f"budget: must be at least 1 safe mode, not {budget}")
    if max_links is not None and max_links < 1:
        raise NotApplicableError(f"max_links: must be at least 1 link change, not {max_links}")
    cands = list(candidate_links) if candidate_links is not None else default_candidates(system, weights)
    if not cands:
        raise NotApplicableError("candidate_links: the candidate set is empty")
    for c in cands:
        system.idx([c.u, c.v])
    if attacks is None or lambdas is None:
        if attacks is None:
            res = audit(system, 2, None, None, tick)
        else:
            attacks = [tuple(F) for F in attacks]
            if progress is not None:
                progress(f"auditing for the exponents of {len(attacks)} attack sets")
            res = audit(system, max(len(F) for F in attacks), sorted({a for F in attacks for a in F}, key=system.index.__getitem__), None, tick)
        rows = {r.actuators: r for r in res.rows}
        if attacks is None:
            attacks = [F for F, r in rows.items() if r.verdict == "undetected"]
        lambdas = {F: r.lambda0 for F, r in rows.items() if r.lambda0 is not None}
    targets_F = [tuple(sorted(F, key=system.index.__getitem__)) for F in attacks]
    exact = system.n <= config.get("safe_modes_exact_max_agents") if exact is None else exact
    t0 = time.perf_counter()
    err = eigenvector_error(system)
    ok = one_link_screen(system, cands, err)
    rules = _OneLinkRules(system, cands)
    stealthy = [F for F in targets_F if F in lambdas]
    tg = _targets(system, stealthy, lambdas, tol)
    thr = math.sqrt(tol.rtol) * 1e-2
    cover = _cover(system, cands, ok, tg, thr)
    rate = len(cands) / max(time.perf_counter() - t0, 1e-9)
    say = progress if progress is not None else (lambda line: None)
    confirm = _Confirmations(system, exact, lambdas, tol, tick, confirm_limit) if verify_designs else None
    uncovered = set(range(len(tg)))
    modes: list[ProposedMode] = []
    rejected: set[int] = set()
    while uncovered and len(modes) < budget:
        best = max((k for k in range(len(cands)) if k not in rejected), key=lambda k: len(cover[k] & uncovered), default=None)
        if best is None or not (cover[best] & uncovered):
            break
        rejected.add(best)
        if not rules.holds(best):  # the screen only filters: the rule functions decide (i)-(iii)
            continue
        claim = [tg[k].F for k in sorted(cover[best] & uncovered)]
        name = f"designed-{len(modes) + 1}"
        if confirm is not None:
            say(f"checking {name} ({cands[best].describe()}) against the {len(claim)} attack sets it should expose")
            got, statuses = confirm([cands[best]], name, claim)
        else:
            got, statuses = claim, {}
        if not got:
            continue
        modes.append(ProposedMode(name, cands[best], tuple(got), statuses, "exact" if exact else "numeric"))
        settled = confirm.settled(got) if confirm is not None else set(got)
        uncovered -= {k for k in range(len(tg)) if tg[k].F in settled}
    combo_links = 2 if max_links is None else max_links
    scored, multi_rate, screened = 0, 0.0, 0
    if uncovered and len(modes) < budget and combo_links >= 2 and err is not None:
        more, done, scored, multi_rate, screened = _multi_search(
            system, cands, tg, uncovered, budget - len(modes), combo_links, thr, exact, confirm, len(modes) + 1
        )
        modes += more
        uncovered -= done
    notes: list[str] = []
    added: list[Label] = []
    obstacle = ""
    if uncovered and len(modes) < budget and confirm is not None:
        obstacle = symmetry_obstacle(system, monitor_room, max_links)
        if not obstacle:
            def sym_confirm(links: Sequence[tuple[Label, Label, Fraction, Fraction | None]], name: str, claim: Sequence[tuple[Label, ...]],
                            mons: Sequence[Label]) -> tuple[list[tuple[Label, ...]], dict[str, str]]:
                got, statuses = confirm([LinkCandidate(u, v, w, False, old) for u, v, w, old in links], name, claim, mons)
                return (got + [F for F in claim if F in confirm.deferred and F not in got] if got else got), statuses  # deferred: off the search

            found, done, notes = break_symmetry(system, tg, uncovered, slots=budget - len(modes), max_links=max_links, room=monitor_room,
                                                confirm=sym_confirm, thr=thr, first=len(modes) + 1, say=say)
            for b in found:
                links = [LinkCandidate(u, v, w, False, old) for u, v, w, old in b.links]
                exposes = tuple(F for F in b.exposes if F not in confirm.deferred)
                modes.append(ProposedMode(f"designed-{len(modes) + 1}", links[0], exposes, b.verification, "exact" if exact else "numeric", tuple(links[1:]), b.monitors))
                added += [a for a in b.monitors if a not in added]
            uncovered -= done
            uncovered -= {k for k in range(len(tg)) if tg[k].F in confirm.deferred}
    unexposed: dict[str, str] = {}
    for F in targets_F:
        if F not in lambdas:
            unexposed[",".join(map(str, F))] = "no stealthy ZDA exponent known for this set (not stealthy, or undecided)"
    blocking = ""
    if uncovered and not any(rules.known.values()) and not modes:
        blocking = "; ".join(x for x in (obstacle, blocking_reason(system, cands, err) if err is None or not obstacle else "") if x)
    for k in sorted(uncovered):
        key = ",".join(map(str, tg[k].F))
        if blocking:
            unexposed[key] = "no candidate meets Theorem III.3 (i)-(iii): " + blocking
        elif not any(k in cv for cv in cover) and not notes:
            why = "no admissible one-link change touches every stealthy direction"
            if combo_links >= 2:
                why += f", and the search found no admissible change of 2..{combo_links} links that does"
            if tg[k].X.shape[1] > 1:
                why += f" (the stealthy kernel at lambda0 has dimension {tg[k].X.shape[1]})"
            unexposed[key] = why
        elif notes:
            unexposed[key] = "; ".join(dict.fromkeys(notes))
        elif confirm is not None and tg[k].F in confirm.undecided:
            # one text for every such set (the notes name each set's lambda0), so that the design's
            # summary groups them on one line
            unexposed[key] = "whether a proposed mode exposes it stays undecided at its lambda0 (switching.avoids-attack), so no mode claims it"
        else:
            unexposed[key] = f"the budget of {budget} safe mode(s) is exhausted"
    admitted = sum(rules.known.values())
    return SafeModeDesign(tuple(modes), tuple(targets_F), unexposed, len(cands), rate, admitted, scored, multi_rate, screened, tuple(added), tuple(notes))
