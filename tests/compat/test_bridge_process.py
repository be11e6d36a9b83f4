"""The bridge's command line as the compatibility fixtures rely on it."""

from __future__ import annotations

import signal

from .bridge_process import SHUTDOWN_TIMEOUT_S, running_bridge


def test_announces_port_and_exits_zero_on_sigint() -> None:
    with running_bridge() as endpoint:
        assert 0 < endpoint.port < 65536
        assert f"listening on ws://127.0.0.1:{endpoint.port}" in endpoint.log.text()
        endpoint.process.send_signal(signal.SIGINT)
        code = endpoint.process.wait(timeout=SHUTDOWN_TIMEOUT_S)
        assert code == 0, f"exit code {code} after SIGINT; output:\n{endpoint.log.text()}"
