"""`bridge.big_writes`: large frames take turns, at most `slots` links at once, in order of
asking; a turn ends when released or after `turn_s`, whoever holds it."""

from __future__ import annotations

import asyncio

from bridge.big_writes import BigWriteTurns


async def test_links_take_turns_in_order_of_asking() -> None:
    turns = BigWriteTurns(slots=2, turn_s=10.0)
    woken: list[int] = []
    assert turns.take(1, lambda: woken.append(1))
    assert turns.take(2, lambda: woken.append(2))
    assert not turns.take(3, lambda: woken.append(3))
    assert not turns.take(4, lambda: woken.append(4))
    assert turns.take(1, lambda: woken.append(1))  # a holder keeps its turn
    turns.release(2)
    await asyncio.sleep(0)
    assert woken == [3] and turns.holds(3) and not turns.holds(4)
    turns.release(1)
    turns.release(3)
    await asyncio.sleep(0)
    assert woken == [3, 4] and turns.holds(4)
    turns.release(4)


async def test_a_link_that_never_releases_loses_its_turn_after_turn_s() -> None:
    turns = BigWriteTurns(slots=1, turn_s=0.01)
    woken = asyncio.Event()
    assert turns.take(1, lambda: None)  # a client that stopped reading: never released
    assert not turns.take(2, woken.set)
    async with asyncio.timeout(5):
        await woken.wait()
    assert turns.holds(2) and not turns.holds(1)
    turns.release(2)


async def test_a_link_that_leaves_gives_up_its_place_in_line() -> None:
    turns = BigWriteTurns(slots=1, turn_s=10.0)
    woken: list[int] = []
    assert turns.take(1, lambda: None)
    assert not turns.take(2, lambda: woken.append(2))
    assert not turns.take(3, lambda: woken.append(3))
    turns.release(2)  # link 2 closed while waiting
    turns.release(1)
    await asyncio.sleep(0)
    assert woken == [3]
    turns.release(3)
