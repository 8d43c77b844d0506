"""The certificate file of a ``verify`` run: what it assumes and one entry per decided verdict.

Format ``glocal-verify/certificates`` version 1 (``docs/certificates.md``)::

    {"format": "glocal-verify/certificates", "version": 1,
     "spec": {"name": ...},
     "assumes": {"alpha": "1", "gamma": "1", "nodes": [...], "edges": [[u, v, "w"], ...],
                 "modes": {q: [[u, v, "w_q"], ...]}, "monitor": {...}, "clusters": [...],
                 "schedule": [...], "attack": {...}},
     "verdicts": [{"id": ..., "scope": {...}, "status": "holds" | "fails",
                   "certificate": {"kind": ..., ...} | null, "reason": "..."}],
     "observations": [{"id": "switching.detects", "scope": {...}, "status": ..., "reason": ...}]}

``python -m glocal_check SPEC FILE`` checks it without this package.

Simulated observations (:data:`SIMULATED`) are not decided verdicts: their status is what one
simulation from one initial state showed, not a statement about the exact system, so no
certificate can prove it. They are listed apart, with the reason, and the checker (which has
its own list of them) counts them neither as certified nor as verdicts without a certificate.
"""

from __future__ import annotations

from types import MappingProxyType

import json
from fractions import Fraction
from typing import Any, Callable, Iterator, Mapping

from glocal_verify.certificates.facts import STRUCTURE_FACTS
from glocal_verify.certificates.global_certificates import (
    NoCertificate,
    central_certificate,
    differences_certificate,
    distinct_certificate,
    hidden_certificate,
    no_zda_certificate,
    observable_certificate,
    touch_certificate,
    zda_certificate,
)
from glocal_verify.certificates.local_certificates import pencil_certificate, uio_certificate
from glocal_verify.certificates.sampled_certificates import detector_certificate, sampled_certificate
from glocal_verify.model import System
from glocal_verify.results import ConditionResult, Report, Status

__all__ = ["CERTIFICATE_FORMAT", "CERTIFICATE_VERSION", "SIMULATED", "assumptions", "certificate_document", "certificate_json"]

CERTIFICATE_FORMAT = "glocal-verify/certificates"
CERTIFICATE_VERSION = 1

#: condition ids whose status is a simulated observation, not a decided verdict (the checker's
#: ``glocal_check.check.SIMULATED`` is the same set): condition id -> why
SIMULATED: Mapping[str, str] = MappingProxyType({
    "switching.detects": (
        "a simulated observation, not a decided verdict: one floating-point simulation from one attack-free initial "
        "state (the spec's seed) crosses, or not, a threshold within the horizon; no exact statement about the system "
        "is claimed, so nothing can be certified (the algebra of the exposure is certified by Theorem III.3's conditions "
        "and switching.avoids-attack)"
    ),
})


def assumptions(system: System) -> dict[str, Any]:
    """The spec's exact data the certificates are about (compared by the checker with its own
    reading of the spec)."""
    spec = system.spec

    def links(items: Any) -> list[list[str]]:
        return sorted(items)

    idx = system.index
    normal = system.edges("normal")
    modes = {}
    for m in system.safe_modes:
        modes[m] = links([str(u), str(v), str(w_q)] for u, v, w_q in _changed(system, m))
    out: dict[str, Any] = {
        "alpha": str(spec.alpha),
        "gamma": str(spec.gamma),
        "nodes": [str(x) for x in system.labels],
        "edges": links([str(a), str(b), str(w)] for a, b, w in (sorted(k, key=idx.__getitem__) + [w] for k, w in normal.items())),
        "modes": modes,
        "monitor": {"positions": [str(a) for a in spec.monitor.positions], "velocities": [str(a) for a in spec.monitor.velocities]},
        "clusters": [
            {"name": c.name, "nodes": [str(a) for a in c.nodes], "observers": [{"center": str(o.center), "positions": [str(a) for a in o.positions], "velocities": [str(a) for a in o.velocities]} for o in system.observers(c.name)]}
            for c in spec.clusters
        ],
        "schedule": _schedule(system),
        "attack": None,
    }
    if spec.implementation is not None:
        out["implementation"] = {"period": str(spec.implementation.period), "controller": spec.implementation.controller}
    a = spec.attack
    if a is not None:
        lam = None if a.lambda0 is None else [str(Fraction(repr(a.lambda0.real))), str(Fraction(repr(a.lambda0.imag)))]
        out["attack"] = {"kind": a.kind, "actuators": [str(x) for x in a.actuators], "sensors": [str(x) for x in a.sensors], "lambda0": lam}
    return out


def _changed(system: System, mode: str) -> Iterator[tuple[Any, Any, Fraction]]:
    """(u, v, weight in ``mode``) for every link whose weight differs from the normal mode's."""
    w = system.edges(mode)
    for u, v, _ in system.switching_links(mode):
        yield u, v, w.get(frozenset((u, v)), Fraction(0))


def _schedule(system: System) -> list[str]:
    from glocal_verify.analysis.unobservable.switched import mode_sequence

    return [m for m, _ in (mode_sequence(system) or [])]


def _privacy(system: System, r: ConditionResult) -> dict[str, Any]:
    hides = (r.status is Status.HOLDS) != (r.id == "switched-observability")
    if r.id == "privacy.consensus-value" and not hides:
        return {"kind": "structure"}
    return hidden_certificate(system, r) if hides else observable_certificate(system, r)


def _zda(system: System, r: ConditionResult) -> dict[str, Any]:
    return zda_certificate(system, r) if r.status is Status.HOLDS else no_zda_certificate(system, r)


def _structure(system: System, r: ConditionResult) -> dict[str, Any]:
    """A combinatorial verdict: its facts (filled in by :func:`_entry`)."""
    return {"kind": "structure"}


Emitter = Callable[[System, ConditionResult], dict[str, Any]]

#: condition id -> how its certificate is made (``structure``: the facts of :data:`STRUCTURE_FACTS`)
EMITTERS: Mapping[str, Emitter] = MappingProxyType({
    "privacy.connected": _structure,
    "privacy.kernel": _structure,
    "privacy.unobservable": _structure,
    "stealthy.covert": _structure,
    "local.k-connected": _structure,
    "local.rank": _structure,
    "switching.coverage": _structure,
    "switching.image-kernel": _structure,
    "privacy.initial-state": _privacy,
    "switched-observability": _privacy,
    "privacy.consensus-value": _privacy,
    "stealthy.zda": _zda,
    "switching.avoids-attack": touch_certificate,
    "switching.distinct-eigenvalues": distinct_certificate,
    "switching.eigenvector-differences": differences_certificate,
    "local.pencil": pencil_certificate,
    "local.uio": uio_certificate,
    "sampled.stability": sampled_certificate,
    "sampled.no-aliasing": sampled_certificate,
    "sampled.observability": sampled_certificate,
    "sampled.zda": sampled_certificate,
    "sampled.local-uio": sampled_certificate,
    "detection.thresholds": detector_certificate,
})


def _entry(system: System, r: ConditionResult, options: Mapping[str, Any]) -> dict[str, Any]:
    entry: dict[str, Any] = {"id": r.id, "scope": json.loads(json.dumps(dict(r.scope), default=str)), "status": r.status.value}
    try:
        if r.id == "central.observer":
            if r.status is not Status.HOLDS:
                raise NoCertificate("a failing central observer has no certificate yet")
            cert = central_certificate(system, r, options)
        elif r.id in EMITTERS:
            cert = EMITTERS[r.id](system, r)
        else:
            raise NoCertificate(f"{r.id} has no certificate yet (docs/certificates.md)")
        if cert.get("kind") == "structure":
            cert = {"kind": "structure", "facts": STRUCTURE_FACTS[r.id](system, r)}
        entry["certificate"] = cert
    except NoCertificate as exc:
        entry["certificate"] = None
        entry["reason"] = str(exc)
    return entry


def certificate_document(system: System, report: Report) -> dict[str, Any]:
    """The certificate file of ``report`` (a ``verify`` run on ``system``) as a JSON-ready
    mapping: every ``holds``/``fails`` result gets its certificate, or ``null`` and a reason.

    Parameters
    ----------
    system : System
        The system ``report`` was computed on.
    report : Report
        Its verdicts (``undecided`` results are left out).
    """
    options = dict(report.options.get("options", {}) or {}) if isinstance(report.options.get("options"), Mapping) else {}
    decided = [r for r in report.conditions if r.status is not Status.UNDECIDED]
    verdicts = [_entry(system, r, options) for r in decided if r.id not in SIMULATED]
    observations = [
        {"id": r.id, "scope": json.loads(json.dumps(dict(r.scope), default=str)), "status": r.status.value, "reason": SIMULATED[r.id]}
        for r in decided
        if r.id in SIMULATED
    ]
    return {
        "format": CERTIFICATE_FORMAT,
        "version": CERTIFICATE_VERSION,
        "spec": {"name": system.name},
        "assumes": assumptions(system),
        "verdicts": verdicts,
        "observations": observations,
    }


def certificate_json(system: System, report: Report) -> str:
    """:func:`certificate_document` as JSON text (one verdict per line)."""
    doc = certificate_document(system, report)
    head = {k: v for k, v in doc.items() if k not in ("verdicts", "observations")}
    out = json.dumps(head, separators=(",", ":"))[:-1]
    for key in ("verdicts", "observations"):
        lines = [json.dumps(v, separators=(",", ":")) for v in doc[key]]
        out += f',"{key}":[\n' + ",\n".join(lines) + "\n]"
    return out + "}\n"
