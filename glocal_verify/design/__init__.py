"""Design: answers to the defender's inverse questions, built on the checkers.

- :mod:`.placement` -- local observer placement (Remark III.2.1);
- :mod:`.generators` -- random clustered networks for tests, benchmarks and sweeps.

Layer: imports :mod:`glocal_verify.conditions` and below.
"""
