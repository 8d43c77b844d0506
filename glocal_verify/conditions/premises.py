"""When a condition holds or fails vacuously: the premises each verdict needs, written once.

A result whose premise is absent on the system says so in :attr:`ConditionResult.premise` and
reads ``vacuous`` (:class:`~glocal_verify.results.Polarity`): its status is a fact, but it
answers no question a designer asked. The registry applies :func:`vacuous_premise` to every
result a checker returns (a checker may also set the premise itself, as
``switching.avoids-attack`` does when no stealthy ZDA exists: there is nothing to avoid).

- ``local.*`` with the suspected set ``attack`` in a cluster that holds no attacked agent:
  the observer has nothing to detect there.
- ``privacy.*`` (except ``privacy.connected``) and ``central.observer`` with no global
  monitor: the control centre measures nothing, so nothing can be reconstructed and there is
  nothing to observe.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from glocal_verify import config
from glocal_verify.model import System

__all__ = ["NO_MONITORS_PREMISE", "missing_input", "vacuous_premise"]

NO_MONITORS_PREMISE = "no global monitors: the control centre measures nothing"
_NEEDS_MONITORS = frozenset({"privacy.kernel", "privacy.unobservable", "privacy.initial-state", "privacy.consensus-value", "central.observer"})


def vacuous_premise(system: System, cid: str, scope: Mapping[str, Any]) -> str | None:
    """The absent premise of condition ``cid`` in ``scope`` on ``system`` (None: the premise holds).

    Parameters
    ----------
    system : System
    cid : str
        A condition id.
    scope : mapping
        The result's scope.
    """
    if cid.startswith("local.") and scope.get("suspected") == "attack" and scope.get("cluster") is not None:
        name = str(scope["cluster"])
        members = set(system.cluster(name).nodes)
        if not any(a in members for a in system.attacked):
            return f"no attacked agent in cluster {name}: there is nothing for its observer to detect"
    if cid in _NEEDS_MONITORS and not system.monitored:
        return NO_MONITORS_PREMISE
    return None


#: conditions that need the spec's attack
_NEEDS_ATTACK = frozenset({"stealthy.zda", "stealthy.covert", "switching.avoids-attack", "switching.detects", "sampled.zda", "detection.local-alarm", "detection.guarantee"})
#: conditions evaluated per safe mode
_NEEDS_SAFE_MODES = frozenset(
    {"switching.image-kernel", "switching.distinct-eigenvalues", "switching.eigenvector-differences", "switching.coverage", "switching.avoids-attack", "switching.detects"}
)


def missing_input(system: System, cid: str, *, exact: bool = False, options: Mapping[str, Any] | None = None) -> str | None:
    """Why condition ``cid`` has nothing to evaluate on ``system`` (None: it has something).

    The part of the spec the condition is about is absent: a sampled deployment
    (``[implementation]``) for ``sampled.*`` and ``detection.*``, an ``[attack]``, safe modes,
    local observers, a ``[switching]`` schedule for the simulation of ``switching.detects``.
    The checker then returns no result; ``verify`` neither runs nor announces it, and says why
    (:func:`glocal_verify.conditions.registry.check_conditions`). The checkers' own guards
    call this function: the rule is written once.

    Parameters
    ----------
    system : System
    cid : str
        A condition id.
    exact : bool
        The run is exact (``switching.detects``, a floating-point simulation, is left out).
    options : mapping, optional
        The checkers' options (``simulate``: whether ``switching.detects`` simulates).
    """
    spec = system.spec
    impl = spec.implementation
    if cid.startswith(("sampled.", "detection.")):
        if impl is None:
            return "the spec has no [implementation] (a sampled deployment)"
        if impl.controller != "sampled" and (cid.startswith("detection.") or cid == "sampled.local-uio"):
            return f"the [implementation] controller is {impl.controller}, not sampled"
        if cid in ("detection.local-alarm", "detection.guarantee") and system.n > (most := config.get("guarantee_max_agents")):
            return f"{system.n} agents, more than {most} (the certified detectors are dense)"
    if cid in _NEEDS_ATTACK and spec.attack is None:
        return "no [attack] in the spec"
    if cid in _NEEDS_SAFE_MODES and not system.safe_modes:
        return "no safe modes in the spec ([[modes]])"
    if cid.startswith("local.") and not any(c.observers for c in spec.clusters):
        return "no local observers in the spec ([[clusters.observers]])"
    if cid == "switching.detects":
        if exact:
            return "a floating-point simulation, left out of an exact run (run verify without --exact to simulate)"
        if not (options or {}).get("simulate"):
            return "not simulated (--simulate never, or more agents than --simulate auto simulates: --simulate always runs it)"
        if spec.switching is None:
            return "no [switching] in the spec: no switch to simulate"
    return None
