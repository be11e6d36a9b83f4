"""Two hosts in one DDS domain: a bridge in each of two network namespaces joined by a veth
pair, with real third-party clients on either side.

roslibpy (PyPI) on host A publishes and calls; roslibjs (npm `roslib`, under Node) on host B
subscribes and provides the service. Each bridge is started as users start it
(`python -m bridge --dds --domain N --dds-interface <veth> --dds-peer <other host>`), so DDS
discovery and data cross the veth pair and nothing else.
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

from tests.child_process import running
from tests.compat.node_runner import JS_DIR, node_executable
from tests.dds.dds_netns import Host, bridge_argv, two_hosts, why_not

pytestmark = pytest.mark.slow

ROSLIBPY_HOST = Path(__file__).resolve().parent / "roslibpy_host.py"
LISTENING = r"listening on ws://127\.0\.0\.1:(?P<port>\d+)"
RESULT_TIMEOUT_S = 120.0


def roslibpy_argv(host: Host, port: str, *scenario: str) -> list[str]:
    """roslibpy (PyPI) in `host`'s namespace, running a scenario against the bridge at `port`."""
    return host.command([sys.executable, str(ROSLIBPY_HOST), "127.0.0.1", port, *scenario])


def start(argv: list[str], cwd: Path | None = None) -> subprocess.Popen[str]:
    return subprocess.Popen(
        argv, cwd=cwd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True
    )


def result_of(process: subprocess.Popen[str], timeout_s: float = RESULT_TIMEOUT_S) -> dict:
    """The JSON line a scenario prints; the assertion quotes its output when it fails."""
    try:
        out, err = process.communicate(timeout=timeout_s)
    except subprocess.TimeoutExpired:
        process.kill()
        out, err = process.communicate()
    lines = [line for line in out.splitlines() if line.startswith("{")]
    command = " ".join(process.args)
    context = f"`{command}` exited {process.returncode}\n{out[-3000:]}\n{err[-3000:]}"
    assert process.returncode == 0 and lines, context
    return json.loads(lines[-1])


def test_roslibpy_on_host_a_reaches_roslibjs_on_host_b_through_dds(dds_domain):
    reason = why_not()
    if reason is not None:
        pytest.skip(f"no network namespaces here: {reason}")
    node = node_executable()
    with (
        two_hosts() as (a, b),
        running(bridge_argv(a, b, dds_domain)) as bridge_a,
        running(bridge_argv(b, a, dds_domain)) as bridge_b,
    ):
        port_a = bridge_a.wait_for_line(LISTENING).group("port")
        url_b = f"ws://127.0.0.1:{bridge_b.wait_for_line(LISTENING).group('port')}"
        clients = [
            start(
                b.command(
                    [
                        node,
                        str(JS_DIR / "subscribe_first.mjs"),
                        url_b,
                        "/chatter",
                        "std_msgs/msg/String",
                        "none",
                    ]
                ),
                cwd=JS_DIR,
            ),
            start(
                b.command(
                    [node, str(JS_DIR / "provide_service.mjs"), url_b, "/lock_gate", "1", "async"]
                ),
                cwd=JS_DIR,
            ),
            start(roslibpy_argv(a, port_a, "publish", "/chatter", "90")),
        ]
        try:
            received = result_of(clients[0])
            listed = result_of(
                start(
                    b.command(
                        [node, str(JS_DIR / "rosapi.mjs"), url_b, "/chatter", "std_msgs/msg/String"]
                    ),
                    cwd=JS_DIR,
                )
            )
            called = result_of(start(roslibpy_argv(a, port_a, "call", "/lock_gate", "90")))
            provided = result_of(clients[1])
        finally:
            for process in clients:
                if process.poll() is None:
                    process.kill()
                    process.communicate()
        log_b = bridge_b.text()
        node_a = bridge_a.wait_for_line(r"as node (?P<node>\S+)").group("node")
    assert received["message"]["data"].startswith("hello from A ")
    # roslibjs's rosapi helpers on B list what host A has (Foxglove asks the same services).
    assert "/chatter" in listed["topics"]["topics"]
    assert listed["topic_type"] == "std_msgs/msg/String"
    assert node_a in listed["nodes"]
    assert called["response"] == {"success": True, "message": "lock gate opening"}
    assert provided["requests"] == [{"data": True}]
    assert f"interface {b.interface} (peers {a.address}, multicast false)" in log_b
    assert "Traceback" not in log_b
