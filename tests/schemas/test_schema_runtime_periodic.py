"""The one periodic schedule: a drift-free grid, failures logged, whole periods late skipped."""

import asyncio
import contextlib

from schemas.runtime.periodic import every, ticks


async def test_ticks_skip_whole_periods_behind_instead_of_bursting():
    period_s = 0.02
    loop = asyncio.get_running_loop()
    seen: list[tuple[int, float]] = []
    async for skipped in ticks(period_s):
        seen.append((skipped, loop.time()))
        if len(seen) == 1:
            await asyncio.sleep(3.5 * period_s)  # an overrun of three and a half periods
        if len(seen) == 3:
            break
    assert seen[0][0] == 0
    assert seen[1][0] >= 2, "ticks wholly missed are skipped, not queued"
    assert seen[2][0] == 0


async def test_every_goes_on_after_a_failing_call_and_reports_skips(caplog):
    calls: list[int] = []
    skips: list[int] = []
    enough = asyncio.Event()

    async def action() -> None:
        calls.append(len(calls))
        if len(calls) == 1:
            raise RuntimeError("one bad tick")
        if len(calls) == 2:
            await asyncio.sleep(0.05)
        if len(calls) >= 4:
            enough.set()

    task = asyncio.create_task(every(0.01, action, on_skipped=skips.append))
    await asyncio.wait_for(enough.wait(), timeout=5)
    task.cancel()
    with contextlib.suppress(asyncio.CancelledError):
        await task
    assert "one bad tick" in caplog.text
    assert sum(skips) >= 3, skips
