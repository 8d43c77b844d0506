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

from glocal_verify.model import System

__all__ = ["NO_MONITORS_PREMISE", "vacuous_premise"]

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
