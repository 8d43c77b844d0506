"""Conditions: the catalogue, the registry and one thin checker module per paper result.

- :mod:`.registry` -- the condition catalogue, :class:`CheckContext` and :func:`check_conditions`
  (the checkers run, before the assessment that :func:`glocal_verify.verify` attaches);
- :mod:`.privacy` -- Lemma III.1 and Problem 1 (i): every ``privacy.*`` id;
- :mod:`.observability` -- Lemma II.3 (``switched-observability``);
- :mod:`.stealthy` -- Proposition II.4 (``stealthy.zda``, ``stealthy.covert``);
- :mod:`.local` -- Proposition III.2 (``local.*``);
- :mod:`.central` -- the centralised observer (``central.observer``);
- :mod:`.switching` -- Theorem III.3 (i)-(iii) and Lemma A.2;
- :mod:`.safe_switch` -- Remark III.3.1 (does the switch touch the attack?);
- :mod:`.detects` -- the theorem's conclusion by simulation (``switching.detects``);
- :mod:`.sampled` -- the conditions re-decided for the sampled implementation (``sampled.*``);
- :mod:`.detection` -- certified thresholds and detection guarantees (``detection.*``);
- :mod:`.paper_findings` -- finding rules that are not tied to one checker;
- :mod:`.cost` -- time and memory estimates from the spec's sizes, and the exact-cost model.

A checker wraps the rule of its condition (a :class:`~glocal_verify.results.Verdict` from
:mod:`glocal_verify.analysis` or :mod:`glocal_verify.observers`) into
:class:`~glocal_verify.results.ConditionResult` values (:func:`.registry.verdict_result`) and
reads like the theorem it checks. Layer: imports :mod:`glocal_verify.simulation` and below.
"""
