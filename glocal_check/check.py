"""Check a certificate file against a spec: the assumptions, then every certificate.

The file (``format = "glocal-verify/certificates"``, ``version = 1``) lists every decided
verdict of a ``glocal-verify verify`` run: its condition id, scope and status, and its
certificate or ``null`` (then ``reason`` says why there is none). ``assumes`` states the exact
numbers the certificates are about; they must be those the checker reads from the spec.

Simulated observations (:data:`SIMULATED`, the checker's own list) are not decided verdicts:
``switching.detects`` reports what one floating-point simulation from one initial state showed,
which no exact statement about the system decides (Theorem III.3's conditions and
``switching.avoids-attack`` carry the algebra, each with its own certificate). Wherever the file
lists them (``observations``, or ``verdicts`` without a certificate) they are counted apart and
named on one line; any other id listed as an observation counts as a decided verdict without a
certificate, and a certificate for a simulated id is rejected.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from typing import Any, Callable

from glocal_check.algebra import Rejected, require
from glocal_check.central import central
from glocal_check.context import Context
from glocal_check.local import pencil, uio
from glocal_check.spec import CheckError, Spec, read_spec
from glocal_check.spectra import differences, distinct
from glocal_check.sampled import SAMPLED_STRUCTURAL, detector_stable, sampled_stability, sampled_uio, sampled_zda
from glocal_check.structure import STRUCTURAL
from glocal_check.subspaces import hidden, observable
from glocal_check.zda import avoids_attack, no_zda, zda_exists

__all__ = ["FORMAT", "SIMULATED", "VERSION", "Outcome", "assumptions", "check_certificate", "check_files"]

FORMAT = "glocal-verify/certificates"
VERSION = 1

#: condition ids whose status is a simulated observation, not a decided verdict
SIMULATED = frozenset({"switching.detects"})

#: statuses a ``structure`` certificate may prove for ids whose other status needs more
STRUCTURE_PROVES = {"local.uio": {"fails"}, "local.pencil": {"fails"}}


@dataclass
class Outcome:
    """The result of checking one file."""

    accepted: int = 0
    rejected: list[str] = field(default_factory=list)
    without: int = 0
    observations: int = 0

    @property
    def checked(self) -> int:
        return self.accepted + len(self.rejected)

    @property
    def ok(self) -> bool:
        return not self.rejected and self.without == 0

    def observed(self) -> str:
        """The line naming the simulated observations (empty when there are none)."""
        if not self.observations:
            return ""
        return f"not checked: {self.observations} simulated observation(s) ({', '.join(sorted(SIMULATED))}: a simulation, not a decided verdict)"

    def summary(self) -> str:
        return f"checked {self.checked} certificates: {self.accepted} accepted, {len(self.rejected)} rejected; {self.without} decided verdicts without a certificate"


def assumptions(spec: Spec) -> dict[str, Any]:
    """The spec's exact data, as the certificate file states what it assumes."""
    lab = spec.labels

    def links(w: dict[tuple[int, int], Any]) -> list[list[str]]:
        return sorted([str(lab[i]), str(lab[j]), str(x)] for (i, j), x in w.items())

    out: dict[str, Any] = {
        "alpha": str(spec.alpha),
        "gamma": str(spec.gamma),
        "nodes": [str(x) for x in lab],
        "edges": links(spec.weights["normal"]),
        "modes": {m: sorted([str(lab[i]), str(lab[j]), str(spec.weights[m].get((i, j), 0))] for (i, j) in spec.delta(m)) for m in spec.modes if m != "normal"},
        "monitor": {"positions": [str(lab[a]) for a in spec.positions], "velocities": [str(lab[a]) for a in spec.velocities]},
        "clusters": [
            {"name": c.name, "nodes": [str(lab[a]) for a in c.nodes], "observers": [{"center": str(lab[o.center]), "positions": [str(lab[a]) for a in o.positions], "velocities": [str(lab[a]) for a in o.velocities]} for o in c.observers]}
            for c in spec.clusters
        ],
        "schedule": list(spec.schedule),
        "attack": None,
    }
    if spec.implementation is not None:
        out["implementation"] = {"period": str(spec.implementation["period"]), "controller": spec.implementation["controller"]}
    if spec.attack is not None:
        a = spec.attack
        out["attack"] = {
            "kind": a["kind"],
            "actuators": [str(lab[x]) for x in a["actuators"]],
            "sensors": [str(lab[x]) for x in a["sensors"]],
            "lambda0": None if a["lambda0"] is None else [str(a["lambda0"][0]), str(a["lambda0"][1])],
        }
    return out


def _structure(ctx: Context, cid: str, scope: dict[str, Any], status: str, cert: dict[str, Any]) -> None:
    rule = STRUCTURAL.get(cid) or SAMPLED_STRUCTURAL.get(cid)
    require(rule is not None, f"{cid} has no structural rule")
    require(status in STRUCTURE_PROVES.get(cid, {"holds", "fails"}), f"a structure certificate cannot prove that {cid} {status}")
    got, facts = rule(ctx, scope)
    if cid == "privacy.consensus-value" and status == "holds":
        require("mode" in scope, "x* hidden on a schedule needs an invariant-subspace certificate")
    require(got == status, f"the spec gives {cid} {got}, not {status}")
    ctx.same(cert.get("facts"), facts, "facts")


def _privacy(ctx: Context, cid: str, scope: dict[str, Any], status: str, cert: dict[str, Any]) -> None:
    """``privacy.initial-state`` / ``switched-observability`` (its negation) / ``privacy.consensus-value``."""
    hides = status == "holds" if cid != "switched-observability" else status == "fails"
    kind = cert.get("kind")
    if hides:
        require(kind == "invariant-subspace", f"{cid} {status} needs an invariant-subspace certificate")
        hidden(ctx, scope, cert, consensus=cid == "privacy.consensus-value")
    else:
        require(kind == "observable" and cid != "privacy.consensus-value", f"{cid} {status} needs an observable certificate")
        observable(ctx, scope, cert)


def _zda(ctx: Context, cid: str, scope: dict[str, Any], status: str, cert: dict[str, Any]) -> None:
    if status == "fails":
        return no_zda(ctx, scope, cert)
    require(cert.get("kind") == "zda", "stealthy.zda holds needs a zda certificate")
    require(not scope, "stealthy.zda has the global scope")
    zda_exists(ctx, cert)


def _avoids(ctx: Context, cid: str, scope: dict[str, Any], status: str, cert: dict[str, Any]) -> None:
    avoids_attack(ctx, scope, status, cert)


def _distinct(ctx: Context, cid: str, scope: dict[str, Any], status: str, cert: dict[str, Any]) -> None:
    distinct(ctx, scope, status, cert)


def _differences(ctx: Context, cid: str, scope: dict[str, Any], status: str, cert: dict[str, Any]) -> None:
    differences(ctx, scope, status, cert)


def _pencil(ctx: Context, cid: str, scope: dict[str, Any], status: str, cert: dict[str, Any]) -> None:
    pencil(ctx, scope, status, cert)


def _uio(ctx: Context, cid: str, scope: dict[str, Any], status: str, cert: dict[str, Any]) -> None:
    require(status == "holds", "local.uio fails needs a structure certificate")
    uio(ctx, scope, cert)


def _central(ctx: Context, cid: str, scope: dict[str, Any], status: str, cert: dict[str, Any]) -> None:
    require(status == "holds" and not scope, "central.observer: only holds (global) has a certificate")
    central(ctx, cert)


Check = Callable[[Context, str, dict[str, Any], str, dict[str, Any]], None]

#: condition id -> its check (``structure`` certificates go to the structural rules)
CHECKS: dict[str, Check] = {
    "privacy.initial-state": _privacy,
    "privacy.consensus-value": _privacy,
    "switched-observability": _privacy,
    "stealthy.zda": _zda,
    "switching.avoids-attack": _avoids,
    "switching.distinct-eigenvalues": _distinct,
    "switching.eigenvector-differences": _differences,
    "local.pencil": _pencil,
    "local.uio": _uio,
    "central.observer": _central,
    "sampled.stability": lambda ctx, cid, scope, status, cert: sampled_stability(ctx, scope, status, cert),
    "sampled.zda": lambda ctx, cid, scope, status, cert: sampled_zda(ctx, scope, status, cert),
    "sampled.local-uio": lambda ctx, cid, scope, status, cert: sampled_uio(ctx, scope, status, cert),
    "detection.thresholds": lambda ctx, cid, scope, status, cert: detector_stable(ctx, scope, status, cert),
}


def check_certificate(ctx: Context, entry: dict[str, Any]) -> None:
    """Check one entry of the file; raise :class:`Rejected` with the reason."""
    cid, scope, status, cert = entry.get("id"), entry.get("scope"), entry.get("status"), entry.get("certificate")
    require(isinstance(cid, str) and isinstance(scope, dict) and status in ("holds", "fails") and isinstance(cert, dict), "malformed entry")
    require(cid not in SIMULATED, f"{cid} is a simulated observation: no certificate can prove it")
    if cert.get("kind") == "structure":
        return _structure(ctx, cid, scope, status, cert)
    check = CHECKS.get(cid)
    require(check is not None, f"no certificate check for {cid}")
    check(ctx, cid, scope, status, cert)


def _name(entry: dict[str, Any]) -> str:
    scope = entry.get("scope") or {}
    where = ", ".join(f"{k}={v}" for k, v in scope.items()) if isinstance(scope, dict) else str(scope)
    return f"{entry.get('id')} [{where or 'global'}] {entry.get('status')}"


def check_files(spec_path: str, cert_path: str, report: Callable[[str], None] = print) -> Outcome:
    """Check every certificate of ``cert_path`` against the spec at ``spec_path``; ``report``
    receives one line per rejected certificate."""
    spec = read_spec(spec_path)
    try:
        with open(cert_path, encoding="utf-8") as fh:
            data = json.load(fh)
    except (OSError, ValueError) as exc:
        raise CheckError(f"{cert_path}: cannot read the certificate file ({exc})") from None
    if not isinstance(data, dict) or data.get("format") != FORMAT or data.get("version") != VERSION:
        raise CheckError(f"{cert_path}: not a certificate file of format {FORMAT} version {VERSION}")
    entries = data.get("verdicts")
    if not isinstance(entries, list):
        raise CheckError(f"{cert_path}: no list of verdicts")
    out = Outcome()
    mine = json.loads(json.dumps(assumptions(spec)))
    theirs = data.get("assumes") if isinstance(data.get("assumes"), dict) else {}
    differ = [k for k in sorted(set(mine) | set(theirs)) if mine.get(k) != theirs.get(k)]
    ctx = Context(spec)
    observations = data.get("observations", [])
    if not isinstance(observations, list):
        raise CheckError(f"{cert_path}: observations is not a list")
    for entry in observations:
        simulated = isinstance(entry, dict) and entry.get("id") in SIMULATED
        out.observations += simulated
        out.without += not simulated  # a decided verdict listed as an observation has no certificate
    for entry in entries:
        if not isinstance(entry, dict) or entry.get("status") not in ("holds", "fails"):
            out.rejected.append(f"REJECTED {entry!r:.80}: not a decided verdict")
            report(out.rejected[-1])
            continue
        if entry.get("id") in SIMULATED and entry.get("certificate") is None:
            out.observations += 1
            continue
        if entry.get("certificate") is None:
            out.without += 1
            continue
        try:
            require(not differ, f"the file assumes other values of {', '.join(differ)} than the spec has")
            check_certificate(ctx, entry)
            out.accepted += 1
        except (Rejected, CheckError) as exc:
            out.rejected.append(f"REJECTED {_name(entry)}: {exc}")
            report(out.rejected[-1])
        except (KeyError, TypeError, ValueError, IndexError, AttributeError, ZeroDivisionError) as exc:
            out.rejected.append(f"REJECTED {_name(entry)}: malformed certificate ({type(exc).__name__}: {exc})")
            report(out.rejected[-1])
    return out
