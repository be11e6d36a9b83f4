"""Who may do what: the roles policy the core asks once per op, before the op takes effect.

Pure and sans-I/O: the time is passed in, the audit trail is a callable the composition gives
(`bridge.audit` writes it off the loop). Without `--roles` and `--audit-log` the policy is
inactive and the core skips it with one attribute test, so the bridge stays as fast as before.

- `requested(op, message)`: what an op asks, as (`Action`, absolute name), or None for ops that
  only touch what the client already owns (unsubscribe, service_response, set_level...).
- `Policy.check`: the role's allow-list for that name, the advertise limits and, on publish,
  the client's messages/s and bytes/s token buckets. The answer is a `Refusal` or None.
- `Policy.grant`: a principal (a token's subject) gets a role, within its connection limit.
- `Policy.authorize`: the same decision for another protocol or a mirror acting for a client.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass, field
from datetime import UTC, datetime
from fnmatch import fnmatchcase
from typing import TYPE_CHECKING

from bridge.errors import InvalidNameError
from bridge.names import absolute_name
from schemas.roles_config import Action, Role, RolesConfig
from schemas.values import JsonObject, JsonValue

if TYPE_CHECKING:
    from bridge.session import ClientSession

NS_PER_S = 1_000_000_000
ANONYMOUS = "anonymous"  # the principal of a client that has not authenticated
TRUSTED = "bridge"  # the principal of in-process clients (mirrors, telemetry): never limited

AuditSink = Callable[[dict[str, object]], None]
MAX_DECISIONS = 10_000  # remembered allow-list answers before the memo starts over

# /rosapi services that read or write parameters: checked as parameters, by parameter name.
PARAM_SERVICES = {
    "/rosapi/get_param": Action.GET_PARAM,
    "/rosapi/has_param": Action.GET_PARAM,
    "/rosapi/search_param": Action.GET_PARAM,
    "/rosapi/get_param_names": Action.GET_PARAM,
    "/rosapi/set_param": Action.SET_PARAM,
    "/rosapi/delete_param": Action.SET_PARAM,
}
# The op that asks for an action, and the field naming what it acts on.
OP_ACTIONS: dict[str, tuple[Action, str]] = {
    "advertise": (Action.PUBLISH, "topic"),
    "publish": (Action.PUBLISH, "topic"),
    "subscribe": (Action.SUBSCRIBE, "topic"),
    "call_service": (Action.CALL_SERVICE, "service"),
    "advertise_service": (Action.ADVERTISE_SERVICE, "service"),
    "send_action_goal": (Action.SEND_GOAL, "action"),
    "cancel_action_goal": (Action.SEND_GOAL, "action"),
    "advertise_action": (Action.ADVERTISE_ACTION, "action"),
}
# Ops written to the audit trail whenever they are allowed (publishes only on audited topics);
# not rosapi's reads of the graph (Foxglove polls them every 3 s), but parameter changes.
AUDITED_OPS = {"call_service", "send_action_goal", "cancel_action_goal"}
ROSAPI_PREFIX = "/rosapi/"


@dataclass(frozen=True)
class Refusal:
    """Why an op may not take effect; `quota` refusals are counted, not audited one by one,
    and `retry_ns` says when the client's quota has room again (read nothing before)."""

    text: str
    quota: bool = False
    retry_ns: int = 0


@dataclass
class TokenBucket:
    """`rate` per second, holding at most one second's worth (the burst)."""

    rate: float
    level: float
    last_ns: int

    def take(self, amount: float, now_ns: int) -> bool:
        level, rate = self.level, self.rate
        if now_ns > self.last_ns:  # (plain comparisons: this runs per publish)
            level += (now_ns - self.last_ns) * rate / NS_PER_S
            if level > rate:
                level = rate
            self.last_ns = now_ns
        if amount > level and level < rate:
            self.level = level
            return False  # a message larger than the burst passes only from a full bucket
        self.level = level - amount
        return True

    def ready_ns(self, amount: float, now_ns: int) -> int:
        """When the bucket will hold `amount` (or be full, for more than a burst)."""
        missing = min(amount, self.rate) - self.level
        return now_ns + max(0, int(missing / self.rate * NS_PER_S))


@dataclass
class Grant:
    """A client's role and its own quota buckets."""

    role_name: str
    role: Role
    messages: TokenBucket | None
    bytes: TokenBucket | None


@dataclass
class PrincipalCounters:
    """What one principal did, for /metrics."""

    messages: int = 0
    bytes: int = 0
    refusals: int = 0
    dropped: int = 0  # publishes past its quota


@dataclass
class Requested:
    """What an op asks: an action on a name."""

    action: Action
    name: str


def requested(op_name: str, message: Mapping[str, JsonValue]) -> Requested | None:
    """The action and absolute name `message` asks for; None if it asks for none we gate, or
    its name is not a valid ROS name (the op's handler refuses that itself)."""
    found = OP_ACTIONS.get(op_name)
    if found is None:
        return None
    action, key = found
    raw = message.get(key)
    if not isinstance(raw, str):
        return None
    try:
        name = absolute_name(raw.partition("#")[0] if key == "service" else raw)
    except InvalidNameError:
        return None
    param_action = PARAM_SERVICES.get(name) if action is Action.CALL_SERVICE else None
    if param_action is not None:
        return Requested(param_action, param_name(message.get("args")))
    return Requested(action, name)


def param_name(args: JsonValue) -> str:
    """The parameter a /rosapi param call names ("" for get_param_names)."""
    raw = args.get("name") if isinstance(args, dict) else args[0] if args else None
    return raw if isinstance(raw, str) else ""


def allows(role: Role, action: Action, name: str) -> bool:
    return any(fnmatchcase(name, glob) for glob in role.globs(action))


def stamp(now_ns: int) -> str:
    return datetime.fromtimestamp(now_ns / NS_PER_S, UTC).isoformat(timespec="milliseconds")


@dataclass
class Policy:
    """The roles of one bridge (None: everyone may do everything) and its audit trail."""

    roles: RolesConfig | None
    audit: AuditSink | None = None
    counters: dict[str, PrincipalCounters] = field(default_factory=dict)
    # Whether the core must ask at all: a plain attribute, read once per op on the hot path.
    active: bool = field(init=False, default=False)
    _decisions: dict[tuple[str, Action, str], bool] = field(init=False, default_factory=dict)

    def __post_init__(self) -> None:
        self.active = self.roles is not None or self.audit is not None

    def set_audit(self, sink: AuditSink | None) -> None:
        self.audit = sink
        self.active = self.roles is not None or sink is not None

    def role(self, name: str) -> Role | None:
        return self.roles.roles.get(name) if self.roles is not None else None

    def grant(
        self,
        session: ClientSession,
        role_name: str | None,
        principal: str,
        sessions: Iterable[ClientSession],
        now_ns: int,
    ) -> str | None:
        """Give `session` the role `role_name` as `principal`; the problem if it may not."""
        role = None
        if self.roles is not None:
            role = self.role(role_name) if role_name is not None else None
            if role is None:
                return f"role {role_name!r} is not in the roles file"
            most = role.limits.connections
            same = sum(1 for s in sessions if s.principal == principal and s is not session)
            if most is not None and same >= most:
                return f"principal {principal!r} already has {same} connections (role limit)"
        session.principal, session.role = principal, role_name
        session.grant = None if role is None else new_grant(role_name or "", role, now_ns)
        return None

    def anonymous_limit(
        self, session: ClientSession, sessions: Iterable[ClientSession]
    ) -> str | None:
        """The unauthenticated role's `connections` limit, counted over anonymous clients."""
        grant = session.grant
        most = grant.role.limits.connections if grant is not None else None
        if most is None:
            return None
        same = sum(1 for s in sessions if not s.principal and s.grant and s is not session)
        if same < most:
            return None
        return f"{same} anonymous clients already (role {session.role} allows {most})"

    def check(
        self, session: ClientSession, op_name: str, message: JsonObject, wire: int, now_ns: int
    ) -> Refusal | None:
        """May `session` do what `message` asks now? Counts, audits, and spends its quota."""
        asked = requested(op_name, message)
        if asked is None:
            return None
        refusal = self._refusal(session, op_name, asked, wire, now_ns)
        counters = self.counters_of(session.principal or ANONYMOUS)
        if refusal is not None:
            if refusal.quota:
                counters.dropped += 1
            else:
                counters.refusals += 1
                self.record(session, op_name, asked.name, now_ns, "refused", refusal.text)
            return refusal
        if op_name == "publish":
            counters.messages += 1
            counters.bytes += wire
            if self.audited(asked.name):
                self.record(session, op_name, asked.name, now_ns, "allowed")
        elif asked.action is Action.SET_PARAM or (
            op_name in AUDITED_OPS and not asked.name.startswith(ROSAPI_PREFIX)
        ):
            self.record(session, op_name, asked.name, now_ns, "allowed")
        return None

    def _refusal(
        self, session: ClientSession, op_name: str, asked: Requested, wire: int, now_ns: int
    ) -> Refusal | None:
        grant = session.grant
        if grant is None:
            return None
        role = grant.role
        if not self.allows(grant.role_name, role, asked.action, asked.name):
            return Refusal(
                f"{op_name} {asked.name} refused: role {grant.role_name} may not "
                f"{asked.action.value.replace('_', ' ')} {asked.name}"
            )
        over = advertise_limit(session, op_name, asked.name, role)
        if over is not None:
            return Refusal(f"{op_name} {asked.name} refused: role {grant.role_name} {over}")
        if op_name == "publish" and not within_quota(grant, wire, now_ns):
            return Refusal(
                f"publish {asked.name} dropped: {session.principal or ANONYMOUS} is over the "
                f"quota of role "
                f"{grant.role_name}",
                quota=True,
                retry_ns=quota_ready_ns(grant, wire, now_ns),
            )
        return None

    def allows(self, role_name: str, role: Role, action: Action, name: str) -> bool:
        """`allows`, remembered per (role, action, name): globs are matched once per name."""
        key = (role_name, action, name)
        found = self._decisions.get(key)
        if found is None:
            if len(self._decisions) >= MAX_DECISIONS:  # names are the clients': stay bounded
                self._decisions.clear()
            found = self._decisions[key] = allows(role, action, name)
        return found

    def authorize(self, session: ClientSession | None, action: Action, name: str) -> str | None:
        """Another protocol's or a mirror's question: may this client do `action` on `name`?
        The refusal text, or None. Quotas and audit are the caller's op's, not counted here."""
        grant = session.grant if session is not None else None
        if grant is None or allows(grant.role, action, name):
            return None
        return f"role {grant.role_name} may not {action.value.replace('_', ' ')} {name}"

    def audited(self, topic: str) -> bool:
        globs = self.roles.audited_topics if self.roles is not None else ("/cmd_wrench",)
        return self.audit is not None and any(fnmatchcase(topic, g) for g in globs)

    def counters_of(self, principal: str) -> PrincipalCounters:
        found = self.counters.get(principal)
        if found is None:
            found = self.counters[principal] = PrincipalCounters()
        return found

    def record(
        self,
        session: ClientSession,
        op_name: str,
        name: str,
        now_ns: int,
        outcome: str,
        reason: str = "",
    ) -> None:
        """One audit entry (nothing without `--audit-log`)."""
        if self.audit is None:
            return
        entry: dict[str, object] = {
            "time": stamp(now_ns),
            "principal": session.principal or ANONYMOUS,
            "role": session.role,
            "client": session.node,
            "peer": session.peer,
            "op": op_name,
            "name": name,
            "outcome": outcome,
        }
        if reason:
            entry["reason"] = reason
        self.audit(entry)


def bearer_token(authorization: str | None) -> str | None:
    """The token of an `Authorization: Bearer <token>` header value, else None."""
    scheme_name, _, value = (authorization or "").partition(" ")
    return value.strip() or None if scheme_name.lower() == "bearer" else None


def new_grant(role_name: str, role: Role, now_ns: int) -> Grant:
    limits = role.limits
    return Grant(
        role_name,
        role,
        None if limits.messages_per_s is None else bucket(limits.messages_per_s, now_ns),
        None if limits.bytes_per_s is None else bucket(limits.bytes_per_s, now_ns),
    )


def bucket(rate: float, now_ns: int) -> TokenBucket:
    return TokenBucket(rate, rate, now_ns)


def within_quota(grant: Grant, wire_bytes: int, now_ns: int) -> bool:
    """Spend one message and its bytes from the client's buckets; False if either is empty."""
    if grant.messages is not None and not grant.messages.take(1, now_ns):
        return False
    return grant.bytes is None or grant.bytes.take(wire_bytes, now_ns)


def quota_ready_ns(grant: Grant, wire_bytes: int, now_ns: int) -> int:
    """When both buckets hold another message like this one."""
    ready = now_ns
    if grant.messages is not None:
        ready = max(ready, grant.messages.ready_ns(1, now_ns))
    if grant.bytes is not None:
        ready = max(ready, grant.bytes.ready_ns(wire_bytes, now_ns))
    return ready


def advertise_limit(session: ClientSession, op_name: str, name: str, role: Role) -> str | None:
    """The role's limit an advertisement would pass, if any."""
    limits = role.limits
    if op_name in ("advertise", "publish"):
        if name in session.published:  # the common case: a topic it already publishes
            return None
        most, owned = limits.topics_advertised, session.published
        what = "topics"
    elif op_name in ("advertise_service", "advertise_action"):
        most, owned = limits.services_advertised, session.services | session.actions
        what = "services and actions"
    else:
        return None
    if most is None or name in owned or len(owned) < most:
        return None
    return f"allows at most {most} {what} advertised per client"


__all__ = [
    "ANONYMOUS",
    "TRUSTED",
    "AuditSink",
    "Grant",
    "Policy",
    "PrincipalCounters",
    "Refusal",
    "Requested",
    "TokenBucket",
    "requested",
]
