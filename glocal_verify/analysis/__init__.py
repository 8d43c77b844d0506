"""Analysis: the paper's objects on a given system as typed results, and the rules of the conditions.

Each condition's decision is one function here returning a frozen
:class:`~glocal_verify.results.Verdict` (``docs/architecture.md`` names them per condition id);
the checkers of :mod:`glocal_verify.conditions` only wrap them.

- :mod:`.observability` -- ``switched-observability`` (Lemma II.3) and the state-map witnesses;
- :mod:`.privacy` -- the ``privacy.*`` rules (Lemma III.1, Problem 1 (i));
- :mod:`.switching`, :mod:`.eigenstructure` -- Theorem III.3 (i)-(iii) and Lemma A.2;
- :mod:`.local_structure`, :mod:`.local_pencil` -- Proposition III.2 (i)-(iii);
- :mod:`.twins`, :mod:`.transfer` -- exact twin modes and the exact transfer function shared by rules;

- :mod:`.modal` -- eigen-groups of L_q with their unobservable parts (the modal structure);
- :mod:`.unobservable` -- unobservable subspaces per mode (modal, exact);
- :mod:`.switched` -- Lemma II.3's switched unobservable subspace;
- :mod:`.zda`, :mod:`.zda_exact` -- zero-dynamics attacks: zeros, directions, growth;
- :mod:`.covert` -- the channels a covert attacker must own;
- :mod:`.avoidance` -- does a safe mode touch the stealthy kernel (Remark III.3.1)?
- :mod:`.local_cases`, :mod:`.cluster_pencil` -- cluster subsystems and their reduced pencils;
- :mod:`.cluster_modal` -- the interior eigen-decomposition of a cluster block shared by the UIO checks;
- :mod:`.sampled`, :mod:`.sampled_zda`, :mod:`.sampled_scan` -- the sampled implementation per
  Laplacian mode: stability, aliasing, observability, the sampled pencil, pathological periods.

Layer: imports :mod:`glocal_verify.numerics`, :mod:`glocal_verify.model` and the spec types.
Derived results are kept on the system's explicit :class:`~glocal_verify.derived.Analysis`,
each kind declared by the module that computes it (:class:`~glocal_verify.derived.Kind`).
"""
