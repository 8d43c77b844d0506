"""What every check reads: the spec, the scope of a verdict, and the matrices of the paper
built from the spec's exact rationals (kept per check run on this object)."""

from __future__ import annotations

from typing import Any

from flint import fmpq, nmod_mat

from glocal_check.algebra import Rejected, mod_matrix, require
from glocal_check.spec import NORMAL, Cluster, Observer, Spec

__all__ = ["Context", "LocalScope"]


class LocalScope:
    """A cluster scope: P_i, its observer, the suspected agents, the boundary dP_i."""

    def __init__(self, spec: Spec, scope: dict[str, Any]) -> None:
        name, centre, sus = scope.get("cluster"), scope.get("observer"), scope.get("suspected")
        found = [c for c in spec.clusters if c.name == name]
        require(len(found) == 1, f"no cluster {name!r} in the spec")
        self.cluster: Cluster = found[0]
        c = spec.idx(centre, "scope.observer")
        obs = [o for o in self.cluster.observers if o.center == c]
        require(len(obs) == 1, f"cluster {name} has no observer at {centre!r}")
        self.observer: Observer = obs[0]
        members = set(self.cluster.nodes)
        self.members = members
        if sus == "all":
            self.suspected = tuple(self.cluster.nodes)
        elif sus == "attack":
            require(spec.attack is not None, "suspected = attack without an [attack]")
            self.suspected = tuple(a for a in self.cluster.nodes if a in set(spec.attack["actuators"]))
        else:
            raise Rejected(f"unknown suspected set {sus!r}")
        self.cut = [(i, j) for (i, j) in spec.weights[NORMAL] if (i in members) != (j in members)]
        ends = {a for e in self.cut for a in e if a in members}
        self.boundary = tuple(a for a in self.cluster.nodes if a in ends)


class Context:
    """The spec and the exact matrices built from it, shared by the checks of one run."""

    def __init__(self, spec: Spec) -> None:
        self.spec = spec
        self._lap: dict[str, list[dict[int, fmpq]]] = {}
        self._lap_mod: dict[tuple[str, int], nmod_mat] = {}
        #: results of checks shared by several certificates (e.g. one observer's two suspected sets)
        self.memo: dict[Any, Any] = {}

    def lap(self, mode: str) -> list[dict[int, fmpq]]:
        """Rows of L_q."""
        if mode not in self._lap:
            self.mode(mode)
            self._lap[mode] = self.spec.laplacian(mode)
        return self._lap[mode]

    def lap_mod(self, mode: str, p: int) -> nmod_mat:
        """L_q modulo p (dense)."""
        if (mode, p) not in self._lap_mod:
            self._lap_mod[(mode, p)] = mod_matrix(self.lap(mode), self.spec.n, p)
        return self._lap_mod[(mode, p)]

    def mode(self, mode: Any) -> str:
        require(isinstance(mode, str) and mode in self.spec.weights, f"no mode {mode!r} in the spec")
        return mode

    def scope_modes(self, scope: dict[str, Any]) -> list[str]:
        """The modes a mode scope (``{'mode': q}``) or the schedule scope (``{}``) concerns."""
        if "mode" in scope:
            return [self.mode(scope["mode"])]
        require(not scope, f"unexpected scope {scope!r}")
        require(bool(self.spec.schedule), "a schedule scope, but the spec has no [switching] schedule")
        return list(dict.fromkeys(self.spec.schedule))

    def first_mode(self, scope: dict[str, Any]) -> str:
        """The mode a scope starts in (the schedule's first mode for ``{}``)."""
        return self.mode(scope["mode"]) if "mode" in scope else self.spec.schedule[0]

    def minors(self, minors: Any) -> list[dict[str, Any]]:
        """A certificate's minors with their row labels as agent indices."""
        require(isinstance(minors, list) and all(isinstance(m, dict) and isinstance(m.get("rows"), list) for m in minors), "minors: expected [{rows, degree}, ...]")
        return [dict(m, rows=[self.spec.idx(a, "rows") for a in m["rows"]]) for m in minors]

    def labels(self, idx: Any) -> list[str]:
        return [str(self.spec.labels[i]) for i in idx]

    def same(self, claimed: Any, actual: Any, what: str) -> None:
        """Reject unless a fact the certificate states is the one recomputed from the spec."""
        require(claimed == actual, f"{what}: the certificate says {claimed!r}, the spec gives {actual!r}")
