"""The sans-I/O rosbridge core: frames and the time in, effects out.

`BridgeCore` owns the graph and every client session. The asyncio edge calls it with what
arrived and when; it never awaits, never opens a socket and never reads the clock. Ops are
dispatched through one table built from the op-family modules in `bridge.ops`.
"""

from __future__ import annotations

import contextlib
import logging
from collections.abc import Callable, Iterable

from bridge.config import BridgeConfig
from bridge.context import BridgeState, Context, log_problem_summary
from bridge.effects import DeadlineKey, Effect, Hold
from bridge.errors import BridgeError, InvalidNameError
from bridge.inbound import InboundFrame, RefusedFrame, decode_frame, read_frame
from bridge.names import absolute_name
from bridge.ops import OpRoute, actions, auth, fragments, levels, merge_routes, services, topics
from bridge.outgoing import MIN_FRAGMENT_SIZE, TopicMessage
from bridge.roles import TRUSTED, AuditSink, new_grant
from bridge.rosapi import ROSAPI_SERVICES
from bridge.rosapi.common import RosapiService
from bridge.session import ClientSession
from bridge.sinks import MessageSink
from bridge.validation import PublishCheck
from schemas import tokens
from schemas.errors import SchemaError
from schemas.message import normalize, payload_bytes
from schemas.ops import MAX_NAME_CHARS, OpError, reply_id
from schemas.registry import TypeRegistry
from schemas.roles_config import Action
from schemas.safety import echo, safe_text
from schemas.specs import MessageSpec
from schemas.values import JsonObject, JsonValue, OpId

logger = logging.getLogger("bridge.core")

OP_ROUTES: dict[str, OpRoute] = merge_routes(
    topics.ROUTES, services.ROUTES, actions.ROUTES, fragments.ROUTES, levels.ROUTES, auth.ROUTES
)

# Deadline keys are tuples whose first item selects the handler; the rest are its arguments.
DEADLINE_HANDLERS: dict[str, Callable[..., None]] = {
    "release": topics.on_release_deadline,
    "call": services.on_call_deadline,
    "fragment": fragments.on_fragment_deadline,
    "problems": log_problem_summary,
    "auth_grace": auth.on_grace_deadline,
}

# Clean-up per op family when a client leaves; each releases what the client owned.
RELEASERS = (services.release_client, actions.release_client, topics.release_client)


class BridgeCore:
    """All protocol behaviour of the bridge, independent of any transport."""

    def __init__(self, config: BridgeConfig, registry: TypeRegistry) -> None:
        self.state = BridgeState(config, registry)
        self.state.rosapi = dict(ROSAPI_SERVICES)

    # -- connections -------------------------------------------------------------------------

    def connect(self, peer: str = "", node: str | None = None) -> int:
        """Register a new client; returns its id (its node is `/rosbridge_client_<id>`).

        `node` names an in-process client of another middleware instead (a DDS mirror's
        stand-in for a remote node): its ops and effects flow like a websocket client's.
        """
        self.state.clients_ever += 1
        client_id = self.state.clients_ever
        # An in-process client of another middleware (`node` given) is trusted; a websocket
        # client must authenticate first when the bridge has an auth secret (and no role for
        # clients that do not: then it starts with that role).
        config = self.state.config
        trusted = node is not None
        session = self.state.sessions[client_id] = ClientSession(
            client_id,
            node or f"/rosbridge_client_{client_id}",
            peer,
            authenticated=trusted or not config.needs_auth(),
        )
        if trusted:
            session.principal = TRUSTED
        elif config.roles is not None and config.roles.unauthenticated_role is not None:
            session.role = config.roles.unauthenticated_role
            role = config.roles.roles[session.role]
            session.grant = new_grant(session.role, role, 0)
        logger.info("[%s] connected from %s", session.node, peer or "?")
        return client_id

    def admit(self, client_id: int, now_ns: int, token: str | None = None) -> list[Effect]:
        """A websocket client's handshake is done: check the token it presented there
        (`Authorization: Bearer`, `?token=`), else give it `--auth-grace` to authenticate.
        Without a secret a token is ignored, as the `auth` op is."""
        ctx = Context(self.state, now_ns)
        session = self.state.sessions.get(client_id)
        if session is None:
            return []
        if token is not None and self.state.config.auth_secret is not None:
            auth.authenticate_token(ctx, session, token, None)
        elif session.grant is not None:  # anonymous, with the unauthenticated role
            problem = self.state.policy.anonymous_limit(session, self.state.sessions.values())
            if problem is not None:
                auth.refuse(ctx, session, None, problem)
        elif not session.authenticated:
            grace_ns = int(self.state.config.auth_grace_s * 1e9)
            ctx.schedule(("auth_grace", client_id), now_ns + grace_ns)
        return ctx.effects

    def authorize(self, client_id: int, action: Action | str, name: str) -> str | None:
        """May client `client_id` do `action` on `name`? The refusal text, or None. For other
        protocols (Foxglove) and mirrors acting on a client's behalf: the same roles as ops."""
        session = self.state.sessions.get(client_id)
        if session is None:
            return f"client {client_id} is not connected"
        if not session.authenticated:
            return "not authenticated"
        asked = Action(action)
        if asked not in (Action.GET_PARAM, Action.SET_PARAM):  # parameters keep their names
            try:
                name = absolute_name(name)
            except InvalidNameError as exc:
                return str(exc)
        return self.state.policy.authorize(session, asked, name)

    def disconnect(self, client_id: int, now_ns: int) -> list[Effect]:
        """Release everything the client owned and answer whatever waited on it."""
        ctx = Context(self.state, now_ns)
        session = self.state.sessions.pop(client_id, None)
        if session is None:
            return []
        for release in RELEASERS:
            release(ctx, session)
        summary = session.problems.summary(session.node, now_ns)
        if summary is not None:
            logger.warning("%s", summary)
        logger.info("[%s] disconnected", session.node)
        return ctx.effects

    # -- inbound -----------------------------------------------------------------------------

    def receive(
        self, client_id: int, data: bytes | str, arrived_ns: int, now_ns: int
    ) -> list[Effect]:
        """Decode and handle one websocket frame (text = JSON, binary = CBOR or JSON) that was
        read at `arrived_ns`. The edge splits this up: `read_frame`, `offload`, `receive_frame`.
        """
        try:
            frame = read_frame(data, arrived_ns)
        except SchemaError as exc:
            return self.receive_invalid(client_id, str(exc), now_ns)
        return self.receive_frame(client_id, frame, now_ns)

    def offload(self, frame: InboundFrame, now_ns: int) -> PublishCheck | None:
        """The work `frame` needs off the event loop, or None to handle it at once.

        A publish of at least `offload_threshold_bytes` whose message is not mostly bytes and
        arrays: checking it runs in Python (nested messages) or outside the GIL (base64),
        while bulk bytes and arrays cost microseconds. The check reads the topic's type now;
        hand its result back as `frame.checked` to `receive_frame`.
        """
        message = frame.message
        if (
            frame.wire_bytes < self.state.config.offload_threshold_bytes
            or not isinstance(message, dict)
            or message.get("op") != "publish"
        ):
            return None
        raw = message.get("msg")
        if not isinstance(raw, dict) or payload_bytes(raw) * 2 >= frame.wire_bytes:
            return None
        spec = self._presumed_spec(message)
        if spec is None:
            return None
        return PublishCheck(spec, raw, frame.wire_bytes, now_ns, self.state.registry)

    def _presumed_spec(self, message: JsonObject) -> MessageSpec | None:
        topic = message.get("topic")
        try:
            entry = (
                self.state.graph.topics.get(absolute_name(topic))
                if isinstance(topic, str)
                else None
            )
        except InvalidNameError:
            return None
        type_name = entry.type_name if entry is not None else message.get("type")
        try:
            return self.state.registry.message(type_name) if isinstance(type_name, str) else None
        except SchemaError:
            return None

    def receive_invalid(self, client_id: int, problem: str, now_ns: int) -> list[Effect]:
        """A frame that did not decode."""
        ctx = Context(self.state, now_ns)
        session = self.state.sessions.get(client_id)
        if session is not None:
            ctx.problem(session, "?", None, f"undecodable frame: {problem}")
        return ctx.effects

    def receive_frame(self, client_id: int, frame: InboundFrame, now_ns: int) -> list[Effect]:
        """Handle one decoded frame (and any message its fragments complete)."""
        return self._receive(client_id, frame.message, frame, now_ns)

    def receive_op(self, client_id: int, message: JsonObject, now_ns: int) -> list[Effect]:
        """Handle an op of an in-process client (`connect(node=...)`): no frame, no wire."""
        return self._receive(client_id, message, None, now_ns)

    def _receive(
        self,
        client_id: int,
        message: JsonValue | RefusedFrame,
        frame: InboundFrame | None,
        now_ns: int,
    ) -> list[Effect]:
        ctx = Context(self.state, now_ns, frame)
        session = self.state.sessions.get(client_id)
        if session is None or session.closing:
            return []
        self._dispatch_guarded(ctx, session, message)
        while ctx.reassembled and client_id in self.state.sessions:
            text = ctx.reassembled.pop(0)
            try:
                message = decode_frame(text)
            except SchemaError as exc:
                ctx.problem(session, "fragment", None, f"reassembled text is not JSON: {exc}")
                continue
            if frame is not None:  # the message arrived with its last fragment
                ctx.frame = InboundFrame(message, frame.arrived_ns, len(text))
            self._dispatch_guarded(ctx, session, message)
        return ctx.effects

    def _dispatch_guarded(
        self, ctx: Context, session: ClientSession, message: JsonValue | RefusedFrame
    ) -> None:
        """`_dispatch`, where a bug costs one op: never the connection (1011) or the server."""
        try:
            self._dispatch(ctx, session, message)
        except Exception as exc:
            head = message if isinstance(message, dict) else {}
            ctx.problem(
                session,
                str(head.get("op", "?")),
                reply_id(head.get("id")),
                f"internal error: {echo(exc)}",
                exc_info=exc,
            )
            with contextlib.suppress(Exception):
                answer_failed_request(ctx, session, head, f"internal error: {echo(exc)}", log=False)

    def _dispatch(
        self, ctx: Context, session: ClientSession, message: JsonValue | RefusedFrame
    ) -> None:
        if isinstance(message, RefusedFrame):
            answer_failed_request(ctx, session, message.head, message.problem)
            return
        if not isinstance(message, dict):
            ctx.problem(
                session, "?", None, f"message must be a JSON object, got {type(message).__name__}"
            )
            return
        op_name, op_id = message.get("op"), reply_id(message.get("id"))
        if "fragment_size" in message:
            set_fragment_size(ctx, session, message["fragment_size"], shown(op_name), op_id)
        route = OP_ROUTES.get(op_name) if isinstance(op_name, str) else None
        if route is None:
            shown_op = shown(op_name)
            what = "message without an op" if op_name is None else f"Unknown operation: {shown_op}"
            ctx.problem(session, shown_op, op_id, what)
            return
        if not session.authenticated and route.op != "auth":
            answer_failed_request(
                ctx,
                session,
                message,
                "not authenticated: this bridge needs a valid auth op (a token or rosauth's MAC) "
                "before any other",
            )
            return
        policy = self.state.policy
        if policy.active:
            wire_bytes = ctx.frame.wire_bytes if ctx.frame is not None else 0
            refusal = policy.check(session, route.op, message, wire_bytes, ctx.now_ns)
            if refusal is not None:
                answer_failed_request(ctx, session, message, refusal.text)
                if refusal.quota:  # read nothing more of it until its quota has room
                    ctx.effects.append(Hold(session.client_id, refusal.retry_ns))
                return
        try:
            route.run(ctx, session, message)
        except OpError as exc:  # the op did not parse: nothing was handled
            answer_failed_request(ctx, session, message, f"malformed op: {exc}")
        except (BridgeError, SchemaError) as exc:
            ctx.problem(session, route.op, op_id, str(exc))

    # -- time --------------------------------------------------------------------------------

    def on_deadline(self, key: DeadlineKey, now_ns: int) -> list[Effect]:
        """A deadline scheduled with `Schedule(key, at_ns)` has come."""
        ctx = Context(self.state, now_ns)
        handler = DEADLINE_HANDLERS.get(key[0]) if key and isinstance(key[0], str) else None
        if handler is not None:
            handler(ctx, *key[1:])
        return ctx.effects

    # -- the middleware seam -----------------------------------------------------------------

    def add_sink(self, sink: MessageSink) -> None:
        """Receive every message published in the graph from now on (e.g. a DDS mirror)."""
        self.state.sinks.append(sink)

    def remove_sink(self, sink: MessageSink) -> None:
        with contextlib.suppress(ValueError):
            self.state.sinks.remove(sink)

    def may_read_metrics(self, token: str | None, now_ns: int) -> bool:
        """/metrics for everyone, unless the roles file says `metrics_role_only`: then only
        for a valid token whose role has `metrics = true`."""
        roles, secret = self.state.config.roles, self.state.config.auth_secret
        if roles is None or not roles.metrics_role_only:
            return True
        if token is None or secret is None:
            return False
        try:
            claims = tokens.verify(secret.get_secret_value(), token, now_ns / 1e9)
        except tokens.TokenError:
            return False
        role = roles.roles.get(claims.role)
        return role is not None and role.metrics

    def set_audit(self, sink: AuditSink | None) -> None:
        """Where the policy writes audit entries (`--audit-log`); None: nowhere."""
        self.state.policy.set_audit(sink)

    def answer_service(self, name: str, service: RosapiService) -> None:
        """Answer calls to `name` in the bridge itself, as rosapi's (the stats service)."""
        self.state.rosapi[name] = service

    def stop_answering(self, name: str) -> None:
        self.state.rosapi.pop(name, None)

    def set_external_nodes(self, source: str, nodes: Iterable[str]) -> None:
        """The nodes another graph (`source`: a DDS domain...) has, listed by rosapi."""
        self.state.external_graphs[source] = frozenset(nodes)

    def add_remote_publisher(self, topic: str, type_name: str, node: str, advert: OpId) -> None:
        """A node of another graph publishes `topic` (GraphConflictError: another type)."""
        self.state.graph.declare_type(topic, type_name)
        self.state.graph.add_publisher(topic, node, advert, latch=False)

    def remove_remote_publisher(self, topic: str, node: str) -> None:
        self.state.graph.remove_publisher(topic, node)

    def add_remote_subscriber(self, topic: str, type_name: str, node: str) -> None:
        """A node of another graph subscribes to `topic` (GraphConflictError: another type)."""
        self.state.graph.declare_type(topic, type_name)
        self.state.graph.add_subscriber(topic, node)

    def remove_remote_subscriber(self, topic: str, node: str) -> None:
        self.state.graph.remove_subscriber(topic, node)

    def publish_external(
        self,
        node: str,
        topic: str,
        type_name: str,
        msg: JsonObject,
        now_ns: int,
        cdr: bytes | None = None,
        latch: bool = False,
    ) -> list[Effect]:
        """Publish a message from a source outside the websocket clients (a DDS mirror, the
        bridge's own telemetry).

        `node` becomes a publisher of the topic; `msg` is validated and completed like a
        client's message; `cdr`, if given, is reused for cbor-raw subscribers; with `latch`
        the message is kept for later subscribers.
        """
        ctx = Context(self.state, now_ns)
        name = absolute_name(topic)
        spec = self.state.registry.message(type_name)
        self.state.graph.declare_type(name, spec.name)
        entry = self.state.graph.add_publisher(name, node, None, latch=latch)
        message = TopicMessage(
            name,
            spec.name,
            normalize(spec, msg, now_ns=now_ns),
            now_ns,
            self.state.registry,
            cdr,
            has_float32=spec.has_float32_sequence,
        )
        if latch:
            entry.latched = message
        ctx.publish(message, node)
        return ctx.effects


def shown(op_name: JsonValue) -> str:
    """An op's name as a log line may show it."""
    return safe_text(str(op_name), 60) if op_name is not None else "?"


def set_fragment_size(
    ctx: Context, session: ClientSession, value: JsonValue, op_name: str, op_id: OpId
) -> None:
    """Any message carrying `fragment_size` sets the client-wide size (protocol §1.2)."""
    if value is None:
        session.fragment_size = None
    elif isinstance(value, int) and not isinstance(value, bool) and value > 0:
        session.fragment_size = max(value, MIN_FRAGMENT_SIZE)
    else:
        ctx.problem(
            session,
            op_name,
            op_id,
            f"fragment_size must be a positive integer or null, got {echo(value, 60)}",
        )


def answer_failed_request(
    ctx: Context, session: ClientSession, message: JsonObject, problem: str, log: bool = True
) -> None:
    """Log an op that could not be handled; a caller waiting for an answer still gets one.

    A `call_service` is answered with `result: false`, a `send_action_goal` with a failed
    `action_result`, and a provider's unusable `service_response` fails its caller's call.
    The answer echoes the caller's service or action string cut to `MAX_NAME_CHARS` and its
    id only if acceptable, so it is never much larger than the request.
    """
    op_name, op_id = message.get("op"), reply_id(message.get("id"))
    problem = safe_text(problem)
    if log:
        ctx.problem(
            session, safe_text(str(op_name), 60) if op_name is not None else "?", op_id, problem
        )
    service, action = message.get("service"), message.get("action")
    if op_name == "call_service" and isinstance(service, str):
        services.respond(ctx, session.client_id, service[:MAX_NAME_CHARS], op_id, problem, False)
    elif op_name == "service_response":
        services.settle_unparsed_response(ctx, session, message, problem)
    elif op_name == "send_action_goal" and isinstance(action, str):
        actions.fail_goal(ctx, session.client_id, action[:MAX_NAME_CHARS], op_id, problem)
