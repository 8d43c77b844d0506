"""Extra: the toolkit's integrations with other libraries, each reached through a guarded import.

Every module here adapts one library the core does not need to import on its own, and knows
no object of the paper: it takes and returns plain values (matrices, names, nested dicts,
callables). The library is imported inside the function that needs it, so importing a module
of this folder costs nothing, and a missing optional library becomes one
:class:`~glocal_verify.errors.NotApplicableError` naming the extra to install.

- :mod:`.dask` -- ``dask.distributed`` as the executor of sweeps and audits (an embedded
  ``LocalCluster`` or an existing scheduler) and when its workers pay off;
- :mod:`.control` -- python-control: a state-space model of given matrices
  (:meth:`glocal_verify.model.System.to_statespace`; ``pip install 'glocal-verify[control]'``);
- :mod:`.matlab` -- MATLAB v5 files through ``scipy.io``: a nested dict of arrays written as
  structs and cell arrays, and read back (the ``.mat`` deployment file of
  :mod:`glocal_verify.reporting.export`).

Matplotlib is not here: every figure is rendering, and its one room is
:mod:`glocal_verify.reporting.figures`.

Layer: right above :mod:`glocal_verify.runtime` (the Dask workers die with their parent);
imports nothing else of the package, and every layer above may use it.
"""

__all__: list[str] = []
