"""Is the web dashboard smooth on a full-rate stack, and does its memory stay flat?

Opens the dashboard in headless Chromium (Debian's, driven by playwright-core from
web/node_modules) against a running stack, records every requestAnimationFrame interval and
performance.memory.usedJSHeapSize once a second, and prints frame-time median/p99/max, the
share of frames over 50 ms, long tasks, messages received per topic, and the JS heap trend.
The trend is a least-squares line through the heap's floor (the minimum per window, i.e. what
survives garbage collection), in MiB per minute.

Starts ``python -m clients.stack.up_cli --port 0`` itself unless ``--url`` names a running bridge.
Usage: python -m benchmarks.dashboard [--minutes N] [--url http://127.0.0.1:9090/]
"""

from __future__ import annotations

import argparse
import contextlib
import json
import subprocess
import sys
import tempfile
from collections.abc import Iterator
from pathlib import Path

import numpy as np

from tests.child_process import REPO_ROOT
from tests.dashboard.stack import running_stack

MEASURE_SCRIPT = REPO_ROOT / "web" / "scripts" / "measure_frames.mjs"
MIB = 1024 * 1024
FRAME_BUDGET_MS = 50.0  # issue 6: no frame over 50 ms on a full-rate stack


@contextlib.contextmanager
def started_stack() -> Iterator[str]:
    """Run bridge, simulator and navigation (as the dashboard's browser tests do); yield the
    dashboard's URL; stop them after."""
    with (
        tempfile.TemporaryDirectory(prefix="riverbridge-up-") as folder,
        running_stack(Path(folder) / "up.log") as stack,
    ):
        yield stack.page_url


def measure(url: str, seconds: float) -> dict:
    """Run the browser recorder for `seconds`; its JSON result."""
    result = subprocess.run(
        ["node", str(MEASURE_SCRIPT), url, str(seconds)],
        capture_output=True,
        text=True,
        timeout=seconds + 180,
    )
    lines = result.stdout.strip().splitlines()
    if not lines:
        raise RuntimeError(f"measure_frames.mjs printed nothing:\n{result.stderr}")
    recorded = json.loads(lines[-1])
    if not recorded["ok"]:
        raise RuntimeError(recorded["reason"])
    return recorded


def heap_floor_trend(heap: np.ndarray, window_s: float) -> tuple[np.ndarray, float]:
    """Per-window minima of `heap : (n, 2)` (t_s, bytes) and their slope in MiB/min."""
    windows = np.floor(heap[:, 0] / window_s).astype(int)
    floors = np.array(
        [[heap[windows == w, 0].mean(), heap[windows == w, 1].min()] for w in np.unique(windows)]
    )
    if len(floors) < 2:
        return floors, float("nan")
    slope_bytes_per_s = np.polyfit(floors[:, 0], floors[:, 1], 1)[0]
    return floors, slope_bytes_per_s * 60 / MIB


def report(recorded: dict) -> str:
    frames = np.asarray(recorded["frame_ms"], dtype=float)
    heap = np.asarray(recorded["heap"], dtype=float)
    seconds = recorded["seconds"]
    floors, slope = heap_floor_trend(heap, window_s=max(10.0, seconds / 10))
    p50, p99 = np.percentile(frames, [50, 99])
    over = int((frames > FRAME_BUDGET_MS).sum())
    long_tasks = np.asarray(recorded["long_tasks_ms"], dtype=float)
    rates = {topic: count / seconds for topic, count in recorded["counts"].items()}
    lines = [
        f"{seconds:.0f} s, {len(frames)} frames ({len(frames) / seconds:.1f} fps)",
        f"frame time ms: median {p50:.1f}  p99 {p99:.1f}  max {frames.max():.1f}  "
        f"over {FRAME_BUDGET_MS:.0f} ms: {over} ({100 * over / len(frames):.2f} %)",
        f"long tasks (>50 ms): {len(long_tasks)}"
        + (f", max {long_tasks.max():.0f} ms" if len(long_tasks) else ""),
        f"worst dashboard draw in one frame: {recorded['worst_draw_ms']:.1f} ms; per panel: "
        + ", ".join(f"{k} {v:.1f}" for k, v in recorded["panel_worst_ms"].items()),
        "worst message handling ms: "
        + ", ".join(f"{k} {v:.1f}" for k, v in sorted(recorded["handler_worst_ms"].items())),
        f"JS heap MiB: first floor {floors[0, 1] / MIB:.1f}  last floor "
        f"{floors[-1, 1] / MIB:.1f}  max {heap[:, 1].max() / MIB:.1f}  "
        f"trend {slope:+.2f} MiB/min over {len(floors)} windows",
        "messages received (whole page life, /s over the run): "
        + ", ".join(f"{t} {r:.1f}" for t, r in sorted(rates.items())),
    ]
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--minutes",
        type=float,
        default=1.0,
        help="how long to record (default %(default)s; 10 for the soak)",
    )
    parser.add_argument(
        "--url",
        help="dashboard of a running stack, e.g. http://127.0.0.1:9090/; "
        "default: start `riverbridge up` on a free port",
    )
    args = parser.parse_args(argv)
    seconds = args.minutes * 60
    if args.url:
        print(report(measure(args.url, seconds)))
        return 0
    with started_stack() as url:
        print(f"stack at {url}")
        print(report(measure(url, seconds)))
    return 0


if __name__ == "__main__":
    sys.exit(main())
