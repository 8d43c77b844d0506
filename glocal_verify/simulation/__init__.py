"""Simulation: exact piecewise-LTI propagation, attacks, observer models, thresholds, Algorithm 1.

- :mod:`.attacks` -- zero-dynamics and covert attack signals;
- :mod:`.observer_models` -- the central observer and local UIOs as simulated systems;
- :mod:`.schedule` -- switching schedules and simulation results;
- :mod:`.limits` -- samples, bytes and internal steps estimated before a run (refusals);
- :mod:`.engine` -- the propagators (dense and modal) and :func:`simulate`;
- :mod:`.thresholds` -- attack-free residual envelopes and crossings;
- :mod:`.algorithm1` -- Algorithm 1 (``alg:detection_procedure``); the choice of safe mode is
  passed in (the verdicts that rank modes live in :mod:`glocal_verify.conditions`).

Layer: imports :mod:`glocal_verify.observers`, :mod:`glocal_verify.analysis` and below; never a
checker.
"""
