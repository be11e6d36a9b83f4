"""The report's figures: box plots per topic and stage (like the thesis's figures 4.1-4.4)
and a bytes chart, written with matplotlib's Agg backend (imported only when asked for)."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

from clients.report.journeys import stage_order
from clients.report.results import Run


def write_plots(runs: Sequence[Run], folder: Path) -> list[Path]:
    """Box plots per topic and stage (like thesis figures 4.1-4.4) and a bytes chart."""
    import matplotlib

    matplotlib.use("Agg")
    from matplotlib import pyplot as plt

    folder.mkdir(parents=True, exist_ok=True)
    written = []
    for run in runs:
        for topic, values in run.stage_values.items():
            stages = stage_order(s for s in values if values[s])
            if not stages:
                continue
            sample = run.samples.get(topic, "")
            fig, ax = plt.subplots(figsize=(max(6.0, 0.8 * len(stages)), 4.5))
            ax.boxplot([values[s] for s in stages], showfliers=True)
            ax.set_xticks(range(1, len(stages) + 1), stages, rotation=45, ha="right")
            ax.set_ylabel("ms")
            ax.set_title(f"{topic} ({run.label}) {sample}")
            ax.grid(axis="y", alpha=0.3)
            fig.tight_layout()
            path = folder / f"{run.label.replace('/', '-')}{topic.replace('/', '_')}.png"
            fig.savefig(path, dpi=100)
            plt.close(fig)
            written.append(path)
    written.append(_bytes_chart(runs, folder, plt))
    return written


def _bytes_chart(runs: Sequence[Run], folder: Path, plt: Any) -> Path:
    topics = sorted({t for run in runs for t in run.topics})
    fig, ax = plt.subplots(figsize=(max(7.0, 1.1 * len(topics)), 4.5))
    width = 0.8 / (1 + 2 * len(runs))
    positions = list(range(len(topics)))
    first = runs[0].topics
    ax.bar(
        positions,
        [first[t].payload_bytes if t in first else 0 for t in topics],
        width,
        label="payload (CDR)",
    )
    for k, run in enumerate(runs, start=1):
        ax.bar(
            [p + k * width for p in positions],
            [summary.wire_in_bytes if (summary := run.topic(t)) else 0 for t in topics],
            width,
            label=f"wire ({run.label})",
        )
    ax.set_yscale("log")
    ax.set_xticks([p + width * len(runs) / 2 for p in positions], topics, rotation=30, ha="right")
    ax.set_ylabel("bytes per message")
    ax.legend()
    fig.tight_layout()
    path = folder / "bytes.png"
    fig.savefig(path, dpi=100)
    plt.close(fig)
    return path
