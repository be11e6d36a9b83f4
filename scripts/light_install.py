"""Check the light install: `pip install riverbridge` with no extras is the bridge, the client
library and record/play, in a small environment that runs the bridge.

    python3 scripts/light_install.py [--venv DIR] [--max-mb 250]

Builds a fresh venv, installs this checkout into it (its tracked and new files, copied first so
no stale `build/` of the checkout leaks into the wheel), measures the venv on disk, checks that
none of the heavy libraries came along, starts `riverbridge bridge --port 0` from the venv,
has the installed client library publish and receive a message through it, and checks that
`riverbridge sim` names the extra it lacks. Prints one line per
check and exits 0 if all hold, 1 if one fails, 2 on bad arguments. tests/test_light_install.py
runs it.
"""

from __future__ import annotations

import argparse
import os
import re
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

CHECKOUT = Path(__file__).resolve().parents[1]
HEAVY = ("cv2", "trimesh", "embreex", "sklearn", "scipy", "matplotlib", "zenoh")
LISTENING = re.compile(r"listening on ws://[^\s:/]+:(?P<port>\d+)")
START_TIMEOUT_S = 60.0

# Runs inside the venv: the installed client library through the installed bridge.
SMOKE = """
import asyncio, sys
from clients import RosbridgeClient

async def main(url):
    async with RosbridgeClient(url, encoding="cbor") as client:
        await client.advertise("/light/chat", "std_msgs/msg/String")
        chat = await client.subscribe("/light/chat", "std_msgs/msg/String")
        await client.publish("/light/chat", {"data": "hello from the light install"})
        received = await asyncio.wait_for(anext(aiter(chat)), timeout=20)
        assert received.msg == {"data": "hello from the light install"}, received.msg

asyncio.run(main(sys.argv[1]))
"""


def source_copy(into: Path) -> Path:
    """The checkout's tracked and new (not ignored) files, copied under `into`."""
    listed = subprocess.run(
        ["git", "ls-files", "-z", "--cached", "--others", "--exclude-standard"],
        cwd=CHECKOUT,
        check=True,
        capture_output=True,
    ).stdout.split(b"\0")
    for name in filter(None, (entry.decode() for entry in listed)):
        source = CHECKOUT / name
        if source.is_file():
            (into / name).parent.mkdir(parents=True, exist_ok=True)
            shutil.copy2(source, into / name)
    return into


def tree_mb(path: Path) -> float:
    """Bytes of every file under `path` (as `du` counts them, without block rounding), in MB."""
    total = sum(f.stat().st_size for f in path.rglob("*") if f.is_file() and not f.is_symlink())
    return total / 1e6


def run_bridge_smoke(venv: Path) -> None:
    """Start the venv's `riverbridge bridge --port 0`, run SMOKE against it, stop it."""
    bridge = subprocess.Popen(
        [str(venv / "bin" / "riverbridge"), "bridge", "--host", "127.0.0.1", "--port", "0"],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        text=True,
        cwd=tempfile.gettempdir(),  # never import the checkout by accident
    )
    try:
        port = None
        deadline = time.monotonic() + START_TIMEOUT_S
        assert bridge.stderr is not None
        while port is None and time.monotonic() < deadline:
            line = bridge.stderr.readline()
            if not line:
                raise RuntimeError("the bridge exited before it listened")
            match = LISTENING.search(line)
            port = int(match.group("port")) if match else None
        if port is None:
            raise RuntimeError(f"the bridge did not listen within {START_TIMEOUT_S:.0f} s")
        subprocess.run(
            [str(venv / "bin" / "python"), "-c", SMOKE, f"ws://127.0.0.1:{port}"],
            check=True,
            timeout=60,
            cwd=tempfile.gettempdir(),
        )
    finally:
        bridge.terminate()
        bridge.wait(timeout=15)


def check(venv: Path, max_mb: float) -> list[str]:
    """Install into `venv` and return the failed checks (printing each result)."""
    failures = []
    with tempfile.TemporaryDirectory(prefix="riverbridge-src-") as source:
        subprocess.run([sys.executable, "-m", "venv", str(venv)], check=True)
        started_s = time.monotonic()
        subprocess.run(
            [str(venv / "bin" / "pip"), "install", "--quiet", str(source_copy(Path(source)))],
            check=True,
        )
        print(f"installed in {time.monotonic() - started_s:.0f} s")
    size_mb = tree_mb(venv)
    print(f"venv size: {size_mb:.0f} MB (at most {max_mb:.0f})")
    if size_mb > max_mb:
        failures.append(f"the venv is {size_mb:.0f} MB, more than {max_mb:.0f}")
    probe = f"import importlib.util as u; print(*(m for m in {HEAVY!r} if u.find_spec(m)))"
    found = subprocess.run(
        [str(venv / "bin" / "python"), "-c", probe], check=True, capture_output=True, text=True
    ).stdout.split()
    print(f"heavy libraries installed: {', '.join(found) or 'none'}")
    if found:
        failures.append(f"the light install pulled {', '.join(found)}")
    run_bridge_smoke(venv)
    print("riverbridge bridge --port 0 served a publish/subscribe of the installed client")
    sim = subprocess.run(
        [str(venv / "bin" / "riverbridge"), "sim", "--help"], capture_output=True, text=True
    )
    print(f"riverbridge sim: exit {sim.returncode}: {sim.stderr.strip()}")
    if sim.returncode != 2 or "riverbridge[sim]" not in sim.stderr:
        failures.append("riverbridge sim does not name the extra it needs")
    return failures


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--venv", type=Path, help="where to build the venv (default: a temp dir)")
    parser.add_argument("--max-mb", type=float, default=250.0, help="the size budget in MB")
    args = parser.parse_args(argv)
    if args.venv is not None and args.venv.exists():
        parser.error(f"--venv {args.venv} exists; give a new directory")
    with tempfile.TemporaryDirectory(prefix="riverbridge-light-") as scratch:
        venv = args.venv or Path(scratch) / "venv"
        try:
            failures = check(venv, args.max_mb)
        except (subprocess.CalledProcessError, subprocess.TimeoutExpired, RuntimeError) as exc:
            failures = [str(exc)]
    for failure in failures:
        print(f"FAILED: {failure}", file=sys.stderr)
    return 1 if failures else 0


if __name__ == "__main__":
    os.environ.pop("PYTHONPATH", None)  # the venv must import what it installed, nothing else
    sys.exit(main())
