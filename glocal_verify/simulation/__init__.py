"""Simulation: exact piecewise-LTI propagation, attacks, observer models, thresholds, Algorithm 1.

- :mod:`.attacks` -- zero-dynamics and covert attack signals;
- :mod:`.observer_models` -- the central observer and local UIOs as simulated systems;
- :mod:`.schedule` -- switching schedules and simulation results;
- :mod:`.limits` -- samples, bytes and internal steps estimated before a run (refusals);
- :mod:`.engine` -- the propagators (dense and modal) and :func:`simulate`;
- :mod:`.thresholds` -- attack-free residual envelopes and crossings;
- :mod:`.algorithm1` -- Algorithm 1 (``alg:detection_procedure``); the choice of safe mode is
  passed in (the verdicts that rank modes live in :mod:`glocal_verify.conditions`);
- :mod:`.certified_thresholds`, :mod:`.switch_thresholds` -- certified thresholds of the sampled
  detectors over the whole uncertainty set (before and after a switch);
- :mod:`.sampled_attack`, :mod:`.guarantees` -- held attacks, their exact composites and the
  certified detection guarantee (who detects, by when, the smallest size);
- :mod:`.sampled_runs`, :mod:`.escape` -- batched sampled runs of Algorithm 1 (random, vertex,
  worst case) and the largest attack an admissible run hides.
- :mod:`.deployment` -- :func:`design_deployment`: the designed observers, their attack-free
  thresholds, the monitors and the schedule as one frozen :class:`Deployment` (what the export
  writes).

Layer: imports :mod:`glocal_verify.observers`, :mod:`glocal_verify.analysis` and below; never a
checker.
"""
