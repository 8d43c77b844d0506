"""Reporting: renderers of given results (reports, figures, the case study's folder, the findings report).

- :mod:`.assessment` -- the bottom line of a report (Problems 1 and 2), from its results alone;
- :mod:`.render` -- Markdown, JSON and HTML reports and the report schema (``schemas/``);
- :mod:`.html`, :mod:`.network_svg` -- the self-contained HTML report and the network drawing (SVG);
- :mod:`.figures` -- figures drawn from given results (no simulation inside);
- :mod:`.guarantee_figures` -- thresholds, residuals and detection times of the sampled guarantees;
- :mod:`.simulation_report` -- writes simulation and case-study reports to a folder;
- :mod:`.findings` -- writes ``findings.md`` from the verified finding specs;
- :mod:`.layout`, :mod:`.network_figure` -- where agents and links go in every network drawing
  (no link passes through an agent it does not join), and the drawing on a matplotlib axes;
- :mod:`.export` -- a :class:`~glocal_verify.simulation.deployment.Deployment` (observers,
  thresholds, schedule) as a ``.mat``, JSON or ``.npz`` file (``docs/export.md``);
- :mod:`.words` -- small helpers for the words of messages (``1 mode``, ``4 modes``).

Reporting renders only: it never runs a checker, the simulator or Algorithm 1 (the runs are
computed by :mod:`glocal_verify.design.case_study` and :mod:`glocal_verify.design.findings`).

Layer: the top of the library; imports anything below, nothing imports it but the CLI.
"""
