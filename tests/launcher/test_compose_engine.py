"""docker-compose.host.yml run for real: build the image, start the three containers, use them.

`compose up --build` on a copy of the checkout (with this machine's package-index settings in
docker/build-config/), host networking so every byte stays on loopback; then all three health
checks must pass, roslibpy must receive /imu/data and /nav/boxes, `riverbridge report` must
measure the containers, the bridge must serve the built dashboard and its script, and
/metrics must parse. Skipped, with the reason, where no Docker engine can run. The first run
on a machine builds the bases and the image (minutes); later runs reuse them (docker_engine).
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
import threading
import time
import urllib.request
from collections.abc import Iterator
from pathlib import Path

import pytest

from tests.child_process import REPO_ROOT, free_port, run_command

from .docker_engine import (
    EngineFailed,
    EngineUnavailable,
    build_bases,
    compose_command,
    docker_engine,
    make_context,
    run,
)

pytestmark = pytest.mark.slow

PROJECT = "riverbridge-engine-test"
UP_TIMEOUT_S = 1500.0  # a cold build on a loaded 2-core machine
HEALTHY_TIMEOUT_S = 300.0
SERVICES = ("bridge", "simulator", "navigation")
IMAGE = "riverbridge:0.1.0"  # docker-compose.yml's image


@pytest.fixture(scope="module")
def engine() -> Iterator[None]:
    try:
        with docker_engine():
            yield
    except EngineUnavailable as exc:
        pytest.skip(f"no Docker engine: {exc}")
    except EngineFailed as exc:
        pytest.fail(f"the Docker engine failed to start: {exc}", pytrace=False)


class Compose:
    """`compose -f docker-compose.host.yml -p PROJECT ...` in one project folder."""

    def __init__(self, folder: Path, env: dict[str, str]) -> None:
        self.folder, self.env = folder, env
        self.argv = [*compose_command(), "-f", "docker-compose.host.yml", "-p", PROJECT]

    def __call__(
        self, *args: str, timeout_s: float = 300.0, check: bool = True
    ) -> subprocess.CompletedProcess[str]:
        return run(
            *self.argv, *args, cwd=self.folder, env=self.env, timeout_s=timeout_s, check=check
        )

    def health(self) -> dict[str, str]:
        """Service name -> docker's health status of its container."""
        ids = self("ps", "-q").stdout.split()
        if not ids:
            return {}
        lines = run(
            "docker",
            "inspect",
            "-f",
            '{{index .Config.Labels "com.docker.compose.service"}} '
            "{{if .State.Health}}{{.State.Health.Status}}{{else}}{{.State.Status}}{{end}}",
            *ids,
        ).stdout.splitlines()
        return dict(line.split(maxsplit=1) for line in lines if line.strip())

    def wait_healthy(self) -> None:
        deadline = time.monotonic() + HEALTHY_TIMEOUT_S
        while (health := self.health()) != {name: "healthy" for name in SERVICES}:
            assert "unhealthy" not in health.values(), f"{health}\n{self.logs()}"
            assert time.monotonic() < deadline, f"not healthy: {health}\n{self.logs()}"
            time.sleep(2.0)

    def logs(self) -> str:
        return self("logs", "--no-color", "--tail", "60", check=False).stdout


def fetch(url: str) -> tuple[str, bytes]:
    with urllib.request.urlopen(url, timeout=30) as response:
        return response.headers.get("Content-Type", ""), response.read()


def receive_with_roslibpy(
    port: int, topics: dict[str, str], timeout_s: float = 60.0
) -> dict[str, dict]:
    """One message of each topic through the real roslibpy client."""
    import roslibpy

    from tests.compat.roslibpy_support import close, connect

    received: dict[str, dict] = {}
    done = threading.Event()

    def keep(topic: str):
        def callback(msg: dict) -> None:
            received.setdefault(topic, msg)
            if len(received) == len(topics):
                done.set()

        return callback

    ros = connect("127.0.0.1", port)
    subscribed = [roslibpy.Topic(ros, topic, type_name) for topic, type_name in topics.items()]
    try:
        for topic in subscribed:
            topic.subscribe(keep(topic.name))
        done.wait(timeout_s)
    finally:
        for topic in subscribed:
            topic.unsubscribe()
        close(ros)
    return received


def check_dashboard(port: int) -> None:
    content_type, body = fetch(f"http://127.0.0.1:{port}/")
    page = body.decode("utf-8")
    assert content_type.startswith("text/html") and "<title>riverbridge dashboard" in page, page
    script = re.search(r'<script type="module"[^>]*src="\./(assets/[^"]+\.js)"', page)
    assert script, page
    content_type, code = fetch(f"http://127.0.0.1:{port}/{script[1]}")
    assert "javascript" in content_type and len(code) > 10_000, (content_type, len(code))


def check_metrics(port: int) -> None:
    from prometheus_client.parser import text_string_to_metric_families

    _, body = fetch(f"http://127.0.0.1:{port}/metrics")
    families = {f.name: f for f in text_string_to_metric_families(body.decode("utf-8"))}
    received = {
        s.labels["topic"]: s.value
        for s in families["riverbridge_messages"].samples
        if s.labels.get("direction") == "in"
    }
    assert received.get("/imu/data", 0) > 0, received
    assert families["process_cpu_seconds"].samples[0].value > 0


def check_image() -> None:
    """The image runs as its own user and holds none of the build settings."""
    user = run("docker", "image", "inspect", "-f", "{{.Config.User}}", IMAGE).stdout.strip()
    assert user == "riverbridge", user
    inside = run(
        "docker",
        "run",
        "--rm",
        "--network",
        "none",
        IMAGE,
        "sh",
        "-c",
        "id -u; ls -d /build-config /opt/riverbridge/web/index.html 2>&1",
        check=False,
    ).stdout
    uid, *listing = inside.splitlines()
    assert uid != "0" and "/opt/riverbridge/web/index.html" in listing, inside
    assert "/build-config" not in listing, inside


@pytest.mark.timeout(UP_TIMEOUT_S + HEALTHY_TIMEOUT_S + 600)
def test_compose_up_builds_runs_and_serves_the_stack(engine: None, tmp_path: Path) -> None:
    timings: dict[str, float] = {}
    start = time.monotonic()
    try:
        base, node = build_bases()
    except EngineUnavailable as exc:
        pytest.skip(str(exc))
    timings["bases"] = time.monotonic() - start
    port = free_port()
    env = {
        **os.environ,
        "RIVERBRIDGE_PORT": str(port),
        "RIVERBRIDGE_BASE_IMAGE": base,
        "RIVERBRIDGE_NODE_IMAGE": node,
        "DOCKER_BUILDKIT": "0",
    }
    compose = Compose(make_context(tmp_path / "riverbridge"), env)
    compose("down", "--remove-orphans", check=False)  # leftovers of an interrupted run
    try:
        mark = time.monotonic()
        compose("up", "--build", "-d", timeout_s=UP_TIMEOUT_S)
        compose.wait_healthy()
        timings["up_healthy"] = time.monotonic() - mark
        received = receive_with_roslibpy(
            port,
            {"/imu/data": "sensor_msgs/msg/Imu", "/nav/boxes": "riverbridge_msgs/msg/BoxArray"},
        )
        assert set(received) == {"/imu/data", "/nav/boxes"}, received.keys()
        assert received["/imu/data"]["header"]["frame_id"]
        mark = time.monotonic()
        report = run_command(
            [
                sys.executable,
                str(REPO_ROOT / "riverbridge.py"),
                "report",
                "--bridge",
                f"ws://127.0.0.1:{port}",
                "--duration",
                "10",
            ],
            timeout_s=300,
        )
        timings["report"] = time.monotonic() - mark
        assert report.returncode == 0, report.stdout + report.stderr
        for topic in ("/lidar/points", "/imu/data", "/radar/image"):
            # the topic table's row: the name, then its measured rate
            row = re.compile(rf"^\s*{re.escape(topic)}\s+\d", re.MULTILINE)
            assert row.search(report.stdout), report.stdout
        check_dashboard(port)
        check_metrics(port)
        check_image()
    except BaseException:
        print(compose.logs())
        raise
    finally:
        mark = time.monotonic()
        compose("down", "--remove-orphans", check=False, timeout_s=120)
        timings["down"] = time.monotonic() - mark
        timings["total"] = time.monotonic() - start
        print(
            "compose engine test timings (s): "
            + ", ".join(f"{name} {value:.1f}" for name, value in timings.items())
        )
