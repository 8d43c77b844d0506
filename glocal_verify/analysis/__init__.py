"""Analysis: the paper's objects on a given system as typed results, and the rules of the conditions.

Each condition's decision is one function here returning a frozen
:class:`~glocal_verify.results.Verdict` (``docs/architecture.md`` names them per condition id);
the checkers of :mod:`glocal_verify.conditions` only wrap them. The modules are grouped by the
paper's condition families, each folder naming the objects it holds and exporting its rules:

- :mod:`.laplacian` -- the Laplacian over Q shared by every topic: exact entries, twin modes,
  the transfer function of the agents' input dynamics;
- :mod:`.unobservable` -- unobservable subspaces: the modal structure, per mode, switched
  (Lemma II.3, ``switched-observability``) and invariant (Lemma III.1, ``privacy.*``);
- :mod:`.local` -- Proposition III.2 on each cluster (``local.k-connected``, ``local.rank``,
  ``local.pencil``): local cases, cluster pencils, the interior modes the UIO designs share;
- :mod:`.stealthy` -- Proposition II.4: zero-dynamics attacks (``stealthy.zda``) with their
  certificates, and covert attacks (``stealthy.covert``);
- :mod:`.switching` -- Theorem III.3 (i)-(iii), Lemma A.2 and Remark III.3.1 (``switching.*``):
  the image-kernel and coverage rules, the eigenstructure of L_q, the touch tests;
- :mod:`.sampled` -- the sampled implementation per Laplacian mode: stability, aliasing,
  observability, the sampled pencil, pathological periods.

Inside the layer a topic imports only the topics listed before it (``tests/test_architecture.py``).

Layer: imports :mod:`glocal_verify.numerics`, :mod:`glocal_verify.model` and the spec types.
Derived results are kept on the system's explicit :class:`~glocal_verify.derived.Analysis`,
each kind declared by the module that computes it (:class:`~glocal_verify.derived.Kind`).
"""

__all__: list[str] = []
