"""The assessment a report carries, as every renderer reads it.

Every format leads with the assessment (Problems 1 and 2, :mod:`glocal_verify.answer.assessment`);
it is computed below the renderers, by :func:`glocal_verify.verify` or
:func:`~glocal_verify.answer.assessment.with_assessment`, never here.
"""

from __future__ import annotations

from glocal_verify.answer.assessment import Assessment
from glocal_verify.errors import ArgumentError
from glocal_verify.results import Report

__all__ = ["assessment_of"]


def assessment_of(report: Report) -> Assessment:
    """The assessment ``report`` carries: every format leads with it, and no renderer computes it.

    The report :func:`glocal_verify.verify` returns carries it; for another one,
    :func:`glocal_verify.answer.assessment.with_assessment` attaches it.

    Raises
    ------
    ArgumentError
        When the report carries none.
    """
    if report.assessment is None:
        raise ArgumentError("report: it carries no assessment; render the report glocal_verify.verify returns, or attach one with glocal_verify.answer.assessment.with_assessment(report)")
    return report.assessment
