"""Reporting: renderers of given results (reports, figures, the case study's folder, the findings report).

- :mod:`.assessment` -- the assessment a report carries, as every renderer reads it;
- :mod:`.render` -- Markdown, JSON and HTML reports and the report schema (``schemas/``), each
  led by the assessment the report carries (:func:`glocal_verify.answer.assessment.assess`);
- :mod:`.html`, :mod:`.network_svg` -- the self-contained HTML report and the network drawing (SVG);
- :mod:`.audit_html` -- an audit as one self-contained HTML page;
- :mod:`.output` -- the output policy of :mod:`glocal_verify.runtime.files` as the renderers use it;
- :mod:`.figures` -- every matplotlib figure, drawn from given results on the Agg canvas
  (the simulation runs, the sampled guarantees, the audit, a sweep's rates, the network panel);
- :mod:`.simulation_report` -- writes simulation and case-study reports to a folder;
- :mod:`.findings` -- writes ``findings.md`` from the verified finding specs;
- :mod:`.sweep_report` -- a sweep's results table, Markdown summary and plots;
- :mod:`.layout` -- where agents and links go in every network drawing (no link passes
  through an agent it does not join);
- :mod:`.export` -- a :class:`~glocal_verify.simulation.deployment.Deployment` (observers,
  thresholds, schedule) as a ``.mat``, JSON or ``.npz`` file (``docs/export.md``);

Reporting renders only: it calls no function of :mod:`glocal_verify.analysis`,
:mod:`glocal_verify.observers`, :mod:`glocal_verify.simulation`, :mod:`glocal_verify.conditions`,
:mod:`glocal_verify.answer` or :mod:`glocal_verify.design` (``tests/test_architecture.py``): the
runs, the assessment, the deployment and a sweep's rates are computed below it and handed over
(:mod:`glocal_verify.design.case_study`, :mod:`glocal_verify.design.findings`,
:func:`glocal_verify.answer.assessment.with_assessment`,
:func:`glocal_verify.simulation.deployment.design_deployment`,
:func:`glocal_verify.design.sweep.sweep_rates`).

Layer: the top of the library; imports anything below, nothing imports it but the CLI.
"""
