"""roslibpy over wss:// against `python -m bridge --certfile/--keyfile`.

roslibpy connects through autobahn's `connectWS`, which without a context factory uses
Twisted's `ClientContextFactory`: it encrypts but does not verify the server's certificate
(docs/bridge.md says so). The tests pin both facts: the session works over TLS, and a
certificate nobody trusts is accepted all the same, so a change in roslibpy shows up here."""

from __future__ import annotations

import time

import roslibpy

from tests.tls_certificates import make_certificate

from . import roslibpy_support as rp
from .bridge_process import running_bridge


def test_roslibpy_calls_and_subscribes_over_wss(tmp_path):
    certificate = make_certificate(tmp_path)
    with running_bridge(
        ["--certfile", str(certificate.certfile), "--keyfile", str(certificate.keyfile)]
    ) as endpoint:
        ros = roslibpy.Ros("127.0.0.1", endpoint.port, is_secure=True)
        ros.run(timeout=rp.CONNECT_TIMEOUT_S)
        try:
            outcome = rp.call_service(ros, "/rosapi/get_time", {})
            assert outcome.succeeded, outcome.value
            inbox = rp.Inbox()
            listener = roslibpy.Topic(ros, "/tls_chatter", "std_msgs/msg/String")
            listener.subscribe(inbox)
            talker = roslibpy.Topic(ros, "/tls_chatter", "std_msgs/msg/String")
            talker.advertise()
            deadline = time.monotonic() + rp.WAIT_TIMEOUT_S
            while not inbox.snapshot() and time.monotonic() < deadline:
                talker.publish(roslibpy.Message({"data": "over tls"}))
                time.sleep(0.1)
            assert inbox.expect(1)[0]["data"] == "over tls"
        finally:
            rp.close(ros)
        assert "Traceback" not in endpoint.log.text()


def test_roslibpy_does_not_verify_the_certificate(tmp_path):
    certificate = make_certificate(tmp_path)
    with running_bridge(
        ["--certfile", str(certificate.certfile), "--keyfile", str(certificate.keyfile)]
    ) as endpoint:
        ros = roslibpy.Ros("127.0.0.1", endpoint.port, is_secure=True)  # trusts nothing
        try:
            ros.run(timeout=rp.CONNECT_TIMEOUT_S)
            outcome = rp.call_service(ros, "/rosapi/get_time", {})
            assert outcome.succeeded, outcome.value
        finally:
            rp.close(ros)
