"""Numerics: certified decisions on matrices, exact arithmetic and pencils, knowing no system.

- :mod:`.tolerance` -- the three-valued zero test (:class:`Tolerance`, :class:`Decision`), ranks
  with their evidence, eigenvalue grouping;
- :mod:`.subspace` -- :class:`Subspace` (a computed subspace with both readings of its
  undecided decisions) and :func:`decide_with_error`;
- :mod:`.spectrum` -- :class:`Spectrum`, the eigendecomposition of one symmetric matrix with
  its a-posteriori error bounds;
- :mod:`.rank_one`, :mod:`.updated_spectrum`, :mod:`.block_spectrum` -- the spectrum after a few
  link changes, kept as the one before times certified rank-one factors (no N^3 product, no
  ``syrk``), and a clustered Laplacian's from its blocks and the links between them;
- :mod:`.staircase` -- the generic orthogonal staircase for any (A, C);
- :mod:`.pencil`, :mod:`.pencil_exact` -- the Rosenbrock system pencil, numeric and exact;
- :mod:`.exact`, :mod:`.exact_subspace` -- python-flint helpers over Q;
- :mod:`.zero_polynomial` -- the zero polynomial of a left-invertible selection system,
  proved by minors modulo a prime and exact kernels (no V* iteration);
- :mod:`.hurwitz` -- certified Hurwitz tests of a real matrix from its eigenvalue condition numbers;
- :mod:`.certified_rows` -- impulse-response rows ``C M^k`` of a stable discrete system with
  a-posteriori error bounds and a certified tail (the sampled detectors' thresholds).
- :mod:`.threads`, :mod:`.collection` -- BLAS threads and deferred full garbage collections for
  a block of code (resources, no numbers).

Layer: imports only :mod:`glocal_verify.errors`, :mod:`glocal_verify.config`,
:mod:`glocal_verify.runtime` (the forked exact runs of :mod:`.deadline`), :mod:`glocal_verify.results`
(the status enum) and :mod:`glocal_verify.spec.arguments` (argument domains); everything here takes
matrices, never a ``System``.
"""
