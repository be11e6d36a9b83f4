"""Real ROS 2 nodes for the DDS tests: rclpy from PyPI in the Python 3.12 venvs that
scripts/setup.sh makes (one per distribution), started as child processes.

A node runs on rmw_fastrtps_cpp (the only RMW those wheels ship) with its discovery pinned to
this host (`ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST`) and the test's own domain id.
"""

from __future__ import annotations

import os
import subprocess
import threading
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

NODES = Path(__file__).resolve().parent / "ros2_nodes"
KILTED_PROFILE = Path(__file__).resolve().parents[2] / "docs" / "fastdds-kilted-profile.xml"
# Where scripts/setup.sh puts the venvs (outside the checkout, so every clone shares them).
VENVS = Path(os.environ.get("RIVERBRIDGE_ROS2_VENVS", Path.home() / ".cache" / "riverbridge"))
DISTROS = ("jazzy", "kilted")
READY_TIMEOUT_S = 60.0


def ros2_python(distro: str) -> Path:
    """The venv's interpreter; a missing venv fails the test and says how to make it."""
    python = VENVS / f"ros2-{distro}" / "bin" / "python3"
    if not python.exists():
        raise RuntimeError(
            f"no ROS 2 {distro} venv at {python.parent.parent}: run scripts/setup.sh"
        )
    return python


def ros2_env(distro: str, domain: int) -> dict[str, str]:
    """What a ROS 2 node of the tests needs: nothing of the test's own Python environment.

    Kilted's Fast DDS 3 takes docs/fastdds-kilted-profile.xml, as docs/ros2.md tells users:
    its XTypes type objects are refused by Cyclone, so it must announce types by name only.
    """
    profile = {"FASTDDS_DEFAULT_PROFILES_FILE": str(KILTED_PROFILE)} if distro == "kilted" else {}
    return profile | {
        "PATH": "/usr/bin:/bin",
        "HOME": str(Path.home()),
        "ROS_DOMAIN_ID": str(domain),
        "ROS_AUTOMATIC_DISCOVERY_RANGE": "LOCALHOST",
        "RMW_IMPLEMENTATION": "rmw_fastrtps_cpp",
        "PYTHONUNBUFFERED": "1",
    }


class RclpyProcess:
    """One rclpy script running; its output is kept for the failure message."""

    def __init__(self, process: subprocess.Popen[str]) -> None:
        self.process = process
        self.lines: list[str] = []
        self._ready = threading.Event()
        self._reader = threading.Thread(target=self._read, daemon=True)
        self._reader.start()

    def _read(self) -> None:
        assert self.process.stdout is not None
        for line in self.process.stdout:
            self.lines.append(line.rstrip("\n"))
            if line.startswith("READY"):
                self._ready.set()
        self._ready.set()  # ended: wait_ready reports it

    def wait_ready(self) -> None:
        if not self._ready.wait(READY_TIMEOUT_S) or self.process.poll() is not None:
            raise RuntimeError("rclpy node did not start:\n" + "\n".join(self.lines[-40:]))

    def output(self) -> str:
        return "\n".join(self.lines)

    def stop(self) -> None:
        if self.process.poll() is None:
            self.process.terminate()
            try:
                self.process.wait(timeout=10)
            except subprocess.TimeoutExpired:
                self.process.kill()
                self.process.wait()
        self._reader.join(timeout=5)
        if self.process.stdout is not None:
            self.process.stdout.close()


@contextmanager
def rclpy_script(distro: str, domain: int, script: str, *args: str) -> Iterator[RclpyProcess]:
    """Run `ros2_nodes/<script>` under `distro`'s rclpy until the block ends."""
    started = time.monotonic()
    process = subprocess.Popen(
        [str(ros2_python(distro)), str(NODES / script), *args],
        env=ros2_env(distro, domain),
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
    )
    node = RclpyProcess(process)
    try:
        node.wait_ready()
        node.lines.append(f"(ready after {time.monotonic() - started:.1f} s)")
        yield node
    finally:
        node.stop()
