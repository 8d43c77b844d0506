"""Observers: design of the centralised Luenberger observer and of the local unknown-input observers.

- :mod:`.central` -- eq. ``obs_cent``: a gain H stabilising A_1 - H C on the observable part;
- :mod:`.uio_existence` -- existence of the UIO (Chen, Patton & Zhang) and its certificates;
- :mod:`.uio` -- the verified UIO design of eqs. ``uio_conds_1``-``uio_conds_3``;
- :mod:`.uio_modes` -- a local observer's designs in every mode that changes its cluster (the
  decoupling matrix h_q of a mode that adds an inter-cluster link, and the reset at a switch);
- :mod:`.uio_modal` -- the same default design and its Hurwitz certificate from the cluster's
  modal structure (one symmetric eigenproblem of the interior block; large clusters);
- :mod:`.uio_verdict`, :mod:`.uio_modal_verdict` -- the rule of ``local.uio`` (existence, design
  and certified verification per mode);
- :mod:`.central_verdict` -- the rule of ``central.observer``;
- :mod:`.sampled` -- the detectors of a sampled implementation (period h), designed exactly on
  its rational model, with their error equations.

The two observer conditions have their rules here because each certifies an observer it
designs first.

Layer: imports :mod:`glocal_verify.analysis` and below.
"""
