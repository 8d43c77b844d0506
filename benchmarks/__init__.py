"""Benchmarks of glocal-verify: ``python -m benchmarks`` writes ``reports/benchmarks.md``.

Each ``bench_*.py`` module defines ``run(quick: bool) -> list[Row]``. Every row compares a
candidate with a baseline measured in the same run and reports their ratio, so the numbers
stay meaningful across machines.
"""
