"""The three cases of Section IV: companion systems, simulated outcomes, the paper's claims checked.

Everything ``glocal-verify simulate`` computes lives here: one run of Algorithm 1 with the
``switching.detects`` verdicts (:func:`simulate_system`), and the case study
(:func:`run_case_study`: one case per safe mode, its verdicts and simulated outcome, the
findings, Algorithm 1 with the local trigger). :mod:`glocal_verify.reporting.simulation_report`
writes these results; it computes nothing.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from types import MappingProxyType
from typing import Any, Callable, Mapping, Sequence

from glocal_verify.conditions.detects import THEOREM_III3_IDS, algorithm1, zda_touch, zda_touched
from glocal_verify.conditions.registry import implemented_ids, check_conditions
from glocal_verify.model import System
from glocal_verify.results import jsonable
from glocal_verify.simulation.algorithm1 import Algorithm1Result
from glocal_verify.simulation.thresholds import ThresholdRule

__all__ = [
    "CaseSpec",
    "CaseOutcome",
    "CaseStudy",
    "PAPER_CLAIMS",
    "SimulationRun",
    "cases_for",
    "companion_systems",
    "run_case",
    "run_case_study",
    "case_findings",
    "simulate_system",
]

#: a callback told the name of each phase of a long run (one line per phase on stderr)
PhaseHook = Callable[[str], None] | None

# --------------------------------------------------------------------------------------------
# cases (the paper's Section IV)


#: the paper's sentences per (system name, mode), with the observable outcome they predict:
#: ``"vanishing"`` -- the post-switch global residual is bounded and vanishes;
#: ``"unbounded"`` -- it grows without bound; ``"no-detection"`` -- the control centre does not detect.
PAPER_CLAIMS: Mapping[tuple[str, str], tuple[str, str]] = MappingProxyType({
    ("paper19", "case-1"): (
        "vanishing",
        "Section IV: conditions (i)-(iii) are met; 'the global residual r_{0_1}(t) for case 1 is bounded and vanishing after topology switching'",
    ),
    ("paper19", "case-2"): (
        "unbounded",
        "Section IV: conditions (i)-(iii) are met; 'that of case 2 is unbounded'",
    ),
    ("paper19-case3", "case-3"): (
        "no-detection",
        "Section IV: 'none of the Theorem III.3's conditions are met in case 3, yielding the global residuals ... remain unaffected by the switching topology. Consequently, stealthy attack is not detectable'",
    ),
})

#: the sentence every case shares
PRE_SWITCH_CLAIM = "ZDA is stealthy in the global residuals before topology switching; it is detectable in a local residual"


@dataclass(frozen=True, slots=True)
class CaseSpec:
    """One case of a case study: a system (with its own attack) and the safe mode it switches to.

    Attributes
    ----------
    name : str
    system : System
    mode : str
    expect : str or None
        ``"vanishing"``, ``"unbounded"`` or ``"no-detection"`` (the paper's claim), or None.
    claim : str
        The paper's sentence.
    """

    name: str
    system: System
    mode: str
    expect: str | None = None
    claim: str = ""


@dataclass(frozen=True, slots=True)
class CaseOutcome:
    """A case's simulated outcome next to the verdicts that predicted it.

    Attributes
    ----------
    case : CaseSpec
    result : Algorithm1Result
    verdicts : mapping of condition id to status (str)
        Verdicts of the case's system in the case's mode (and the global ones).
    observed : str
        Behaviour of the post-switch global residual: ``"vanishing"``, ``"unbounded"`` or
        ``"persistent"`` (:class:`PostSwitch`).
    detected : bool
        The control centre detected the attack after the switch.
    pre_switch_ok : bool
        The attack is invisible in the global residual and detected locally before the switch.
    agrees : bool or None
        ``observed`` matches ``expect`` (None without a claim).
    """

    case: CaseSpec
    result: Algorithm1Result
    verdicts: Mapping[str, str]
    observed: str
    detected: bool
    pre_switch_ok: bool
    agrees: bool | None

    def to_json(self) -> dict[str, Any]:
        """JSON-ready dict (the case table row plus the run summary)."""
        return jsonable(
            {
                "case": self.case.name,
                "system": self.case.system.name,
                "mode": self.case.mode,
                "paper_claim": self.case.claim,
                "expected": self.case.expect,
                "observed": self.observed,
                "detected": self.detected,
                "agrees": self.agrees,
                "pre_switch_ok": self.pre_switch_ok,
                "verdicts": dict(self.verdicts),
                "run": self.result.to_json(),
            }
        )


def companion_systems(system: System) -> dict[str, System]:
    """Companion specs of ``system``: for a safe mode q, a spec named ``<name>-<q>`` (hyphens
    in q optional) that carries case q's own attack.

    Bundled examples are searched for a bundled system (``paper19`` finds ``paper19-case3``
    for mode ``case-3``); for a file, ``<stem>-<q>.toml`` next to it. A companion must define
    the mode q.

    Parameters
    ----------
    system : System
    """
    from pathlib import Path

    from glocal_verify.spec import load_spec
    from glocal_verify.spec.examples import example_names, load_example

    src = system.spec.source or ""
    out: dict[str, System] = {}
    for q in system.safe_modes:
        cands = [f"{system.name}-{q}", f"{system.name}-{q.replace('-', '')}"]
        found: System | None = None
        if src.startswith("<example "):
            for c in cands:
                if c in example_names():
                    found = System(load_example(c))
                    break
        elif src:
            base = Path(src)
            for c in (f"{base.stem}-{q}", f"{base.stem}-{q.replace('-', '')}"):
                p = base.with_name(f"{c}.toml")
                if p.exists():
                    found = System(load_spec(p))
                    break
        if found is not None and q in found.modes:
            out[q] = found
    return out


def cases_for(system: System, companions: Mapping[str, System] | None = None) -> list[CaseSpec]:
    """One case per safe mode of ``system``; a mode listed in ``companions`` uses that system
    (which carries the case's own attack, e.g. ``paper19-case3`` for case 3).

    Parameters
    ----------
    system : System
    companions : mapping of mode name to System, optional
    """
    out = []
    comp = dict(companions or {})
    for q in system.safe_modes:
        s = comp.get(q, system)
        exp, claim = PAPER_CLAIMS.get((s.name, q), (None, ""))
        out.append(CaseSpec(q, s, q, exp, claim))
    return out


#: condition ids whose verdicts the case table shows (those implemented)
CASE_VERDICT_IDS = (
    "stealthy.zda",
    "switching.image-kernel",
    "switching.distinct-eigenvalues",
    "switching.eigenvector-differences",
    "switching.coverage",
    "switching.avoids-attack",
)


def _verdicts(system: System, mode: str) -> dict[str, str]:
    ids = [c for c in CASE_VERDICT_IDS if c in implemented_ids()]
    out: dict[str, str] = {}
    if not ids:
        return out
    rep = check_conditions(system, ids)
    for cid in ids:
        rs = [r for r in rep.results(cid) if r.scope.get("mode") in (None, mode)]
        if not rs:
            continue
        sts = {r.status.value for r in rs}
        out[cid] = sts.pop() if len(sts) == 1 else "mixed"
    return out


def run_case(case: CaseSpec, *, rule: ThresholdRule = ThresholdRule(), method: str = "auto", progress: bool = False) -> CaseOutcome:
    """Simulate one case with the scheduled switch and compare with the paper's claim.

    Parameters
    ----------
    case : CaseSpec
    rule : ThresholdRule
    method : str
    progress : bool
    """
    r = algorithm1(case.system, mode=case.mode, trigger="schedule", rule=rule, method=method, progress=progress)
    ps = r.post_switch
    if ps is None:
        observed = "no-switch"
    elif "unbounded" in (ps.full, ps.attack_part):
        observed = "unbounded"
    else:
        observed = ps.full
    mx = r.residual_max.get("central", {})
    pre_ok = (
        (r.global_before is None or not r.global_before.detected)
        and mx.get("attack_before_relative", 0.0) <= r.thresholds.rule.rounding
        and r.first_local is not None
    )
    agrees = None
    if case.expect == "no-detection":
        agrees = not r.detected_globally
    elif case.expect is not None:
        agrees = observed == case.expect
    return CaseOutcome(case, r, _verdicts(case.system, case.mode), observed, r.detected_globally, bool(pre_ok), agrees)


def case_findings(outcomes: Sequence[CaseOutcome]) -> list[str]:
    """Places where the simulated cases contradict the paper (Markdown sentences).

    * Theorem III.3 says (i)-(iii) are sufficient for ZDA detection when the system is not at
      consensus: a case where every evaluated condition of (i)-(iii) holds and the control
      centre does not detect is a counterexample.
    * Remark III.3.1 / Section IV: the text says only case 2 meets eq. ``unsafe_set`` and that
      case 2 is unbounded, while the remark says meeting it keeps the residual bounded and
      vanishing; the simulation says which case's switch avoids the attack (dL_q xi = 0).

    Parameters
    ----------
    outcomes : sequence of CaseOutcome
    """
    out: list[str] = []
    for oc in outcomes:
        th = [oc.verdicts.get(c) for c in THEOREM_III3_IDS]
        evaluated = [v for v in th if v is not None]
        atk = oc.result.attack
        if evaluated and all(v == "holds" for v in evaluated) and not oc.detected and atk is not None and atk.kind == "zda":
            d = zda_touch(oc.case.system, oc.case.mode, atk)
            out.append(
                f"Theorem III.3 (sufficiency) fails on {oc.case.system.name} / {oc.case.name}: conditions "
                f"{', '.join(c for c, v in zip(THEOREM_III3_IDS, th) if v is not None)} hold, the initial state is "
                f"random (not at consensus), yet the control centre never detects the ZDA "
                f"(||dL_q xi|| / ||xi|| = {d:.1e}: the switch does not touch the agents the ZDA moves, so the "
                f"ZDA is still a zero direction of (A_q, B, C) and the residual equals the attack-free one). "
                f"The paper's 'trade-off between a faster attack detection ... and a slower detection' "
                f"(Section IV) cannot hold for such a switch on any graph: there is no detection, slow or fast. "
                f"Minimal counterexample (3 agents): the bundled example findings/theorem3-sufficiency-switch-avoids-zda."
            )
    # the touch test of switching.avoids-attack decides which switch avoids the simulated direction
    untouched = {oc.case.name: zda_touched(oc.case.system, oc.case.mode, oc.result.attack) is False for oc in outcomes if oc.result.attack is not None and oc.result.attack.xi is not None}
    bounded = [nm for nm, free in untouched.items() if free and any(o.case.name == nm and o.observed == "vanishing" for o in outcomes)]
    unbounded = [oc.case.name for oc in outcomes if oc.observed == "unbounded"]
    if any(oc.case.expect == "unbounded" for oc in outcomes) and unbounded:
        out.append(
            "Section IV vs Remark III.3.1: three sentences cannot all hold, on any graph: (a) the remark, 'the "
            "discrepancy term ... will be bounded and vanishing if (unsafe_set) holds'; (b) Section IV, 'only case 2 "
            "meets (unsafe_set)'; (c) Section IV, 'that [residual] of case 2 is unbounded'. (a) and (b) make case 2 "
            "bounded, against (c). Simulation supports (a) and (c) with X_q ∩ Z = ∅ read as 'the switch does not touch "
            f"the states the attack moves': the cases whose switch avoids the moved agents ({', '.join(bounded) or 'none'}) "
            f"are bounded and vanishing, the case whose switch touches them ({', '.join(unbounded)}) is unbounded. "
            "Sentence (b) is the one that fails: it is case 1, not case 2, that meets (unsafe_set). Touching is not "
            "sufficient either: the bundled example findings/remark-touching-switch-hides-zda (3 agents) touches the ZDA and "
            "the residual stays exactly attack-free, because Theorem III.3 (ii) fails there."
        )
    return out


def _say(phase: PhaseHook, text: str) -> None:
    if phase is not None:
        phase(text)


# --------------------------------------------------------------------------------------------
# one run (``glocal-verify simulate SPEC``)


@dataclass(frozen=True, slots=True)
class SimulationRun:
    """One simulated run of Algorithm 1 and, when asked, the ``switching.detects`` verdicts.

    Attributes
    ----------
    result : Algorithm1Result
    detects : list of dict or None
        The JSON form of every ``switching.detects`` result (one per safe mode).
    """

    result: Algorithm1Result
    detects: list[dict[str, Any]] | None = None


def simulate_system(
    system: System,
    *,
    mode: str | None = None,
    no_switch: bool = False,
    trigger: str = "auto",
    rule: ThresholdRule = ThresholdRule(),
    method: str = "auto",
    progress: bool = False,
    detects: bool = True,
    phase: PhaseHook = None,
) -> SimulationRun:
    """Run :func:`~glocal_verify.conditions.detects.algorithm1` and, with ``detects``, the
    ``switching.detects`` check of every safe mode (what ``glocal-verify simulate SPEC`` computes).

    Parameters
    ----------
    system : System
    mode : str, optional
        Safe mode to switch to.
    no_switch : bool
        Stay in the normal mode.
    trigger : str
        ``"auto"``, ``"schedule"`` or ``"local"`` (:func:`~glocal_verify.conditions.detects.algorithm1`).
    rule : ThresholdRule
    method : str
        Simulation method.
    progress : bool
        Progress bars on stderr.
    detects : bool
        Also record the ``switching.detects`` verdicts of every safe mode.
    phase : callable, optional
        Told the name of each phase as it starts.
    """
    _say(phase, f"simulating {system.name}: thresholds, attacked run and Algorithm 1")
    res = algorithm1(system, mode=mode, no_switch=no_switch, trigger=trigger, rule=rule, method=method, progress=progress)
    verdicts = None
    if detects:
        _say(phase, "switching.detects: one simulated switch per safe mode")
        rep = check_conditions(system, ["switching.detects"], options={"simulate": True})
        verdicts = [r.to_json() for r in rep.conditions]
    return SimulationRun(res, verdicts)


# --------------------------------------------------------------------------------------------
# the case study (``glocal-verify simulate --cases``)


@dataclass(frozen=True, slots=True)
class CaseStudy:
    """The cases of a system, simulated, with their findings.

    Attributes
    ----------
    system : System
    outcomes : tuple of CaseOutcome
    companions : mapping of mode name to System
        The companion systems the cases used.
    findings : tuple of str
        Markdown sentences: where the simulated cases contradict the paper
        (:func:`case_findings`, and Algorithm 1 choosing a mode that never detects).
    local_run : Algorithm1Result or None
        Algorithm 1 with the local trigger (None without an attack or safe modes).
    """

    system: System
    outcomes: tuple[CaseOutcome, ...]
    companions: Mapping[str, System] = field(default_factory=dict)
    findings: tuple[str, ...] = ()
    local_run: Algorithm1Result | None = None


def run_case_study(
    system: System,
    *,
    companions: Mapping[str, System] | None = None,
    rule: ThresholdRule = ThresholdRule(),
    method: str = "auto",
    progress: bool = False,
    phase: PhaseHook = None,
) -> CaseStudy:
    """One case per safe mode (:func:`cases_for`) simulated with the scheduled switch
    (:func:`run_case`), the findings of :func:`case_findings`, and Algorithm 1 with the local
    trigger (what ``glocal-verify simulate --cases`` computes).

    Parameters
    ----------
    system : System
    companions : mapping, optional
        Mode -> System carrying that case's own attack (default :func:`companion_systems`).
    rule : ThresholdRule
    method : str
    progress : bool
    phase : callable, optional
        Told the name of each phase as it starts.
    """
    comp = dict(companions) if companions is not None else None
    if comp is None:
        try:
            comp = companion_systems(system)
        except ValueError:  # a mode name that is no file-name component: no companion file can match
            comp = {}
    outcomes = []
    for c in cases_for(system, comp):
        _say(phase, f"case {c.name}: simulating {c.system.name} with the switch to {c.mode}")
        outcomes.append(run_case(c, rule=rule, method=method, progress=progress))
    findings = case_findings(outcomes)
    alg = None
    if system.spec.attack is not None and system.safe_modes:
        _say(phase, "Algorithm 1 with the local trigger")
        alg = algorithm1(system, trigger="local", rule=rule, method=method, progress=progress)
        if not alg.detected_globally and alg.chosen_mode is not None:
            findings.append(
                f"Algorithm 1, line 4 ('identify a safe mode that satisfies conditions (i)-(iii)') can choose a mode that "
                f"never detects: on {system.name} the best-ranked mode satisfying (i)-(iii) is {alg.chosen_mode}, and after "
                f"switching to it the control centre never detects the ZDA. Conditions (i)-(iii) do not depend on the attack; "
                f"the local centre must also pick a switch that touches the agents its residual shows moving (dL_q xi != 0)."
            )
    return CaseStudy(system, tuple(outcomes), comp, tuple(findings), alg)
