"""Roles, tokens, quotas and the audit trail in the sans-I/O core (bridge.roles, --roles)."""

from __future__ import annotations

import logging
from pathlib import Path

import pytest
from pydantic import ValidationError

from bridge.config import BridgeConfig
from schemas import rosauth, tokens
from schemas.roles_config import RolesConfig, load_roles
from tests.bridge.bridge_harness import START_NS, CoreHarness

SECRET = "0123456789abcdef0123456789abcdef"
NOW_S = START_NS // 1_000_000_000
WRENCH = {"force": {"x": 1.0, "y": 0.0, "z": 0.0}, "torque": {"x": 0.0, "y": 0.0, "z": 0.5}}
FIB = "example_interfaces/action/Fibonacci"
ROLES = RolesConfig.model_validate(
    {
        "rosauth_role": "component",
        "roles": {
            "observer": {
                "subscribe": ["*"],
                "call_service": ["/rosapi/*"],
                "get_param": ["*"],
                "limits": {"connections": 2},
            },
            "operator": {
                "subscribe": ["*"],
                "publish": ["/cmd_wrench"],
                "call_service": ["*"],
                "send_goal": ["*"],
                "set_param": ["*"],
                "get_param": ["*"],
                "limits": {"messages_per_s": 10, "topics_advertised": 1},
            },
            "component": {
                "subscribe": ["*"],
                "publish": ["*"],
                "call_service": ["*"],
                "advertise_service": ["*"],
                "advertise_action": ["*"],
            },
        },
    }
)


def token(role: str, subject: str = "someone", ttl_s: float | None = 60.0, **kw) -> str:
    return tokens.issue(kw.get("secret", SECRET), role, subject, NOW_S, ttl_s)


def auth_op(mac: str) -> dict:
    """What roslibpy's and roslibjs's `authenticate(mac, ...)` send."""
    return {
        "op": "auth",
        "mac": mac,
        "client": "",
        "dest": "",
        "rand": "",
        "t": 0,
        "level": "",
        "end": 0,
    }


class Audit(list):
    def __call__(self, entry: dict) -> None:
        self.append(entry)


@pytest.fixture
def bridge(registry) -> CoreHarness:
    h = CoreHarness(registry, auth_secret=SECRET, roles=ROLES)
    h.audit = Audit()
    h.core.set_audit(h.audit)
    return h


def join(h: CoreHarness, role: str | None, subject: str = "someone") -> int:
    """A websocket client that authenticates with a token of `role` in the auth op."""
    client = h.connect()
    h._record(h.core.admit(client, h.now_ns))
    if role is not None:
        h.send(client, auth_op(token(role, subject)))
    return client


def test_observer_cannot_publish_the_command_and_nothing_reaches_anyone(bridge, caplog):
    sim = join(bridge, "component", "sim")
    bridge.send(sim, {"op": "subscribe", "topic": "/cmd_wrench", "type": "geometry_msgs/Wrench"})
    observer = join(bridge, "observer", "dashboard")
    bridge.send(observer, {"op": "set_level", "level": "error"})
    bridge.send(
        observer,
        {"op": "publish", "topic": "/cmd_wrench", "msg": WRENCH, "type": "geometry_msgs/Wrench"},
    )
    assert bridge.outbox(sim) == []
    [status] = bridge.outbox(observer)
    assert status["op"] == "status" and status["level"] == "error"
    assert "publish /cmd_wrench refused: role observer may not publish" in status["msg"]
    assert "/cmd_wrench refused: role observer" in caplog.text
    assert bridge.core.state.graph.topics["/cmd_wrench"].publishers == {}
    operator = join(bridge, "operator", "teleop")
    bridge.send(operator, {"op": "publish", "topic": "/cmd_wrench", "msg": WRENCH})
    assert [m["op"] for m in bridge.outbox(sim)] == ["publish"]


def test_observer_reads_the_graph_but_cannot_advertise_or_take_a_service(bridge):
    sim = join(bridge, "component", "sim")
    bridge.send(sim, {"op": "advertise_service", "service": "/reset", "type": "std_srvs/Empty"})
    observer = join(bridge, "observer", "dashboard")
    assert bridge.call(observer, "/rosapi/topics")["result"] is True
    bridge.send(
        observer, {"op": "advertise_service", "service": "/reset", "type": "std_srvs/Empty"}
    )
    bridge.send(observer, {"op": "advertise", "topic": "/fake", "type": "std_msgs/String"})
    assert bridge.state.graph.services["/reset"].provider == bridge.state.sessions[sim].node
    assert "/fake" not in bridge.state.graph.topics
    reply = bridge.call(observer, "/reset")
    assert reply["result"] is False
    assert "call_service /reset refused: role observer may not call service" in reply["values"]
    assert bridge.outbox(sim) == []  # the refused call never reached the provider


def test_observer_reads_but_cannot_set_a_parameter(bridge):
    operator = join(bridge, "operator", "teleop")
    set_args = {"name": "max_speed", "value": "3.0"}
    assert bridge.call(operator, "/rosapi/set_param", set_args)["result"] is True
    observer = join(bridge, "observer", "dashboard")
    refused = bridge.call(observer, "/rosapi/set_param", {"name": "max_speed", "value": "9"})
    assert refused["result"] is False and "may not set param max_speed" in refused["values"]
    refused = bridge.call(observer, "/rosapi/delete_param", {"name": "max_speed"})
    assert refused["result"] is False
    got = bridge.call(observer, "/rosapi/get_param", {"name": "max_speed"})
    assert got["result"] is True and got["values"]["value"] == "3.0"


def test_a_publisher_past_its_quota_loses_messages_counted(bridge):
    sub = join(bridge, "component", "sim")
    bridge.send(sub, {"op": "subscribe", "topic": "/cmd_wrench", "type": "geometry_msgs/Wrench"})
    operator = join(bridge, "operator", "teleop")
    for _ in range(25):  # at one instant: the bucket holds one second's worth (10)
        bridge.send(operator, {"op": "publish", "topic": "/cmd_wrench", "msg": WRENCH})
    assert len(bridge.outbox(sub)) == 10
    counters = bridge.core.state.policy.counters["teleop"]
    assert (counters.messages, counters.dropped, counters.refusals) == (10, 15, 0)
    # Each drop asks the edge to read nothing more of it until one message fits (1/10 s).
    assert {hold.until_ns - START_NS for hold in bridge.holds} == {100_000_000}
    assert {hold.client_id for hold in bridge.holds} == {operator}
    bridge.advance(0.5)  # half a second refills half the bucket
    for _ in range(10):
        bridge.send(operator, {"op": "publish", "topic": "/cmd_wrench", "msg": WRENCH})
    assert len(bridge.outbox(sub)) == 5


def test_advertised_topics_are_limited_per_client(bridge):
    operator = join(bridge, "operator", "teleop")
    bridge.send(
        operator, {"op": "advertise", "topic": "/cmd_wrench", "type": "geometry_msgs/Wrench"}
    )
    bridge.send(
        operator, {"op": "advertise", "topic": "/cmd_wrench", "type": "geometry_msgs/Wrench"}
    )
    assert bridge.state.sessions[operator].published == {"/cmd_wrench"}
    limited = RolesConfig.model_validate(
        {"roles": {"r": {"publish": ["*"], "limits": {"topics_advertised": 1}}}}
    )
    h = CoreHarness(bridge.core.state.registry, auth_secret=SECRET, roles=limited)
    client = join(h, "r")
    for topic in ("/a", "/b", "/c"):
        h.send(client, {"op": "advertise", "topic": topic, "type": "std_msgs/String"})
    assert h.state.sessions[client].published == {"/a"}


@pytest.mark.parametrize(
    ("presented", "why"),
    [
        (token("operator", secret="another secret, not the bridge's"), "signature does not match"),
        (token("operator", ttl_s=-60), "token expired"),
        (token("admin"), "role 'admin' is not in the roles file"),
        ("a.b.c", "malformed token"),
    ],
    ids=["forged", "expired", "unknown-role", "garbage"],
)
def test_bad_tokens_close_the_connection_with_the_reason(bridge, presented, why):
    client = join(bridge, None)
    bridge.send(client, auth_op(presented))
    [close] = bridge.closes
    assert close.client_id == client and close.code == 1008 and why in close.reason
    assert not bridge.state.sessions[client].authenticated
    [entry] = [e for e in bridge.audit if e["op"] == "auth"]
    assert entry["outcome"] == "refused" and why in entry["reason"]


def test_a_token_at_the_handshake_authenticates_and_a_bad_one_closes(bridge):
    good, bad = bridge.connect(), bridge.connect()
    bridge._record(bridge.core.admit(good, bridge.now_ns, token("observer", "dash")))
    bridge._record(bridge.core.admit(bad, bridge.now_ns, token("observer", ttl_s=-30)))
    assert bridge.state.sessions[good].role == "observer"
    assert bridge.state.sessions[good].principal == "dash"
    [close] = bridge.closes
    assert close.client_id == bad and "expired" in close.reason
    bridge.advance(60)  # no grace deadline for a client that authenticated at the handshake
    assert len(bridge.closes) == 1


def test_no_token_no_stay(bridge):
    idle, late = join(bridge, None), join(bridge, None)
    bridge.advance(4.0)
    bridge.send(late, auth_op(token("observer")))
    bridge.advance(1.5)
    [close] = bridge.closes
    assert close.client_id == idle and close.code == 1008
    assert close.reason == "not authenticated within 5 s"


def test_connections_per_principal(bridge):
    join(bridge, "observer", "dash")
    join(bridge, "observer", "dash")
    third = join(bridge, "observer", "dash")
    [close] = bridge.closes
    assert close.client_id == third and "already has 2 connections" in close.reason
    join(bridge, "observer", "another-dash")
    assert len(bridge.closes) == 1


def test_rosauth_mac_grants_the_files_rosauth_role(bridge):
    client = join(bridge, None)
    bridge.send(client, rosauth.auth_op(SECRET, NOW_S, client="10.0.0.2", dest="b", level="x"))
    session = bridge.state.sessions[client]
    assert session.role == "component" and session.principal == "rosauth:10.0.0.2"
    no_mac_role = RolesConfig.model_validate({"roles": {"r": {}}})
    h = CoreHarness(bridge.core.state.registry, auth_secret=SECRET, roles=no_mac_role)
    client = h.connect()
    h.send(client, rosauth.auth_op(SECRET, NOW_S, client="10.0.0.2", dest="b", level="x"))
    [close] = h.closes
    assert close.reason == "authentication failed"


def test_an_unauthenticated_role_lets_clients_stay_and_upgrade(registry):
    roles = ROLES.model_copy(update={"unauthenticated_role": "observer"})
    h = CoreHarness(registry, auth_secret=SECRET, roles=roles)
    client = join(h, None)
    assert h.call(client, "/rosapi/topics")["result"] is True
    h.send(client, {"op": "advertise", "topic": "/x", "type": "std_msgs/String"})
    assert "/x" not in h.state.graph.topics
    h.advance(10)
    assert h.closes == []
    h.send(client, auth_op(token("operator", "teleop")))
    assert h.state.sessions[client].role == "operator"


def test_the_audit_trail_holds_commands_calls_and_refusals(bridge):
    sim = join(bridge, "component", "sim")
    bridge.send(sim, {"op": "advertise", "topic": "/imu", "type": "sensor_msgs/Imu"})
    bridge.send(sim, {"op": "publish", "topic": "/imu", "msg": {}})  # not audited
    operator = join(bridge, "operator", "teleop")
    bridge.send(
        operator,
        {"op": "publish", "topic": "/cmd_wrench", "msg": WRENCH, "type": "geometry_msgs/Wrench"},
    )
    bridge.call(operator, "/rosapi/set_param", {"name": "gain", "value": "2"})
    observer = join(bridge, "observer", "dashboard")
    bridge.send(observer, {"op": "publish", "topic": "/cmd_wrench", "msg": WRENCH})
    seen = [
        (e["principal"], e["role"], e["op"], e["name"], e["outcome"])
        for e in bridge.audit
        if e["op"] != "auth"
    ]
    assert seen == [
        ("teleop", "operator", "publish", "/cmd_wrench", "allowed"),
        ("teleop", "operator", "call_service", "gain", "allowed"),
        ("dashboard", "observer", "publish", "/cmd_wrench", "refused"),
    ]
    assert bridge.audit[-1]["time"].startswith("2023-11-14T22:13:20")


def test_without_roles_the_policy_is_inactive(harness):
    assert not harness.core.state.policy.active
    client = harness.connect()
    harness.send(
        client, {"op": "advertise", "topic": "/cmd_wrench", "type": "geometry_msgs/Wrench"}
    )
    assert "/cmd_wrench" in harness.state.graph.topics


def test_authorize_answers_other_protocols_like_the_core(bridge):
    observer = join(bridge, "observer", "dash")
    assert bridge.core.authorize(observer, "subscribe", "/imu") is None
    refusal = bridge.core.authorize(observer, "publish", "cmd_wrench")
    assert refusal == "role observer may not publish /cmd_wrench"
    assert bridge.core.authorize(join(bridge, None), "subscribe", "/imu") == "not authenticated"


def test_roles_need_a_way_to_authenticate():
    with pytest.raises(ValidationError, match="nobody could authenticate"):
        BridgeConfig(roles=ROLES)


@pytest.mark.parametrize(
    ("text", "named"),
    [
        ('[roles.observer]\nsubscrbe = ["*"]\n', "roles.observer.subscrbe: Extra inputs"),
        ("[roles.o.limits]\nmessages_per_s = 'many'\n", "roles.o.limits.messages_per_s"),
        ('rosauth_role = "admin"\n[roles.o]\n', "rosauth_role 'admin' is not one of the roles"),
        ("[roles.o\n", "Expected ']'"),
    ],
)
def test_a_bad_roles_file_names_the_field(tmp_path: Path, text, named):
    path = tmp_path / "roles.toml"
    path.write_text(text)
    with pytest.raises(ValueError, match=r"roles\.toml") as raised:
        load_roles(path)
    assert named in str(raised.value)


def test_the_example_roles_file_has_an_observer_and_an_operator():
    roles = load_roles(Path(__file__).parents[2] / "config" / "roles.example.toml")
    assert roles.roles["observer"].publish == () and roles.roles["observer"].subscribe == ("*",)
    assert "/cmd_wrench" in roles.roles["operator"].publish
    assert roles.unauthenticated_role is None


def test_refusals_are_logged_once_per_line(bridge, caplog):
    caplog.set_level(logging.ERROR, "bridge.core")
    observer = join(bridge, "observer", "dash")
    bridge.send(observer, {"op": "advertise", "topic": "/cmd_wrench", "type": "std_msgs/String"})
    [line] = [r.getMessage() for r in caplog.records if "refused" in r.getMessage()]
    assert "op=advertise" in line and "role observer" in line and "/cmd_wrench" in line


def test_a_token_at_the_handshake_of_a_bridge_without_a_secret_is_ignored(harness):
    client = harness.connect()
    harness._record(harness.core.admit(client, harness.now_ns, token("operator")))
    assert harness.closes == [] and harness.deadlines == {}
    assert harness.call(client, "/rosapi/get_time")["result"] is True


def test_goals_are_for_roles_that_may_send_them(bridge):
    provider = join(bridge, "component", "sim")
    bridge.send(provider, {"op": "advertise_action", "action": "/fibonacci", "type": FIB})
    goal = {"op": "send_action_goal", "action": "/fibonacci", "action_type": FIB, "args": {}}
    observer = join(bridge, "observer", "dash")
    bridge.send(observer, {**goal, "id": "g1"})
    [failed] = bridge.outbox(observer)
    assert failed["op"] == "action_result" and failed["result"] is False
    assert "role observer may not send goal /fibonacci" in str(failed["values"])
    bridge.send(observer, {"op": "advertise_action", "action": "/fibonacci", "type": FIB})
    assert bridge.outbox(provider) == []  # neither the goal nor a takeover reached anyone
    operator = join(bridge, "operator", "teleop")
    bridge.send(operator, {**goal, "id": "g2"})
    [forwarded] = bridge.outbox(provider)
    assert forwarded["op"] == "send_action_goal"
    audited = [(e["principal"], e["op"], e["outcome"]) for e in bridge.audit if e["op"] != "auth"]
    assert audited == [
        ("dash", "send_action_goal", "refused"),
        ("dash", "advertise_action", "refused"),
        ("teleop", "send_action_goal", "allowed"),
    ]
