"""Access control with real clients: rosauth's `auth` from roslibpy and roslibjs, TLS,
browser Origins and the client limit, against `python -m bridge` with its options."""

from __future__ import annotations

import asyncio
import json
import ssl
import time
import urllib.request
from collections.abc import Iterator
from pathlib import Path

import pytest
import roslibpy
import websockets
from websockets.exceptions import InvalidStatus

from schemas import rosauth
from tests.tls_certificates import CertificatePair, make_certificate

from . import roslibpy_support as rp
from .bridge_process import BridgeEndpoint, running_bridge
from .node_runner import run_scenario

SECRET = "1234567890abcdef"


@pytest.fixture
def secret_file(tmp_path: Path) -> Path:
    path = tmp_path / "secret.txt"
    path.write_text(SECRET + "\n")
    return path


@pytest.fixture
def secured_bridge(secret_file: Path) -> Iterator[BridgeEndpoint]:
    # A long grace: these clients may take their time (closing the silent ones: test_roles).
    args = ["--auth-secret-file", str(secret_file), "--auth-grace", "60"]
    with running_bridge(args) as endpoint:
        yield endpoint
        assert "Traceback" not in endpoint.log.text()


def roslibpy_with_auth(endpoint: BridgeEndpoint, secret: str) -> roslibpy.Ros:
    """A roslibpy connection that authenticates first, as `Ros.authenticate` does it."""
    op = rosauth.auth_op(secret, time.time(), client="192.168.1.101", dest="192.168.1.111")
    ros = roslibpy.Ros(endpoint.host, endpoint.port)
    ros.authenticate(
        op["mac"], op["client"], op["dest"], op["rand"], op["t"], op["level"], op["end"]
    )
    ros.run(timeout=rp.CONNECT_TIMEOUT_S)
    return ros


def test_roslibpy_authenticates_and_is_served(secured_bridge, log_trap):
    ros = roslibpy_with_auth(secured_bridge, SECRET)
    try:
        outcome = rp.call_service(ros, "/rosapi/get_time", {})
        assert outcome.succeeded, outcome.value
    finally:
        rp.close(ros)
    assert "authenticated (client '192.168.1.101'" in secured_bridge.log.text()


def test_roslibpy_without_auth_is_refused_and_kept(secured_bridge):
    with rp.connected(secured_bridge.host, secured_bridge.port) as ros:
        outcome = rp.call_service(ros, "/rosapi/get_time", {})
        assert not outcome.succeeded and "not authenticated" in outcome.value
        assert ros.is_connected


def test_roslibpy_with_a_wrong_secret_is_disconnected(secured_bridge):
    ros = roslibpy_with_auth(secured_bridge, "wrong-secret-000")
    try:
        deadline = time.monotonic() + 20
        while "authentication failed: mac does not match" not in secured_bridge.log.text():
            assert time.monotonic() < deadline, secured_bridge.log.text()
            time.sleep(0.1)
    finally:
        rp.close(ros)
    assert "disconnected" in secured_bridge.log.text()


@pytest.mark.parametrize(("secret", "outcome"), [(SECRET, "success"), ("nope", "closed")])
def test_roslibjs_authenticates(secured_bridge, secret, outcome):
    op = rosauth.auth_op(secret, time.time(), client="browser", dest="127.0.0.1")
    result = run_scenario(
        "auth.mjs",
        secured_bridge.url,
        op["mac"],
        op["client"],
        op["dest"],
        op["rand"],
        str(op["t"]),
        op["level"],
        str(op["end"]),
    )
    assert result["outcome"] == outcome, result


@pytest.fixture
def certificate(tmp_path: Path) -> CertificatePair:
    return make_certificate(tmp_path)


async def get_time(url: str, **connect_options) -> dict:
    async with websockets.connect(url, **connect_options) as ws:
        await ws.send(json.dumps({"op": "call_service", "service": "/rosapi/get_time", "id": "t"}))
        return json.loads(await asyncio.wait_for(ws.recv(), 20))


def test_tls_serves_wss_and_https(certificate, monkeypatch):
    trust = ssl.create_default_context(cafile=str(certificate.certfile))
    with running_bridge(
        ["--certfile", str(certificate.certfile), "--keyfile", str(certificate.keyfile)]
    ) as endpoint:
        assert f"listening on wss://127.0.0.1:{endpoint.port}" in endpoint.log.text()
        url = f"wss://127.0.0.1:{endpoint.port}"
        assert asyncio.run(get_time(url, ssl=trust))["result"] is True
        with urllib.request.urlopen(
            f"https://127.0.0.1:{endpoint.port}/version", context=trust, timeout=20
        ) as page:
            assert json.loads(page.read())["protocol"]["major"] == 2
        with pytest.raises(ssl.SSLCertVerificationError):  # an untrusted certificate
            asyncio.run(get_time(url, ssl=ssl.create_default_context()))
        monkeypatch.setenv("NODE_EXTRA_CA_CERTS", str(certificate.certfile))
        result = run_scenario("call_service.mjs", url, "/rosapi/get_time", "{}")
        assert result["outcome"] == "success", result


def test_bad_tls_files_are_named_and_exit_non_zero(tmp_path):
    from bridge.cli import main

    missing = tmp_path / "missing.pem"
    with pytest.raises(SystemExit) as exit_info:
        main(["--certfile", str(missing), "--keyfile", str(missing)])
    assert exit_info.value.code == 2
    garbage = tmp_path / "garbage.pem"
    garbage.write_text("not a certificate")
    with pytest.raises(SystemExit):
        main(["--certfile", str(garbage), "--keyfile", str(garbage)])
    with pytest.raises(SystemExit):
        main(["--certfile", str(garbage)])  # without --keyfile


async def handshake_status(url: str, origin: str | None = None) -> int:
    try:
        async with websockets.connect(url, origin=origin):
            return 101
    except InvalidStatus as exc:
        return exc.response.status_code


def test_origins_and_the_client_limit():
    args = [
        "--allowed-origins",
        "https://*.example.org",
        "http://localhost:8080",
        "--max-clients",
        "2",
    ]
    with running_bridge(args) as endpoint:
        url, own = endpoint.url, f"http://127.0.0.1:{endpoint.port}"

        async def probe() -> dict[str, int]:
            statuses = {
                origin or "none": await handshake_status(url, origin)
                for origin in (
                    None,
                    "https://app.example.org",
                    "http://localhost:8080",
                    own,
                    "https://evil.example.com",
                    "null",
                )
            }
            async with websockets.connect(url), websockets.connect(url):
                statuses["third client"] = await handshake_status(url)
            return statuses

        statuses = asyncio.run(probe())
        log = endpoint.log.text()
    assert statuses == {
        "none": 101,
        "https://app.example.org": 101,
        "http://localhost:8080": 101,
        own: 101,
        "https://evil.example.com": 403,
        "null": 403,
        "third client": 503,
    }
    assert "Origin https://evil.example.com is not allowed" in log


def test_the_secret_file_may_come_from_the_environment(secret_file, monkeypatch):
    from bridge.cli import build_parser, config_from_args

    monkeypatch.setenv("RIVERBRIDGE_AUTH_SECRET_FILE", str(secret_file))
    config = config_from_args(build_parser().parse_args([]))
    assert config.auth_secret is not None and config.auth_secret.get_secret_value() == SECRET
    monkeypatch.setenv("RIVERBRIDGE_AUTH_SECRET_FILE", "")  # compose's empty default: off
    assert config_from_args(build_parser().parse_args([])).auth_secret is None
