"""Symbolic and exact checks of the proof steps of the paper (``python -m proofs_checks``).

Each module checks one proof; each step is a sympy residual with a name, the paper equation it
checks and a verdict (see :mod:`proofs_checks.core`). Places where the paper is wrong are steps
with ``paper_error`` set: they are expected failures and do not fail the run.
"""

from .core import MODULES, Decision, Outcome, Step, StepList, Verdict, all_steps, check, decide_zero, run

__all__ = ["MODULES", "Decision", "Outcome", "Step", "StepList", "Verdict", "all_steps", "check", "decide_zero", "run"]
