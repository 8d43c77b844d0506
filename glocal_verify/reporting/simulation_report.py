"""Writes simulation and case-study reports (JSON, Markdown, figures) into a chosen folder.

Every folder is written all-or-nothing through :class:`~glocal_verify.reporting.output.OutputFolder`
(staged, then moved into place; an error or Ctrl-C leaves the folder as it was), and every
file name derived from the spec (mode and case names) goes through
:func:`~glocal_verify.reporting.output.safe_component`. Figures are optional
(``figures=False`` never imports matplotlib). The runs are computed by
:mod:`glocal_verify.design.case_study`; this module only writes them.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any, Callable, Sequence

from glocal_verify.design.case_study import CaseOutcome, CaseStudy, SimulationRun
from glocal_verify.model import System
from glocal_verify.reporting.output import OutputFolder, check_output_dir, safe_component
from glocal_verify.results import jsonable
from glocal_verify.simulation.algorithm1 import Algorithm1Result

__all__ = [
    "write_run",
    "write_cases",
    "cases_table",
    "write_simulation",
    "write_case_study",
]

#: a callback told the name of each phase of a long run (one line per phase on stderr)
PhaseHook = Callable[[str], None] | None

# --------------------------------------------------------------------------------------------
# files


def _say(phase: PhaseHook, text: str) -> None:
    if phase is not None:
        phase(text)


def _put_run(folder: OutputFolder, system: System, res: Algorithm1Result, stem: str, verdicts: Any, figures: bool, phase: PhaseHook = None) -> list[Path]:
    data = res.to_json()
    if verdicts is not None:
        data["verdicts"] = jsonable(verdicts)
    paths = [folder.write_text(f"{stem}.json", json.dumps(data, indent=2) + "\n")]
    if figures:
        _say(phase, f"drawing {stem}.png and {stem}.svg (states, residuals and thresholds of the run)")
        from glocal_verify.reporting.figures.canvas import figure_bytes
        from glocal_verify.reporting.figures.simulation import plot_run

        for ext, blob in figure_bytes(plot_run(system, res)).items():
            paths.append(folder.write_bytes(f"{stem}.{ext}", blob))
    return paths


def write_run(
    system: System,
    res: Algorithm1Result,
    out_dir: str | Path,
    stem: str = "simulation",
    *,
    verdicts: Any = None,
    figures: bool = True,
    inputs: Sequence[str] = (),
) -> list[Path]:
    """Write ``<stem>.json`` (the summary of :meth:`Algorithm1Result.to_json`) and the figure
    ``<stem>.{png,svg}``, all or nothing.

    Parameters
    ----------
    system : System
    res : Algorithm1Result
    out_dir : path
    stem : str
        File name stem (passed through :func:`~glocal_verify.reporting.output.safe_component`).
    verdicts : any, optional
        Extra JSON-ready data stored under ``"verdicts"`` (e.g. ``switching.detects`` results).
    figures : bool
        Also draw the figure (False: matplotlib is not imported).
    inputs : sequence of str
        Files the command read: none of them may be replaced.
    """
    with OutputFolder(out_dir, inputs=inputs) as folder:
        _put_run(folder, system, res, safe_component(stem), verdicts, figures)
    return folder.written


def _fmt_time(x: float | None) -> str:
    return "-" if x is None else f"{x:.2f} s"


def cases_table(outcomes: Sequence[CaseOutcome]) -> str:
    """Markdown table: predicted verdicts, the paper's claim and the simulated outcome per case.

    Parameters
    ----------
    outcomes : sequence of CaseOutcome
    """
    ids = []
    for oc in outcomes:
        for cid in oc.verdicts:
            if cid not in ids:
                ids.append(cid)
    short = {
        "stealthy.zda": "ZDA exists",
        "switching.image-kernel": "(i)",
        "switching.distinct-eigenvalues": "(ii)",
        "switching.eigenvector-differences": "(iii)",
        "switching.coverage": "Lemma A.2",
        "switching.avoids-attack": "switch avoids the attack (switching.avoids-attack)",
    }
    head = ["case", "spec", "attack (moved agents)"] + [short.get(c, c) for c in ids] + [
        "local detection (before switch)",
        "global before switch (attack part / state)",
        "switch",
        "global after switch",
        "control centre",
        "paper says",
        "agrees",
    ]
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for oc in outcomes:
        r = oc.result
        atk = r.attack
        a = f"{atk.kind} on {list(atk.actuators)} ({list(atk.moved)})" if atk else "none"
        loc = r.first_local
        locs = f"{loc.observer} at {_fmt_time(loc.time)} ({loc.channel})" if loc else "none"
        mx = r.residual_max.get("central", {})
        gb = f"{mx.get('attack_before_relative', float('nan')):.1e}"
        ga = r.global_after
        det = f"detects at {_fmt_time(ga.time)}" if (ga and ga.detected) else "no detection"
        ps = r.post_switch.summary if r.post_switch else "-"
        claim = oc.case.expect or "-"
        agree = "-" if oc.agrees is None else ("yes" if oc.agrees else "**no**")
        row = [oc.case.name, oc.case.system.name, a] + [oc.verdicts.get(c, "-") for c in ids] + [
            locs,
            gb,
            f"{r.chosen_mode} at {_fmt_time(r.switch_time)}",
            ps,
            det,
            claim,
            agree,
        ]
        lines.append("| " + " | ".join(str(x) for x in row) + " |")
    return "\n".join(lines)


def write_cases(
    outcomes: Sequence[CaseOutcome],
    out_dir: str | Path,
    *,
    preamble: str = "",
    findings: Sequence[str] = (),
    sections: Sequence[tuple[str, str]] = (),
    figures: bool = True,
    inputs: Sequence[str] = (),
    phase: PhaseHook = None,
) -> list[Path]:
    """Write ``cases.md`` (outcome table and verdicts), ``cases.json``, ``figure2.{png,svg}`` and
    one ``<case>.{json,png,svg}`` per case (``<case>`` is the
    :func:`~glocal_verify.reporting.output.safe_component` of the case name), all or nothing.

    Parameters
    ----------
    outcomes : sequence of CaseOutcome
    out_dir : path
    preamble : str
        Markdown inserted after the title (how the files were generated).
    findings : sequence of str
        Markdown bullet texts listed under "Findings".
    sections : sequence of (title, markdown)
        Extra sections placed before the findings.
    figures : bool
        Also draw the figures (False: matplotlib is not imported).
    inputs : sequence of str
        Files the command read: none of them may be replaced.
    phase : callable, optional
        Told each figure as its drawing starts (drawing is most of the time spent here).
    """
    with OutputFolder(out_dir, inputs=inputs) as folder:
        _put_cases(folder, outcomes, preamble, findings, sections, figures, phase)
    return folder.written


def _put_cases(
    folder: OutputFolder,
    outcomes: Sequence[CaseOutcome],
    preamble: str,
    findings: Sequence[str],
    sections: Sequence[tuple[str, str]],
    figures: bool,
    phase: PhaseHook = None,
) -> None:
    for oc in outcomes:
        _put_run(folder, oc.case.system, oc.result, safe_component(oc.case.name), {"case": oc.to_json() | {"run": None}}, figures, phase)
    if figures:
        _say(phase, "drawing figure2.png and figure2.svg (Figure 2: every case side by side)")
        from glocal_verify.reporting.figures.canvas import figure_bytes
        from glocal_verify.reporting.figures.simulation import plot_cases

        for ext, blob in figure_bytes(plot_cases(outcomes)).items():
            folder.write_bytes(f"figure2.{ext}", blob)
    data = {"cases": [oc.to_json() for oc in outcomes]}
    folder.write_text("cases.json", json.dumps(jsonable(data), indent=2) + "\n")
    rule = outcomes[0].result.thresholds.rule.describe() if outcomes else ""
    lines = ["# Section IV cases, simulated exactly", ""]
    if preamble:
        lines += [preamble, ""]
    lines += ["## Outcome table", "", cases_table(outcomes), ""]
    lines += [
        "Columns: verdicts of the toolkit's checkers for the case's system and safe mode; the first",
        "local detection before the switch; the attack-induced part of the global residual before",
        "the switch relative to the state norm (rounding level means invisible); the behaviour of the",
        "global residual after the switch; whether the control centre detects (its residual crosses",
        "the threshold after the switch); the outcome the paper states and whether the simulation agrees.",
        "",
        f"Thresholds: {rule}.",
        "",
        "## Paper sentences",
        "",
    ]
    for oc in outcomes:
        lines.append(f"- **{oc.case.name}** — {oc.case.claim or 'no claim recorded'}")
        lines.append(
            f"  - simulated: pre-switch stealth and local detection {'hold' if oc.pre_switch_ok else 'DO NOT hold'}; "
            f"after the switch the global residual is {oc.result.post_switch.summary if oc.result.post_switch else 'not switched'}; "
            f"the control centre {'detects' if oc.detected else 'does not detect'} the attack."
        )
        fl = oc.result.first_local
        if fl is not None and fl.time == 0.0:
            lines.append(
                f"  - the local detection by {fl.observer} at t = 0 comes from the ZDA's initial deviation x~0 "
                "(part of the actual initial state, Proposition II.4 (ii)): no attack-free initial state in the box "
                "produces that local measurement; the local residual then keeps growing with the attack (figure, panel c)."
            )
    for title, body in sections:
        lines += ["", f"## {title}", "", body]
    if findings:
        lines += ["", "## Findings", ""]
        lines += [f"- {f}" for f in findings]
    lines += [
        "",
        "## Figures",
        "",
        "- `figure2.png` / `figure2.svg`: one column per case (states, global residuals with thresholds,",
        "  local residuals relative to their thresholds, topology with the case's switching links).",
        "- `<case>.png` / `<case>.svg` and `<case>.json`: each run on its own, with the JSON summary",
        "  (events, detection times, residual maxima before and after the switch).",
        "",
    ]
    if not figures:
        lines[-7:-1] = ["## Figures", "", "Not drawn (`--no-figures`); `<case>.json` holds each run's JSON summary."]
    folder.write_text("cases.md", "\n".join(lines) + "\n")


def write_simulation(
    system: System, run: SimulationRun, out_dir: str | Path, *, figures: bool = True, phase: PhaseHook = None, inputs: Sequence[str] = ()
) -> list[Path]:
    """Write the summary and figure of one run of :func:`~glocal_verify.design.case_study.simulate_system`
    (what ``glocal-verify simulate SPEC`` writes).

    Parameters
    ----------
    system : System
    run : SimulationRun
    out_dir : path
    figures : bool
        Draw the figure (False: matplotlib is not imported).
    phase : callable, optional
        Told the name of each phase as it starts.
    inputs : sequence of str
        Files the command read: none of them may be replaced.

    Notes
    -----
    The files are ``simulation-<mode>.{json,png,svg}`` with ``<mode>`` the
    :func:`~glocal_verify.reporting.output.safe_component` of the chosen mode; the
    ``switching.detects`` verdicts, when computed, are stored under ``"verdicts"``.
    """
    check_output_dir(out_dir, inputs=inputs)
    res = run.result
    stem = "simulation-" + safe_component(res.chosen_mode or "normal")
    _say(phase, "writing the summary" + (" and the figure" if figures else ""))
    return write_run(system, res, out_dir, stem, verdicts=run.detects, figures=figures, inputs=inputs)


def _local_trigger_section(system: System, alg: Algorithm1Result) -> str:
    """The paragraph on Algorithm 1 with the local trigger."""
    fl = alg.first_local
    ranking = ", ".join(f"{r.mode} ({'eligible' if r.eligible else 'not eligible'}, score {r.score:.3g})" for r in alg.ranking)
    return (
        f"Algorithm 1 as written, on `{system.name}`: the observers run in the normal mode; the first local "
        f"detection is {fl.observer + ' at t = ' + format(fl.time or 0.0, '.2f') + ' s' if fl else 'none'}; line 4 "
        f"ranks the safe modes by Theorem III.3 (i)-(iii) and their margins: {ranking}; it switches to "
        f"**{alg.chosen_mode}** at t = {alg.switch_time if alg.switch_time is not None else '-'} s, and the control centre "
        + (f"detects the attack at t = {alg.global_after.time:.2f} s." if alg.detected_globally and alg.global_after else "**never detects** the attack.")
    )


def write_case_study(
    study: CaseStudy, out_dir: str | Path, *, command: str = "", figures: bool = True, phase: PhaseHook = None, inputs: Sequence[str] = ()
) -> list[Path]:
    """Write a case study of :func:`~glocal_verify.design.case_study.run_case_study` with
    :func:`write_cases` (what ``glocal-verify simulate --cases`` writes).

    Parameters
    ----------
    study : CaseStudy
    out_dir : path
    command : str
        The command line, recorded in ``cases.md``.
    figures : bool
        Draw the figures (False: matplotlib is not imported).
    phase : callable, optional
        Told the name of each phase as it starts.
    inputs : sequence of str
        Files the command read: none of them may be replaced.
    """
    pre = "Generated by `" + (command or "glocal-verify simulate --cases") + "`; never edited by hand."
    pre += " Every run is an exact piecewise-LTI simulation (matrix exponentials; see `glocal_verify/simulation/engine.py`)."
    if study.companions:
        pre += " Companion specs: " + ", ".join(f"{q} uses `{s.name}`" for q, s in study.companions.items()) + "."
    sections: list[tuple[str, str]] = []
    if study.local_run is not None:
        sections.append(("Algorithm 1 with the local trigger", _local_trigger_section(study.system, study.local_run)))
    _say(phase, "writing the outcome table (cases.md, cases.json)" + (f" and {2 * len(study.outcomes) + 2} figures" if figures else ""))
    check_output_dir(out_dir, inputs=inputs)
    return write_cases(study.outcomes, out_dir, preamble=pre, findings=study.findings, sections=sections, figures=figures, inputs=inputs, phase=phase)
