"""Large-write turns (`bridge.turns`): who may write a large frame, in which order."""

from __future__ import annotations

import pytest

from bridge.turns import LargeWriteTurns


def make(slots: int = 1) -> tuple[LargeWriteTurns[str], list[str]]:
    granted: list[str] = []
    return LargeWriteTurns(granted.append, slots), granted


def test_the_first_link_writes_at_once_and_the_others_wait_in_line() -> None:
    turns, granted = make()
    assert turns.take("a")
    assert not turns.take("b")
    assert not turns.take("c")
    assert turns.take("a")  # a holder asking again keeps its turn
    assert not turns.take("b")  # asking again keeps b's place, once
    turns.give_back("a")
    assert granted == ["b"] and turns.holds("b")
    turns.give_back("b")
    assert granted == ["b", "c"]
    turns.give_back("c")
    assert turns.take("d") and granted == ["b", "c"]


def test_a_link_that_leaves_while_in_line_is_skipped() -> None:
    turns, granted = make()
    turns.take("a")
    turns.take("b")
    turns.take("c")
    turns.give_back("b")  # b closed while waiting
    turns.give_back("a")
    assert granted == ["c"]


def test_slots_bound_the_links_writing_at_once() -> None:
    turns, granted = make(slots=2)
    assert turns.take("a") and turns.take("b")
    assert not turns.take("c")
    turns.give_back("a")
    assert granted == ["c"]
    assert turns.handoffs == 3


def test_a_newcomer_does_not_jump_the_line_when_a_slot_frees() -> None:
    turns, granted = make()
    turns.take("a")
    turns.take("b")
    turns.give_back("a")  # b is granted the free slot before anyone else asks
    assert not turns.take("z")
    assert granted == ["b"]


def test_no_slots_is_refused() -> None:
    with pytest.raises(ValueError):
        make(slots=0)
