"""Reporting: renderers, figures, the Section IV case study and the findings report.

- :mod:`.assessment` -- the bottom line of a report (Problems 1 and 2), from its results alone;
- :mod:`.render` -- Markdown, JSON and HTML reports and the report schema (``schemas/``);
- :mod:`.html`, :mod:`.network_svg` -- the self-contained HTML report and the network drawing;
- :mod:`.figures` -- figures drawn from given results (no simulation inside);
- :mod:`.guarantee_figures` -- thresholds, residuals and detection times of the sampled guarantees;
- :mod:`.case_study` -- the three cases of Section IV, simulated and checked;
- :mod:`.simulation_report` -- writes simulation and case-study reports to a folder;
- :mod:`.findings` -- re-verifies every finding spec and writes ``findings.md``.

Layer: the top of the library; imports anything below, nothing imports it but the CLI.
"""
