"""The one answer: for an attacker, is it stealthy, caught locally, exposed, detected by the glocal scheme?

Layer: above ``conditions`` (it reads their results), below ``design`` and ``reporting`` (the
audit, the designs, the reports, ``--require`` and the notebook displays all read it). It
decides nothing about matrices: every answer is a combination of condition statuses, by the
rules written once here.

- :mod:`glocal_verify.answer.attack` -- the per-attacker answer (:func:`answer_attack`) from
  typed evidence: stealthy to the control centre, caught locally by which observer, exposed by
  which safe mode, and detected under Algorithm 1 and under a ``[switching]`` schedule, with
  the chain that proves it;
- :mod:`glocal_verify.answer.evidence` -- that evidence read from a report's results;
- :mod:`glocal_verify.answer.assessment` -- the bottom line of a report (privacy, the attack,
  warnings);
- :mod:`glocal_verify.answer.gate` -- ``--require``: a CI gate on favourable results;
- :mod:`glocal_verify.answer.run` -- :func:`verify`, the public entry point: the checkers, the
  simulation by one option, and the assessment attached (the command line calls it too).
"""

__all__: list[str] = []
