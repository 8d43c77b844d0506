"""Design the global monitors: the fewest velocity-only monitored agents for the safe modes.

Privacy (Lemma III.1, Problem 1 (i))
    With M_x = ∅ the vector [1; 0] lies in ker C and A_q [1; 0] = 0 in every mode, so
    span{[1; 0]} is invariant and unobservable for every mode and every switching sequence;
    the switched unobservable subspace is nonzero (x(t0) is not reconstructable) and contains
    [1; 0], which is not orthogonal to f = [1/N 1^T, 0] (x* is not reconstructable). So any
    velocity-only monitor set keeps ``privacy.kernel``, ``privacy.unobservable``,
    ``privacy.initial-state`` and ``privacy.consensus-value`` (``privacy.connected`` depends on
    the graph alone). The designed set is re-verified by those checkers.

Theorem III.3 (i) and Lemma A.2
    (i) reads rank(S_M dL_q) = rank(dL_q). dL_q vanishes outside the switching components
    D_q, so only M ∩ D_q matters: (i) holds iff the rows dL_q[M ∩ D_q, :] span the row space of
    dL_q. Every component D_c then meets M (a component without a monitored agent contributes
    rank |D_c| - 1 >= 1 that no monitored row reaches): Lemma A.2's coverage follows. Ranks are
    exact, over Q (:func:`glocal_verify.numerics.exact.rank`).

Search
    f(M) = sum_q rank(dL_q[M ∩ D_q, :]) is a sum of matroid rank functions (row matroids),
    hence monotone submodular, and (i) for every mode is f(M) = f(V). *Exact* (N <= 30, or the
    union of the components has at most 30 agents): subsets of the union D of the components
    by increasing size, the first that reaches f(V) is a minimum (a monitor outside D never
    helps). *Greedy* beyond: add the agent of largest gain; Wolsey (1982) bounds the result by
    (1 + ln max_j f({j})) times the minimum, where f({j}) is at most the number of modes whose
    components contain j.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass, field
from fractions import Fraction
from typing import Any, Iterable, Mapping, Sequence

from glocal_verify import config
from glocal_verify.conditions.registry import check_conditions
from glocal_verify.errors import NotApplicableError
from glocal_verify.model import System
from glocal_verify.numerics import exact as ex
from glocal_verify.spec.types import Label, MonitorSpec, ModeSpec

__all__ = ["MonitorDesign", "design_monitors"]

#: exhaustive search up to this many agents in the union of the switching components
PRIVACY_IDS = ("privacy.connected", "privacy.kernel", "privacy.unobservable", "privacy.initial-state", "privacy.consensus-value")
CHECK_IDS = PRIVACY_IDS + ("switching.image-kernel", "switching.coverage")


@dataclass(frozen=True, slots=True)
class MonitorDesign:
    """A velocity-only monitor set and its verification.

    Attributes
    ----------
    velocities : tuple of labels
        M_v (M_x = ∅).
    method : str
        ``exact`` (proven minimum) or ``greedy``.
    bound : float
        Approximation factor: 1 for exact, 1 + ln max_j f({j}) for greedy.
    required : tuple of labels
        Agents the caller required.
    verification : mapping
        Condition id -> worst status over its scopes (privacy.*, switching.image-kernel, switching.coverage).
    """

    velocities: tuple[Label, ...]
    method: str
    bound: float
    required: tuple[Label, ...] = ()
    verification: Mapping[str, str] = field(default_factory=dict)

    @property
    def ok(self) -> bool:
        """Every verified condition holds."""
        return all(v == "holds" for v in self.verification.values())

    def to_json(self) -> dict[str, Any]:
        """JSON form."""
        return {
            "positions": [],
            "velocities": list(self.velocities),
            "method": self.method,
            "bound": self.bound,
            "required": list(self.required),
            "verification": dict(self.verification),
        }


def _blocks(system: System, modes: Sequence[str]) -> list[tuple[list[int], list[list[Fraction]]]]:
    out = []
    for mode in modes:
        comps = system.switching_components(mode)
        D = system.idx([a for c in comps for a in c])
        dL = system.delta_laplacian_exact(mode)
        out.append((D, [[dL[i][j] for j in D] for i in D]))
    return out


def _f(blocks: Sequence[tuple[list[int], list[list[Fraction]]]], M: set[int]) -> int:
    total = 0
    for D, blk in blocks:
        rows = [blk[k] for k, i in enumerate(D) if i in M]
        total += ex.rank(rows, len(D)) if rows else 0
    return total


def design_monitors(
    system: System,
    modes: Iterable[ModeSpec] | Sequence[str] | None = None,
    *,
    required: Iterable[Label] = (),
    exact_limit: int | None = None,
    verify_design: bool = True,
) -> MonitorDesign:
    """The fewest velocity-only monitors meeting Theorem III.3 (i) (and Lemma A.2) for the safe modes.

    Parameters
    ----------
    system : System
    modes : ModeSpec objects or mode names, optional
        The safe modes; default the spec's. ModeSpec objects replace the spec's modes.
    required : iterable of labels
        Agents that must be monitored anyway.
    exact_limit : int, optional
        Exhaustive search when the union of the switching components has at most this many
        agents (default: the tunable ``monitors_exact_max_agents`` of :mod:`glocal_verify.config` in force).
    verify_design : bool
        Re-verify the design with the checkers (privacy.*, switching.image-kernel, switching.coverage).

    Returns
    -------
    MonitorDesign

    Raises
    ------
    NotApplicableError
        When (i) cannot hold even with every agent monitored (cannot happen: S_V = I).
    """
    import dataclasses

    from glocal_verify.design.safe_modes import with_modes

    mlist = list(modes) if modes is not None else None
    if mlist and isinstance(mlist[0], ModeSpec):
        system = System(with_modes(system.spec, mlist, keep=False))  # type: ignore[arg-type]
        names: Sequence[str] = system.safe_modes
    elif mlist is not None:
        wanted = [system.spec.mode(str(m)) for m in mlist]
        system = System(with_modes(system.spec, wanted, keep=False))
        names = system.safe_modes
    else:
        names = system.safe_modes
    req = tuple(a for a in system.labels if a in set(required))
    system.idx(req)
    blocks = _blocks(system, names)
    goal = _f(blocks, set(range(system.n)))
    D = sorted({i for Dq, _ in blocks for i in Dq})
    base = set(system.idx(req))
    chosen: set[int] | None = None
    method, bound = "greedy", 1.0
    if len(D) <= config.resolve("monitors_exact_max_agents", exact_limit):
        free = [i for i in D if i not in base]
        for size in range(0, len(free) + 1):
            for extra in itertools.combinations(free, size):
                if _f(blocks, base | set(extra)) == goal:
                    chosen = base | set(extra)
                    break
            if chosen is not None:
                break
        method = "exact"
    if chosen is None:
        M = set(base)
        cur = _f(blocks, M)
        single = max((_f(blocks, {i}) for i in D), default=0)
        bound = 1.0 + math.log(max(single, 1))
        while cur < goal:
            gains = [(_f(blocks, M | {i}) - cur, -k, i) for k, i in enumerate(D) if i not in M]
            g, _, i = max(gains)
            if g <= 0:
                raise NotApplicableError("Theorem III.3 (i) cannot be met by any monitor set")
            M.add(i)
            cur += g
        chosen = M
        method = "greedy"
    vel = tuple(system.labels[i] for i in sorted(chosen))
    verification: dict[str, str] = {}
    if verify_design:
        spec = dataclasses.replace(system.spec, monitor=MonitorSpec((), vel))
        rep = check_conditions(System(spec), list(CHECK_IDS), exact=system.n <= 60)
        for r in rep.conditions:
            prev = verification.get(r.id, "holds")
            order = {"holds": 0, "undecided": 1, "fails": 2}
            verification[r.id] = max(prev, r.status.value, key=order.__getitem__)
    return MonitorDesign(vel, method, bound, req, verification)

