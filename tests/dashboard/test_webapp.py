"""The bridge serves the built dashboard over plain HTTP on its websocket port."""

from __future__ import annotations

import asyncio
from collections.abc import AsyncIterator
from contextlib import AbstractAsyncContextManager
from pathlib import Path

import pytest
from websockets.asyncio.client import connect

from bridge.cli import build_parser, config_from_args
from bridge.compose import RunningBridge, run_bridge
from bridge.config import BridgeConfig
from bridge.webapp import BUILD_COMMAND, WEB_ROOT_ENV, default_web_root

INDEX_HTML = b"<!doctype html><title>dashboard</title><script src='./assets/index-3f9a.js'>"
ASSET_JS = b"console.log('riverbridge');\n"


@pytest.fixture
def site(tmp_path: Path) -> Path:
    """A built web/dist: index.html, one hashed asset, a secret next to (not in) the root."""
    root = tmp_path / "dist"
    (root / "assets").mkdir(parents=True)
    (root / "index.html").write_bytes(INDEX_HTML)
    (root / "assets" / "index-3f9a.js").write_bytes(ASSET_JS)
    (root / "assets" / "style-77aa.css").write_text("body{}")
    (tmp_path / "secret.txt").write_text("not for the web")
    return root


def serving(root: Path) -> AbstractAsyncContextManager[RunningBridge]:
    return run_bridge(BridgeConfig(port=0, web_root=root))


@pytest.fixture
async def bridge(site: Path) -> AsyncIterator[RunningBridge]:
    async with serving(site) as running:
        yield running


async def get(bridge: RunningBridge, path: str) -> tuple[str, dict[str, str], bytes]:
    """One raw HTTP/1.1 GET: (status line, lower-cased headers, body)."""
    reader, writer = await asyncio.open_connection("127.0.0.1", bridge.port)
    writer.write(f"GET {path} HTTP/1.1\r\nHost: localhost\r\nConnection: close\r\n\r\n".encode())
    await writer.drain()
    data = await asyncio.wait_for(reader.read(), 5)
    writer.close()
    head, _, body = data.partition(b"\r\n\r\n")
    status, *lines = head.decode().split("\r\n")
    headers = {k.strip().lower(): v.strip() for k, v in (line.split(":", 1) for line in lines)}
    return status, headers, body


async def test_index_is_served_at_root_and_revalidated(bridge: RunningBridge) -> None:
    for path in ("/", "/index.html", "/?bridge=ws://elsewhere:9090"):
        status, headers, body = await get(bridge, path)
        assert status.startswith("HTTP/1.1 200"), path
        assert body == INDEX_HTML
        assert headers["content-type"] == "text/html; charset=utf-8"
        assert headers["cache-control"] == "no-cache"
        assert headers["content-length"] == str(len(INDEX_HTML))


async def test_hashed_assets_have_their_type_and_are_cached_for_good(bridge: RunningBridge) -> None:
    status, headers, body = await get(bridge, "/assets/index-3f9a.js")
    assert status.startswith("HTTP/1.1 200") and body == ASSET_JS
    assert headers["content-type"] == "text/javascript; charset=utf-8"
    assert headers["cache-control"] == "public, max-age=31536000, immutable"
    assert headers["x-content-type-options"] == "nosniff"
    _, headers, _ = await get(bridge, "/assets/style-77aa.css")
    assert headers["content-type"] == "text/css; charset=utf-8"


@pytest.mark.parametrize(
    "path",
    [
        "/../secret.txt",
        "/assets/../../secret.txt",
        "/%2e%2e/secret.txt",
        "/assets/%2e%2e%2f%2e%2e%2fsecret.txt",
        "/..%5csecret.txt",
        "//etc/passwd",
        "/assets/missing.js",
        "/assets/",
        "/index.html%00.js",
    ],
)
async def test_nothing_outside_the_root_or_missing_is_served(
    bridge: RunningBridge, path: str
) -> None:
    status, _, body = await get(bridge, path)
    assert status.startswith("HTTP/1.1 404"), (path, status)
    assert b"not for the web" not in body and b"root:" not in body


async def test_version_and_websocket_still_work_beside_the_site(bridge: RunningBridge) -> None:
    status, headers, _ = await get(bridge, "/version")
    assert status.startswith("HTTP/1.1 200") and headers["content-type"] == "application/json"
    async with connect(bridge.url) as ws:  # the websocket upgrade at "/" is not the page
        await ws.send('{"op": "call_service", "service": "/rosapi/get_time", "id": "t"}')
        assert '"service_response"' in await asyncio.wait_for(ws.recv(), 5)


async def test_without_a_build_root_says_how_to_build_it(tmp_path: Path) -> None:
    async with serving(tmp_path / "no-dist") as bridge:
        status, headers, body = await get(bridge, "/")
        assert status.startswith("HTTP/1.1 200")
        assert headers["content-type"] == "text/html; charset=utf-8"
        assert BUILD_COMMAND.replace("&", "&amp;").encode() in body
        assert str(tmp_path / "no-dist").encode() in body
        status, _, _ = await get(bridge, "/assets/index-3f9a.js")
        assert status.startswith("HTTP/1.1 404")


async def test_start_up_logs_the_build_command_when_there_is_no_build(
    tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    async with serving(tmp_path / "no-dist"):
        pass
    assert any(BUILD_COMMAND in record.getMessage() for record in caplog.records)


def test_web_root_comes_from_the_option_then_the_environment_then_the_repo(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    args = build_parser().parse_args(["--web-root", str(tmp_path)])
    assert config_from_args(args).web_root == tmp_path
    assert config_from_args(build_parser().parse_args([])).web_root is None
    monkeypatch.setenv(WEB_ROOT_ENV, str(tmp_path / "elsewhere"))
    assert default_web_root() == tmp_path / "elsewhere"
    monkeypatch.delenv(WEB_ROOT_ENV)
    assert default_web_root() == Path(__file__).resolve().parents[2] / "web" / "dist"
