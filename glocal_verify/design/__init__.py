"""Design: answers to the defender's inverse questions, built on the checkers.

- :mod:`.audit` -- every set of 1..k compromised actuators: can it hide, who catches it, which
  safe mode exposes it (:mod:`.audit_local` the local observers' part of a row,
  :mod:`.audit_records` the rows and their JSON form);
- :mod:`.safe_modes` -- safe modes (link changes) that satisfy Theorem III.3 and expose the
  audited attacks, by rank-one updates of the spectrum;
- :mod:`.monitors` -- smallest velocity-only global monitor sets that keep privacy;
- :mod:`.network` -- the whole design (monitors, local observers, safe modes) of a spec;
- :mod:`.placement` -- local observer placement (Remark III.2.1);
- :mod:`.generators` -- random clustered networks for tests, benchmarks and sweeps;
- :mod:`.case_study` -- the cases of Section IV (and one Algorithm 1 run), simulated and checked;
- :mod:`.findings` -- the counterexample specs bundled with the package, verified;
- :mod:`.sweep`, :mod:`.sweep_cost` -- ensembles of networks on Dask
  (:mod:`glocal_verify.extra.dask`, or in this process when workers would not pay off),
  estimated before they start, and their rates of ``holds``.

Design draws nothing: its figures, the audit's text and a sweep's table, summary
and plots are rendered by :mod:`glocal_verify.reporting` from the values it returns. The one
file it still writes is a sweep's parts folder, the resume state of a running sweep.

Layer: imports :mod:`glocal_verify.answer`, :mod:`glocal_verify.conditions` and below
(:mod:`glocal_verify.runtime` for a sweep's parts and the processes it starts).
"""
