"""Services: call_service, advertise_service, unadvertise_service, service_response.

Calls to `/rosapi/*` are answered by the bridge itself (`bridge.rosapi`); calls to a service
a client advertised are forwarded to that client as `call_service` with id
`service_request:<service>:<n>` and its `service_response` is routed back (protocol §2.6-2.8).
Every call is answered exactly once: by the provider, or with `result: false` and a string
when the service is unknown, the call times out, or the provider unadvertises or leaves.
"""

from __future__ import annotations

from bridge.context import Context, Gathering, PendingCall
from bridge.errors import BridgeError, OpFailure, RosapiError
from bridge.graph import ServiceEntry
from bridge.names import absolute_name, allowed
from bridge.ops import route
from bridge.rosapi.common import Forward, Gather, RosapiService
from bridge.session import ClientSession
from schemas.errors import SchemaError
from schemas.message import normalize
from schemas.ops import (
    MAX_TIMEOUT_S,
    AdvertiseService,
    CallService,
    ServiceResponse,
    UnadvertiseService,
    reply_id,
)
from schemas.specs import MessageSpec
from schemas.typenames import is_valid_type_name, normalize_type_name
from schemas.values import JsonObject, JsonValue, Message, OpId

NS_PER_S = 1_000_000_000


def respond(
    ctx: Context, caller: int, service: str, call_id: OpId, values: JsonValue, result: bool
) -> None:
    """Send the caller its `service_response`, echoing its service string and id."""
    ctx.send(caller, ServiceResponse(service=service, values=values, result=result, id=call_id))


def fill_message(ctx: Context, spec: MessageSpec, raw: JsonValue) -> Message:
    """Validate and complete request/response fields; a list is positional (protocol §2.6)."""
    if isinstance(raw, list):
        names = [f.name for f in spec.fields]
        if len(raw) > len(names):
            raise OpFailure(f"{spec.name} has {len(names)} fields, got {len(raw)} arguments")
        raw = dict(zip(names, raw, strict=False))
    elif not isinstance(raw, dict):
        raw = {}
    try:
        return normalize(spec, raw, now_ns=ctx.now_ns)
    except SchemaError as exc:
        raise OpFailure(str(exc)) from exc


def request_fields(ctx: Context, type_name: str | None, raw: JsonValue) -> JsonValue:
    """Request args filled against the service type if it is known, else relayed as sent."""
    if type_name is not None and ctx.state.registry.has_service(type_name):
        return fill_message(ctx, ctx.state.registry.service(type_name).request, raw)
    return {} if raw is None else raw


def service_type_name(ctx: Context, raw: str) -> str | None:
    """Canonical `pkg/srv/T` when the type is well formed, else None (relayed untyped)."""
    if not is_valid_type_name(raw):
        return None
    return normalize_type_name(raw, "srv")


def answer_rosapi(ctx: Context, service: RosapiService, args: JsonValue) -> Message:
    """A rosapi service's answer, typed by its `.srv` in the registry both ways: the handler
    gets the request with exactly the request's fields (defaults filled, types checked) and
    its values go out as the response type says (field order, defaults; a field the `.srv`
    lacks fails the call)."""
    srv = ctx.state.registry.service(service.type_name)
    return fill_message(
        ctx, srv.response, service.handler(ctx, fill_message(ctx, srv.request, args))
    )


def forwarded(ctx: Context, service: RosapiService, args: JsonValue) -> Forward | Gather | None:
    """Where a rosapi call is answered by other services (other nodes' parameters)."""
    if service.forward is None:
        return None
    srv = ctx.state.registry.service(service.type_name)
    return service.forward(ctx, fill_message(ctx, srv.request, args))


def handle_call_service(ctx: Context, session: ClientSession, op: CallService) -> None:
    name_part, _, suffix = op.service.partition("#")
    call_id = op.id if op.id is not None else reply_id(suffix or None)  # a long one: none
    try:
        name = absolute_name(name_part)
        values = call(ctx, session, name, op, call_id)
    except (BridgeError, SchemaError) as exc:
        ctx.problem(session, "call_service", call_id, f"{op.service}: {exc}")
        respond(ctx, session.client_id, op.service, call_id, str(exc), False)
        return
    if values is not None:
        respond(ctx, session.client_id, op.service, call_id, values, True)


def call(
    ctx: Context, session: ClientSession, name: str, op: CallService, call_id: OpId
) -> Message | None:
    """Answer a rosapi call (returns its values) or forward it to a provider (returns None)."""
    rosapi = ctx.state.rosapi.get(name)
    forward = forwarded(ctx, rosapi, op.args) if rosapi is not None else None
    if rosapi is not None and forward is None:
        return answer_rosapi(ctx, rosapi, op.args)
    if isinstance(forward, Gather):
        return gather(ctx, session, forward, op, call_id)
    if forward is not None:
        pending = PendingCall(
            forward.service, 0, session.client_id, call_id, op.service, 0.0, forward.translate
        )
        send_call(ctx, pending, forward.args, op.timeout)
        return None
    pending = PendingCall(name, 0, session.client_id, call_id, op.service, 0.0)
    send_call(ctx, pending, op.args, op.timeout)
    return None


def send_call(ctx: Context, pending: PendingCall, args: JsonValue, timeout: float | None) -> None:
    """Call `pending.service`'s provider with `args` (OpFailure: not allowed, no provider);
    its answer, or the timeout, settles `pending`."""
    name = pending.service
    if not allowed(name, ctx.state.config.services_glob):
        raise OpFailure(f"Service {name} is not allowed by services_glob")
    entry = ctx.state.graph.services.get(name)
    provider = ctx.state.session_of_node(entry.provider) if entry else None
    if entry is None or provider is None:
        raise OpFailure(f"Service {name} does not exist")
    request = request_fields(ctx, entry.type_name, args)
    entry.requests_sent += 1
    request_id = f"service_request:{entry.spelling}:{entry.requests_sent}"
    pending.provider = provider.client_id
    pending.timeout_s = (
        min(timeout, MAX_TIMEOUT_S) if timeout and timeout > 0 else ctx.state.config.call_timeout_s
    )
    ctx.state.pending_calls[request_id] = pending
    ctx.send(provider.client_id, CallService(id=request_id, service=entry.spelling, args=request))
    ctx.schedule(("call", request_id), ctx.now_ns + int(pending.timeout_s * NS_PER_S))


def gather(
    ctx: Context, session: ClientSession, wanted: Gather, op: CallService, call_id: OpId
) -> Message | None:
    """Make every call of `wanted` at once; the caller is answered when all are settled
    (at once when there are none or all fail here)."""
    if not wanted.calls:
        return wanted.combine([])
    gathering = Gathering(wanted.combine, [None] * len(wanted.calls))
    for slot, (service, args) in enumerate(wanted.calls):
        pending = PendingCall(
            service, 0, session.client_id, call_id, op.service, 0.0, None, gathering, slot
        )
        try:
            send_call(ctx, pending, args, op.timeout)
        except (BridgeError, SchemaError) as exc:
            finish(ctx, pending, str(exc), False)
    return None


def take_pending(ctx: Context, session: ClientSession, request_id: JsonValue) -> PendingCall | None:
    """Remove and return the call `request_id` if this client is the one answering it."""
    pending = ctx.state.pending_calls.get(request_id) if isinstance(request_id, str) else None
    if pending is None or pending.provider != session.client_id:
        return None
    del ctx.state.pending_calls[request_id]
    return pending


def handle_service_response(ctx: Context, session: ClientSession, op: ServiceResponse) -> None:
    pending = take_pending(ctx, session, op.id)
    if pending is None:
        raise OpFailure(
            "Received service response for unrecognized id "
            "(the call timed out, failed or was never made)"
        )
    settle(ctx, session, pending, op.values, op.result)


def settle(
    ctx: Context, session: ClientSession, pending: PendingCall, values: JsonValue, result: bool
) -> None:
    """Answer the caller from a provider's `values` and `result` (see `response_values`)."""
    entry = ctx.state.graph.services.get(pending.service)
    try:
        answer = response_values(ctx, entry, values, result)
        if pending.translate is not None and isinstance(answer, dict):
            answer = pending.translate(answer)
    except (OpFailure, RosapiError) as exc:
        ctx.problem(session, "service_response", None, str(exc))
        finish(ctx, pending, f"Service {pending.service} answered badly: {exc}", False)
        return
    finish(ctx, pending, answer, not isinstance(answer, str))


def settle_unparsed_response(
    ctx: Context, session: ClientSession, message: JsonObject, problem: str
) -> None:
    """A provider's response that failed validation still ends its caller's wait at once.

    roslibjs omits `result` when its handler returns nothing; values given as an object
    still mean success, as everywhere else. Anything else fails the call with the problem.
    """
    pending = take_pending(ctx, session, message.get("id"))
    if pending is None:
        return
    values = message.get("values")
    if "result" not in message and isinstance(values, dict):
        settle(ctx, session, pending, values, True)
    else:
        finish(ctx, pending, f"Service {pending.service} answered badly: {problem}", False)


def response_values(
    ctx: Context, entry: ServiceEntry | None, values: JsonValue, result: bool
) -> Message | str:
    """The values to return: an object means success; a string or `result: false` failure."""
    if isinstance(values, str):
        return values
    if values is None and result is False:
        return "Service provider reported failure"
    if values is not None and not isinstance(values, dict):
        raise OpFailure(f"values must be an object, got {type(values).__name__}")
    if entry and entry.type_name and ctx.state.registry.has_service(entry.type_name):
        return fill_message(ctx, ctx.state.registry.service(entry.type_name).response, values)
    return values or {}


def finish(ctx: Context, pending: PendingCall, values: JsonValue, result: bool) -> None:
    gathering = pending.gathering
    if gathering is None:
        respond(ctx, pending.caller, pending.caller_service, pending.caller_id, values, result)
        return
    gathering.answers[pending.slot] = values if result and isinstance(values, dict) else str(values)
    answers = [a for a in gathering.answers if a is not None]
    if len(answers) < len(gathering.answers):
        return
    try:
        combined: JsonValue = gathering.combine(answers)
    except RosapiError as exc:
        combined, result = str(exc), False
    else:
        result = True
    respond(ctx, pending.caller, pending.caller_service, pending.caller_id, combined, result)


def fail_calls(ctx: Context, service: str, reason: str) -> None:
    """Answer every pending call to `service` with `result: false`."""
    for request_id, pending in list(ctx.state.pending_calls.items()):
        if pending.service == service:
            del ctx.state.pending_calls[request_id]
            finish(ctx, pending, reason, False)


def handle_advertise_service(ctx: Context, session: ClientSession, op: AdvertiseService) -> None:
    name = absolute_name(op.service)
    if name in ctx.state.rosapi:
        raise OpFailure(f"Service {name} is provided by the bridge itself")
    if not allowed(name, ctx.state.config.services_glob):
        raise OpFailure(f"Service {name} is not allowed by services_glob")
    old = ctx.state.graph.services.get(name)
    if old is not None:
        fail_calls(ctx, name, f"Service {name} was advertised again by another provider")
        previous = ctx.state.session_of_node(old.provider)
        if previous is not None:
            previous.services.discard(name)
    ctx.state.graph.services[name] = ServiceEntry(
        name, op.service, service_type_name(ctx, op.type), session.node
    )
    session.services.add(name)


def handle_unadvertise_service(
    ctx: Context, session: ClientSession, op: UnadvertiseService
) -> None:
    name = absolute_name(op.service)
    entry = ctx.state.graph.services.get(name)
    if entry is None or entry.provider != session.node:
        raise OpFailure(f"Service {name} has not been advertised by this client")
    remove_service(ctx, session, name, f"Service {name} was unadvertised")


def remove_service(ctx: Context, session: ClientSession, name: str, reason: str) -> None:
    del ctx.state.graph.services[name]
    session.services.discard(name)
    fail_calls(ctx, name, reason)


def release_client(ctx: Context, session: ClientSession) -> None:
    """Disconnect clean-up: the client's services go away, calls in both directions end."""
    for name in list(session.services):
        remove_service(ctx, session, name, f"Service {name} provider disconnected")
    for request_id, pending in list(ctx.state.pending_calls.items()):
        if pending.caller == session.client_id:
            del ctx.state.pending_calls[request_id]


def on_call_deadline(ctx: Context, request_id: str) -> None:
    """A forwarded call got no response in time."""
    pending = ctx.state.pending_calls.pop(request_id, None)
    if pending is not None:
        finish(
            ctx,
            pending,
            f"Service {pending.service} call timed out after {pending.timeout_s:g} s",
            False,
        )


ROUTES = (
    route(CallService, handle_call_service),
    route(AdvertiseService, handle_advertise_service),
    route(UnadvertiseService, handle_unadvertise_service),
    route(ServiceResponse, handle_service_response),
)
