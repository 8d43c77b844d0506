"""Figures: every matplotlib drawing of the toolkit, from results it is given.

- :mod:`.canvas` -- the bare Agg canvas every figure is rendered from, to PNG and SVG bytes;
- :mod:`.simulation` -- the runs of ``glocal-verify simulate`` and the case study (the paper's
  Figure 2: states, residuals against their thresholds, the network);
- :mod:`.network` -- the network drawn on a matplotlib axes (the topology panels);
- :mod:`.guarantees` -- certified thresholds, simulated residuals, detection times and period
  scans of the sampled guarantees;
- :mod:`.audit` -- an attack audit per agent or pair of agents;
- :mod:`.replay` -- a replayed log: residuals over their thresholds, alarms and the switch;
- :mod:`.sweep` -- a sweep's rate of ``holds`` against one swept parameter.

Matplotlib is imported by these modules only, and they are imported only when a figure is
drawn (``--no-figures`` never loads it).

Layer: part of :mod:`glocal_verify.reporting`; imports the result types below it.
"""

__all__: list[str] = []
