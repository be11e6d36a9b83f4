"""The dashboard's link view reads the bridge's real /metrics (web/src/linkhealth.js under
Node): per client goodput, RTT and unsent bytes; per topic conflated, dropped, reduced."""

from __future__ import annotations

import asyncio
import json
import shutil
import subprocess

import pytest

from bridge.compose import run_bridge
from bridge.config import BridgeConfig
from clients import RosbridgeClient
from clients.linkemu import Direction, LinkEmulator, LinkProfile
from tests.child_process import REPO_ROOT

LINKHEALTH_JS = (REPO_ROOT / "web" / "src" / "linkhealth.js").as_posix()
PARSE = (
    f'import {{ parseLinkMetrics, metricsUrl }} from "{LINKHEALTH_JS}";'
    + """
let text = "";
process.stdin.on("data", (chunk) => { text += chunk; });
process.stdin.on("end", () => {
  const { clients, topics } = parseLinkMetrics(text);
  console.log(JSON.stringify({ clients: Object.fromEntries(clients),
    topics: [...topics.values()], url: metricsUrl("wss://h:9/x?y=1") }));
});
"""
)
THIN = LinkProfile(
    name="thin",
    to_client=Direction(rate_bps=4e6, delay_ms=5, buffer_bytes=10_000),
    to_server=Direction(rate_bps=4e6, delay_ms=5, buffer_bytes=10_000),
)


def parse(text: str) -> dict:
    node = shutil.which("node")
    if node is None:
        pytest.fail("`node` is not on PATH: the dashboard's tests need Node >= 20")
    done = subprocess.run(
        [node, "--input-type=module", "-e", PARSE],
        input=text,
        capture_output=True,
        text=True,
        timeout=60,
        check=True,
    )
    return json.loads(done.stdout)


async def metrics_text(port: int) -> str:
    reader, writer = await asyncio.open_connection("127.0.0.1", port)
    writer.write(b"GET /metrics HTTP/1.1\r\nHost: x\r\nConnection: close\r\n\r\n")
    body = (await reader.read()).decode()
    writer.close()
    return body.split("\r\n\r\n", 1)[1]


async def test_a_thin_clients_goodput_and_conflated_scans_are_read_from_metrics(registry):
    async with run_bridge(BridgeConfig(port=0), registry) as bridge:
        url = f"ws://127.0.0.1:{bridge.port}"
        async with (
            LinkEmulator(THIN, ("127.0.0.1", bridge.port)) as link,
            RosbridgeClient(f"ws://127.0.0.1:{link.port}", encoding="cbor") as shore,
            RosbridgeClient(url, encoding="cbor") as vessel,
        ):
            await shore.subscribe(
                "/blob", "std_msgs/msg/UInt8MultiArray", queue_length=1, fragment_size=16384
            )
            await vessel.advertise("/blob", "std_msgs/msg/UInt8MultiArray")
            await asyncio.sleep(0.3)
            for _ in range(30):  # 3 MB at 20 Hz into a 4 Mbit/s link
                await vessel.publish("/blob", {"data": bytes(100_000)})
                await asyncio.sleep(0.05)
            seen = parse(await metrics_text(bridge.port))
    assert seen["url"] == "https://h:9/metrics"
    [(name, client)] = [(n, c) for n, c in seen["clients"].items() if "goodputBytesPerS" in c]
    assert 0.2e6 < client["goodputBytesPerS"] < 0.6e6  # 4 Mbit/s is 0.5 MB/s
    assert client["unsentBytes"] >= 0 and client["rttS"] >= 0
    [blob] = [t for t in seen["topics"] if t["topic"] == "/blob" and t["subscriber"] == name]
    assert blob["conflated"] > 0 and blob["dropped"] == 0 and blob["reduced"] == 0
