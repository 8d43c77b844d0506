"""Steps, exact zero decisions and the runner of ``python -m proofs_checks``.

A *step* is one claim of a proof in the paper, reduced to a residual that must be (or, for a
documented paper error, is expected not to be) identically zero:

- ``Step.residual`` is a sympy expression or matrix, or a zero-argument callable returning
  one (steps are built lazily, so ``--list`` costs nothing).
- ``Step.expected`` says what the mathematics gives: ``"zero"`` or ``"nonzero"``.
- ``Step.paper_error`` is empty for an ordinary proof step and a one-line explanation when the
  step documents a place where the paper is wrong. Such a step is an *expected failure*:
  when the residual comes out as expected the verdict is ``EXPECTED-FAIL`` (the paper's claim
  fails, as documented), otherwise ``UNEXPECTED-PASS``.

Verdicts
--------
===============  =============================================  ==========
residual         ordinary step                                  paper-error step
===============  =============================================  ==========
as expected      ``PASS``                                       ``EXPECTED-FAIL``
not as expected  ``FAIL``                                       ``UNEXPECTED-PASS``
not decidable    ``UNDECIDED``                                  ``UNDECIDED``
===============  =============================================  ==========

``FAIL``, ``UNEXPECTED-PASS``, ``UNDECIDED`` and ``ERROR`` (the step raised) make the run
exit with status 1.

Zero decision (no floats anywhere)
----------------------------------
Every entry is expanded. Non-commutative symbols stand for matrix blocks of any conforming
size: the expansion is grouped by non-commutative monomial and each commutative coefficient is
reduced with ``cancel``; the entry is zero iff every coefficient is. A commutative rational
function is zero iff ``cancel`` gives 0, and a nonzero canonical rational function is certainly
nonzero. Anything else (radicals, exponentials) goes through ``simplify``; if it does not reduce
to 0 and sympy cannot prove it nonzero, the entry is *undecided*. A residual containing a
``Float`` is rejected: symbolic checks use exact numbers only (``Rational``).
"""

from __future__ import annotations

import enum
import importlib
import time
from collections import defaultdict
from dataclasses import dataclass, field
from typing import Callable, Iterable, Literal, Sequence, Union

import sympy as sp

__all__ = [
    "Step",
    "StepList",
    "Verdict",
    "Decision",
    "Outcome",
    "decide_zero",
    "check",
    "run",
    "all_steps",
    "MODULES",
]

#: The proof modules, in report order.
MODULES: tuple[str, ...] = (
    "lemma_iii1",
    "modal_unobservable",
    "prop_ii4",
    "uio_error",
    "appendix_c",
    "central_observer",
    "appendix_d",
    "lemma_a2",
    "theorem_iii3",
)

Residual = Union[sp.Basic, sp.MatrixBase, int]


class Decision(str, enum.Enum):
    """Outcome of the exact zero test of a residual."""

    ZERO = "zero"
    NONZERO = "nonzero"
    UNDECIDED = "undecided"


class Verdict(str, enum.Enum):
    """Verdict of one step (see the module docstring for the table)."""

    PASS = "PASS"
    FAIL = "FAIL"
    EXPECTED_FAIL = "EXPECTED-FAIL"
    UNEXPECTED_PASS = "UNEXPECTED-PASS"
    UNDECIDED = "UNDECIDED"
    ERROR = "ERROR"

    @property
    def ok(self) -> bool:
        """True for the verdicts that keep the exit status 0."""
        return self in (Verdict.PASS, Verdict.EXPECTED_FAIL)


@dataclass(frozen=True, slots=True)
class Step:
    """One checked claim of a proof.

    Attributes
    ----------
    module : str
        Proof module the step belongs to (``lemma_iii1``, ...).
    name : str
        Step name, unique within its module; reads as a claim.
    equation : str
        The paper's equation label(s) the step checks (e.g. ``PBH_test``).
    reference : str
        Where in the paper (e.g. ``"Appendix B (proof of Lemma III.1)"``).
    residual : sympy expression or matrix, or zero-argument callable returning one
        The quantity whose zero-ness is decided.
    expected : {"zero", "nonzero"}
        What the residual is expected to be.
    paper_error : str
        Empty for an ordinary step; otherwise a one-line statement of the paper error the step
        exhibits (the step is then an expected failure).
    note : str
        What the step proves or the instance it uses (counterexamples are described here).
    """

    module: str
    name: str
    equation: str
    reference: str
    residual: Residual | Callable[[], Residual]
    expected: Literal["zero", "nonzero"] = "zero"
    paper_error: str = ""
    note: str = ""

    @property
    def qualname(self) -> str:
        return f"{self.module}.{self.name}"

    def evaluate(self) -> Residual:
        """The residual (calling the builder if the step is lazy)."""
        r = self.residual
        if isinstance(r, (sp.Basic, sp.MatrixBase, int, list, tuple)):
            return r  # sympy symbols are callable: test for values first
        return r()


class StepList(list[Step]):
    """The steps of one module, filled by the :meth:`add` decorator.

    Examples
    --------
    >>> steps = StepList("demo")
    >>> @steps.add("trivial", equation="none", reference="none")
    ... def _trivial():
    ...     return sp.Integer(0)
    >>> check(steps[0]).verdict.value
    'PASS'
    """

    def __init__(self, module: str) -> None:
        super().__init__()
        self.module = module

    def add(
        self,
        name: str,
        *,
        equation: str,
        reference: str,
        expected: Literal["zero", "nonzero"] = "zero",
        paper_error: str = "",
        note: str = "",
    ) -> Callable[[Callable[[], Residual]], Callable[[], Residual]]:
        """Register the decorated zero-argument function as the residual builder of a step.

        The function's docstring (first paragraph) is used as the note when ``note`` is empty.
        """

        def deco(fn: Callable[[], Residual]) -> Callable[[], Residual]:
            text = note or _first_paragraph(fn.__doc__ or "")
            if any(s.name == name for s in self):
                raise ValueError(f"duplicate step name {self.module}.{name}")
            self.append(Step(self.module, name, equation, reference, fn, expected, paper_error, text))
            return fn

        return deco


def _first_paragraph(doc: str) -> str:
    lines = []
    for line in doc.strip().splitlines():
        if not line.strip():
            break
        lines.append(line.strip())
    return " ".join(lines)


# -- zero decision ---------------------------------------------------------------------------
def _entries(residual: Residual) -> list[sp.Basic]:
    if isinstance(residual, sp.MatrixBase):
        return list(residual)
    if isinstance(residual, (list, tuple)):
        out: list[sp.Basic] = []
        for r in residual:
            out.extend(_entries(r))
        return out
    if isinstance(residual, bool):
        raise TypeError("a residual must be a sympy expression or matrix, not a bool")
    return [sp.sympify(residual)]


def _decide_entry(e: sp.Basic) -> Decision:
    if e.has(sp.Float):
        raise TypeError(f"floating-point number in a symbolic residual: {e}")
    ex = sp.expand(e)
    if ex == 0:
        return Decision.ZERO
    if not ex.is_commutative:
        # Group by non-commutative monomial; coefficients are commutative expressions.
        coeffs: dict[tuple[sp.Basic, ...], sp.Basic] = defaultdict(lambda: sp.Integer(0))
        for term in sp.Add.make_args(ex):
            c, nc = term.args_cnc()
            coeffs[tuple(nc)] += sp.Mul(*c)
        results = [_decide_commutative(c) for c in coeffs.values()]
        if all(r is Decision.ZERO for r in results):
            return Decision.ZERO
        if any(r is Decision.NONZERO for r in results):
            return Decision.NONZERO
        return Decision.UNDECIDED
    return _decide_commutative(ex)


def _decide_commutative(e: sp.Basic) -> Decision:
    c = sp.cancel(sp.together(e))
    if c == 0:
        return Decision.ZERO
    if c.is_number:
        z = c.is_zero
        if z is True:
            return Decision.ZERO
        if z is False:
            return Decision.NONZERO
    if not c.atoms(sp.Function, sp.Pow) or _is_rational_function(c):
        return Decision.NONZERO
    s = sp.simplify(c)
    if s == 0:
        return Decision.ZERO
    z = s.is_zero
    if z is False:
        return Decision.NONZERO
    return Decision.UNDECIDED


def _is_rational_function(e: sp.Basic) -> bool:
    syms = e.free_symbols
    return bool(syms) and e.is_rational_function(*syms) and not e.atoms(sp.Function)


def decide_zero(residual: Residual) -> Decision:
    """Decide exactly whether a residual (expression, matrix or list of them) is zero.

    Parameters
    ----------
    residual : sympy expression, matrix, int, or list/tuple of them

    Returns
    -------
    Decision
        ``ZERO`` if every entry is identically zero, ``NONZERO`` if some entry is certainly
        nonzero, ``UNDECIDED`` otherwise.

    Raises
    ------
    TypeError
        If the residual contains a floating-point number.
    """
    seen_undecided = False
    for e in _entries(residual):
        d = _decide_entry(e)
        if d is Decision.NONZERO:
            return d
        if d is Decision.UNDECIDED:
            seen_undecided = True
    return Decision.UNDECIDED if seen_undecided else Decision.ZERO


# -- running -------------------------------------------------------------------------------
@dataclass(frozen=True, slots=True)
class Outcome:
    """The result of running one step."""

    step: Step
    verdict: Verdict
    decision: Decision | None
    residual: str
    seconds: float
    error: str = ""

    def as_dict(self) -> dict[str, object]:
        s = self.step
        return {
            "module": s.module,
            "step": s.name,
            "equation": s.equation,
            "reference": s.reference,
            "expected": s.expected,
            "paper_error": s.paper_error,
            "note": s.note,
            "verdict": self.verdict.value,
            "decision": self.decision.value if self.decision else None,
            "residual": self.residual,
            "seconds": round(self.seconds, 4),
            "error": self.error,
        }


def _residual_text(residual: Residual) -> str:
    if isinstance(residual, sp.MatrixBase):
        r = residual.applyfunc(lambda z: sp.factor_terms(sp.expand(z)) if z.is_commutative else sp.expand(z))
        return sp.sstr(r.tolist())
    if isinstance(residual, (list, tuple)):
        return "[" + ", ".join(_residual_text(r) for r in residual) + "]"
    return sp.sstr(sp.expand(sp.sympify(residual)))


def check(step: Step) -> Outcome:
    """Evaluate a step's residual, decide it exactly and give the verdict.

    Exceptions raised while building the residual become ``Verdict.ERROR``.
    """
    t0 = time.perf_counter()
    try:
        residual = step.evaluate()
        decision = decide_zero(residual)
    except Exception as exc:  # a step that cannot be built is a failure, never a pass
        return Outcome(step, Verdict.ERROR, None, "", time.perf_counter() - t0, f"{type(exc).__name__}: {exc}")
    if decision is Decision.UNDECIDED:
        verdict = Verdict.UNDECIDED
    else:
        as_expected = decision.value == step.expected
        if step.paper_error:
            verdict = Verdict.EXPECTED_FAIL if as_expected else Verdict.UNEXPECTED_PASS
        else:
            verdict = Verdict.PASS if as_expected else Verdict.FAIL
    text = "0" if decision is Decision.ZERO else _residual_text(residual)
    return Outcome(step, verdict, decision, text, time.perf_counter() - t0)


def all_steps(modules: Sequence[str] = MODULES) -> list[Step]:
    """Import the proof modules and return their steps in report order."""
    out: list[Step] = []
    for name in modules:
        mod = importlib.import_module(f"proofs_checks.{name}")
        out.extend(mod.STEPS)
    return out


def select(steps: Iterable[Step], only: Sequence[str]) -> list[Step]:
    """Steps whose module, step name or ``module.step`` matches one of ``only`` (fnmatch).

    Raises
    ------
    KeyError
        If some name matches nothing; the message lists the closest names.
    """
    import difflib
    import fnmatch

    steps = list(steps)
    chosen: list[Step] = []
    for pat in only:
        hits = [
            s
            for s in steps
            if fnmatch.fnmatchcase(s.module, pat) or fnmatch.fnmatchcase(s.name, pat) or fnmatch.fnmatchcase(s.qualname, pat)
        ]
        if not hits:
            names = sorted({s.module for s in steps} | {s.qualname for s in steps})
            close = difflib.get_close_matches(pat, names, n=4, cutoff=0.5)
            hint = f" (did you mean {', '.join(close)}?)" if close else ""
            raise KeyError(f"no check named {pat!r}{hint}")
        for s in hits:
            if s not in chosen:
                chosen.append(s)
    order = {id(s): i for i, s in enumerate(steps)}
    return sorted(chosen, key=lambda s: order[id(s)])


def run(steps: Iterable[Step], progress: Callable[[Outcome], None] | None = None) -> list[Outcome]:
    """Check every step in order; ``progress`` is called after each one."""
    out = []
    for s in steps:
        o = check(s)
        out.append(o)
        if progress is not None:
            progress(o)
    return out


@dataclass(frozen=True, slots=True)
class Summary:
    """Counts of verdicts and the exit status of a run."""

    counts: dict[str, int] = field(default_factory=dict)

    @staticmethod
    def of(outcomes: Sequence[Outcome]) -> "Summary":
        c: dict[str, int] = {v.value: 0 for v in Verdict}
        for o in outcomes:
            c[o.verdict.value] += 1
        return Summary(c)

    @property
    def exit_status(self) -> int:
        bad = sum(n for v, n in self.counts.items() if not Verdict(v).ok)
        return 1 if bad else 0
