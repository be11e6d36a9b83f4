"""The audit trail (--audit-log): entries queued on the loop, written by a thread as JSON
lines, rotated by size; and who may read /metrics when the roles file says so."""

from __future__ import annotations

import json

from bridge import audit
from bridge.compose import compose
from bridge.config import BridgeConfig
from schemas import tokens
from schemas.roles_config import RolesConfig
from tests.bridge.bridge_harness import START_NS, CoreHarness

SECRET = "0123456789abcdef0123456789abcdef"


async def test_entries_are_json_lines_rotated_by_size(tmp_path, monkeypatch, registry):
    monkeypatch.setattr(audit, "MAX_BYTES", 4_000)
    path = tmp_path / "audit.jsonl"
    bridge = compose(BridgeConfig(port=0, audit_log=path), registry)
    trail = bridge.plugins["audit"]
    assert bridge.server.core.state.policy.active  # the composition gave the core its sink
    for n in range(400):  # ~75 bytes each: ~7 files' worth
        trail.write({"n": n, "principal": "teleop", "op": "publish", "name": "/cmd_wrench"})
    await trail.start()
    await trail.stop()
    files = sorted(tmp_path.iterdir())
    assert [f.name for f in files] == [
        f"audit.jsonl{s}" for s in ("", ".1", ".2", ".3", ".4", ".5")
    ]
    assert all(f.stat().st_size <= 4_000 for f in files)
    newest = [json.loads(line) for line in path.read_text().splitlines()]
    assert newest[-1] == {"n": 399, "principal": "teleop", "op": "publish", "name": "/cmd_wrench"}
    kept = sum(len(f.read_text().splitlines()) for f in files)
    assert 250 < kept < 400  # the oldest went out with a sixth file


def test_metrics_only_for_a_metrics_role_when_the_file_says_so(registry):
    roles = RolesConfig.model_validate(
        {
            "metrics_role_only": True,
            "roles": {"ops": {"metrics": True}, "observer": {"subscribe": ["*"]}},
        }
    )
    core = CoreHarness(registry, auth_secret=SECRET, roles=roles).core
    now_s = START_NS / 1e9

    def token(role: str, secret: str = SECRET) -> str:
        return tokens.issue(secret, role, "someone", now_s, 60)

    assert core.may_read_metrics(token("ops"), START_NS)
    assert not core.may_read_metrics(token("observer"), START_NS)
    assert not core.may_read_metrics(token("ops", "forged-forged-forged-forged-forged"), START_NS)
    assert not core.may_read_metrics(None, START_NS)
    assert not core.may_read_metrics(token("ops"), START_NS + 120 * 10**9)  # expired
    open_roles = roles.model_copy(update={"metrics_role_only": False})
    assert CoreHarness(registry, auth_secret=SECRET, roles=open_roles).core.may_read_metrics(
        None, START_NS
    )
