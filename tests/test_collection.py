"""Deferred full garbage collections: young generations still collected, thresholds restored."""

from __future__ import annotations

import gc
import weakref

from glocal_verify.numerics.collection import deferred_full_collections


class _Node:
    def __init__(self) -> None:
        self.me = self  # a reference cycle: only the cyclic collector frees it


def test_the_block_restores_the_thresholds_it_found_also_when_nested_and_on_error() -> None:
    before = gc.get_threshold()
    try:
        with deferred_full_collections():
            inside = gc.get_threshold()
            assert inside[:2] == before[:2] and inside[2] > before[2]
            with deferred_full_collections():
                assert gc.get_threshold() == inside
            assert gc.get_threshold() == inside
            raise RuntimeError("leave the block by an exception")
    except RuntimeError:
        pass
    assert gc.get_threshold() == before


def test_short_lived_cycles_are_still_freed_inside_the_block() -> None:
    with deferred_full_collections():
        ref = weakref.ref(_Node())
        for _ in range(50_000):  # enough allocations for several young collections
            _Node()
        assert ref() is None


def test_a_switched_off_collector_stays_off() -> None:
    before = gc.get_threshold()
    gc.set_threshold(0)
    try:
        with deferred_full_collections():
            assert gc.get_threshold()[0] == 0
        assert gc.get_threshold()[0] == 0
    finally:
        gc.set_threshold(*before)


def test_freed_memory_is_given_back_without_changing_any_object() -> None:
    from glocal_verify.numerics.collection import release_freed_memory

    kept = [bytes(1000) for _ in range(1000)]
    freed = [bytes(1000) for _ in range(10_000)]
    del freed
    done = release_freed_memory()
    assert isinstance(done, bool)
    assert all(len(b) == 1000 and not any(b) for b in kept)
