"""Confirmation by simulation of the certified detection guarantees (``python -m guarantee_checks``)."""
