"""Design: answers to the defender's inverse questions, built on the checkers.

- :mod:`.audit` -- every set of 1..k compromised actuators: can it hide, who catches it, which
  safe mode exposes it (:mod:`.audit_screens` its exact screens, :mod:`.audit_local` the
  local observers' part of a row, :mod:`.audit_records` the rows, :mod:`.audit_figure` the
  summary figure);
- :mod:`.safe_modes` -- safe modes (link changes) that satisfy Theorem III.3 and expose the
  audited attacks, by rank-one updates of the spectrum;
- :mod:`.monitors` -- smallest velocity-only global monitor sets that keep privacy;
- :mod:`.network` -- the whole design (monitors, local observers, safe modes) of a spec;
- :mod:`.placement` -- local observer placement (Remark III.2.1);
- :mod:`.generators` -- random clustered networks for tests, benchmarks and sweeps;
- :mod:`.case_study` -- the cases of Section IV (and one Algorithm 1 run), simulated and checked;
- :mod:`.findings` -- the counterexample specs bundled with the package, verified;
- :mod:`.sweep`, :mod:`.sweep_cost`, :mod:`.distributed` -- ensembles of networks and audits on
  Dask (or in this process when workers would not pay off), estimated before they start.

Layer: imports :mod:`glocal_verify.conditions` and below (:mod:`glocal_verify.runtime` for the
files a sweep writes and the processes it starts).
"""
