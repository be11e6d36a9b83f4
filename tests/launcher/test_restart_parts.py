"""The restart policy, its backoff and the published counts, without processes."""

from __future__ import annotations

import pytest
from prometheus_client.parser import text_string_to_metric_families

from bridge.metrics import MetricsSnapshot, render_metrics
from clients.stack.restarts import (
    INITIAL_DELAY_S,
    MAX_DELAY_S,
    STABLE_AFTER_S,
    RestartBackoff,
    RestartLedger,
    RestartPolicy,
)
from schemas.supervision import restart_counts, restarts_msg


@pytest.mark.parametrize(
    ("mode", "code", "restarted"),
    [
        ("on-failure", 1, True),
        ("on-failure", -9, True),
        ("on-failure", 0, False),
        ("always", 0, True),
        ("always", -9, True),
        ("never", -9, False),
        ("never", 1, False),
    ],
)
def test_policy(mode, code, restarted):
    assert RestartPolicy(mode).restarts(code) is restarted


def test_backoff_doubles_while_crashing_and_resets_after_a_stable_run():
    backoff = RestartBackoff()
    delays = [backoff.next_delay(ran_s=1.0) for _ in range(10)]
    assert delays[:3] == [INITIAL_DELAY_S, 2 * INITIAL_DELAY_S, 4 * INITIAL_DELAY_S]
    assert max(delays) == MAX_DELAY_S
    assert backoff.next_delay(ran_s=STABLE_AFTER_S) == INITIAL_DELAY_S


def test_counts_round_trip_through_the_diagnostics_message(check_canonical):
    ledger = RestartLedger()
    for title, pid in (("bridge", 10), ("simulator", 11), ("navigation", 12)):
        ledger.started(title, pid)
    assert ledger.died("simulator", "was killed by SIGKILL (exit code -9)") == 1
    assert ledger.died("simulator", "exited with code 3") == 2
    msg = restarts_msg(ledger.components, 1_700_000_000_000_000_000)
    check_canonical("diagnostic_msgs/msg/DiagnosticArray", msg)
    assert restart_counts(msg) == {"bridge": 0, "simulator": 2, "navigation": 0}
    simulator = msg["status"][1]
    assert simulator["level"] == 1 and "exited with code 3" in simulator["message"]


def test_metrics_show_restarts_per_component():
    snapshot = MetricsSnapshot({}, {}, 0, 0.0, 0, restarts={"simulator": 2, "bridge": 0})
    text = render_metrics(snapshot)
    families = {f.name: f for f in text_string_to_metric_families(text)}
    restarts = families["riverbridge_component_restarts"]
    assert restarts.type == "counter"
    assert {
        s.labels["component"]: s.value for s in restarts.samples if s.name.endswith("_total")
    } == {"simulator": 2.0, "bridge": 0.0}
