"""Certificates of the combinatorial verdicts (kind ``structure``): the facts each verdict rests
on, read from the system's exact structure (the checker recomputes them from the spec)."""

from __future__ import annotations

from types import MappingProxyType

from typing import Any, Callable, Mapping

from glocal_verify.model import System
from glocal_verify.numerics.exact import rank
from glocal_verify.results import ConditionResult
from glocal_verify.spec.types import NORMAL_MODE

__all__ = ["STRUCTURE_FACTS", "schedule_modes"]


def _labels(system: System, labels: Any) -> list[str]:
    return [str(a) for a in sorted(labels, key=system.index.__getitem__)]


def schedule_modes(system: System, scope: Mapping[str, Any]) -> list[str]:
    """The modes of a mode scope, or of the schedule for the schedule scope ``{}``."""
    if "mode" in scope:
        return [scope["mode"]]
    from glocal_verify.analysis.unobservable.switched import mode_sequence

    seq = mode_sequence(system) or []
    return list(dict.fromkeys(m for m, _ in seq))


def _components(system: System, mode: str) -> list[list[Any]]:
    """Components of G_q, ordered as their sorted index lists are."""
    return sorted(system.components(mode), key=lambda c: sorted(system.index[a] for a in c))


def _connected(system: System, r: ConditionResult) -> dict[str, Any]:
    return {"components": len(system.components(r.scope["mode"]))}


def _positions(system: System, r: ConditionResult) -> dict[str, Any]:
    return {"position_monitors": [str(a) for a in system.monitored_positions]}


def _consensus(system: System, r: ConditionResult) -> dict[str, Any]:
    mode = schedule_modes(system, r.scope)[0]
    px = set(system.monitored_positions)
    blind = [_labels(system, c) for c in _components(system, mode) if not px & set(c)]
    return {"mode": mode, "components_without_position_monitor": blind}


def _covert(system: System, r: ConditionResult) -> dict[str, Any]:
    return {"missing": sorted(str(c) for c in r.witness.get("missing", []))}


def _k_connected(system: System, r: ConditionResult) -> dict[str, Any]:
    w = r.witness
    return {"degree": w["degree"], "inter_cluster_edges": w["inter_cluster_edges"], "required": w["required"]}


def _local_rank(system: System, r: ConditionResult) -> dict[str, Any]:
    cm = system.cluster_model(r.scope["cluster"], NORMAL_MODE)
    obs = next(o for o in system.observers(r.scope["cluster"]) if o.center == r.scope["observer"])
    miss = [a for a in cm.boundary if a not in set(obs.velocities)]
    return {"boundary": [str(a) for a in cm.boundary], "unmeasured_boundary": [str(a) for a in miss]}


def _pencil(system: System, r: ConditionResult) -> dict[str, Any]:
    return {"suspected_and_boundary": _labels(system, r.witness.get("suspected_and_boundary", []))}


def _coverage(system: System, r: ConditionResult) -> dict[str, Any]:
    M = set(system.monitored)
    return {"uncovered": [[str(a) for a in c] for c in system.switching_components(r.scope["mode"]) if not M & set(c)]}


def _image_kernel(system: System, r: ConditionResult) -> dict[str, Any]:
    mode = r.scope["mode"]
    dL = system.delta_laplacian_exact(mode)
    M = set(system.monitored)
    ranks = []
    for comp in system.switching_components(mode):
        idx = [system.index[a] for a in comp]
        block = [[dL[i][j] for j in idx] for i in idx]
        seen = [[dL[i][j] for j in idx] for a, i in zip(comp, idx) if a in M]
        ranks.append([rank(block), rank(seen) if seen else 0])
    return {"ranks": ranks}


def _sampled(system: System, r: ConditionResult) -> dict[str, Any]:
    impl = system.spec.implementation
    assert impl is not None
    return {"controller": impl.controller, "gamma_h": str(system.gamma_q * impl.period)}


def _sampled_uio_rank(system: System, r: ConditionResult) -> dict[str, Any]:
    """The boundary agents with neither position nor velocity measured (rank(C E_d) < rank(E_d))."""
    obs = next(o for o in system.observers(r.scope["cluster"]) if o.center == r.scope["observer"])
    seen = set(obs.positions) | set(obs.velocities)
    return {"unmeasured_boundary": [str(a) for a in system.cluster_model(r.scope["cluster"], NORMAL_MODE).boundary if a not in seen]}


#: condition id -> the facts of its structure certificate
STRUCTURE_FACTS: Mapping[str, Callable[[System, ConditionResult], dict[str, Any]]] = MappingProxyType({
    "privacy.connected": _connected,
    "privacy.kernel": _positions,
    "privacy.unobservable": _positions,
    "privacy.consensus-value": _consensus,
    "stealthy.covert": _covert,
    "local.k-connected": _k_connected,
    "local.rank": _local_rank,
    "local.uio": _local_rank,
    "local.pencil": _pencil,
    "switching.coverage": _coverage,
    "switching.image-kernel": _image_kernel,
    "sampled.no-aliasing": _sampled,
    "sampled.observability": _sampled,
    "sampled.stability": _sampled,
    "sampled.local-uio": _sampled_uio_rank,
})
