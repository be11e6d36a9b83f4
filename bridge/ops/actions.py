"""Actions provided by clients (protocol §2.9).

A caller's `send_action_goal` is forwarded to the advertising client with id
`action_goal:<action>:<n>`; the provider's `action_feedback` and `action_result` are routed
back under the caller's own id, and the caller's `cancel_action_goal` is forwarded. Goals
that cannot be served end at once with `action_result` `result: false`.
"""

from __future__ import annotations

from typing import Literal

from bridge.context import Context, PendingGoal
from bridge.errors import BridgeError, OpFailure
from bridge.graph import ActionEntry
from bridge.names import absolute_name, allowed
from bridge.ops import route
from bridge.session import ClientSession
from schemas.errors import SchemaError
from schemas.message import normalize
from schemas.ops import (
    ActionFeedback,
    ActionResult,
    AdvertiseAction,
    CancelActionGoal,
    SendActionGoal,
    UnadvertiseAction,
)
from schemas.specs import MessageSpec
from schemas.typenames import is_valid_type_name, normalize_type_name
from schemas.values import JsonValue, OpId

STATUS_ABORTED = 6  # action_msgs/GoalStatus


def fail_goal(ctx: Context, caller: int, action: str, caller_id: OpId, reason: str) -> None:
    """End a caller's goal with `result: false`, status ABORTED and the reason as values."""
    ctx.send(
        caller,
        ActionResult(
            action=action, values=reason, status=STATUS_ABORTED, result=False, id=caller_id
        ),
    )


def action_spec_part(
    ctx: Context, type_name: str | None, part: Literal["goal", "result", "feedback"]
) -> MessageSpec | None:
    """goal/result/feedback spec of a known action type, else None (relayed untyped)."""
    if type_name is None or not ctx.state.registry.has_action(type_name):
        return None
    spec: MessageSpec = getattr(ctx.state.registry.action(type_name), part)
    return spec


def filled(ctx: Context, spec: MessageSpec | None, raw: JsonValue) -> JsonValue:
    if spec is None:
        return {} if raw is None else raw
    if isinstance(raw, list):
        raw = dict(zip([f.name for f in spec.fields], raw, strict=False))
    try:
        return normalize(spec, raw if isinstance(raw, dict) else {}, now_ns=ctx.now_ns)
    except SchemaError as exc:
        raise OpFailure(str(exc)) from exc


def handle_send_action_goal(ctx: Context, session: ClientSession, op: SendActionGoal) -> None:
    try:
        forward_goal(ctx, session, op)
    except (BridgeError, SchemaError) as exc:
        ctx.problem(session, "send_action_goal", op.id, f"{op.action}: {exc}")
        fail_goal(ctx, session.client_id, op.action, op.id, str(exc))


def action_name(ctx: Context, raw: str) -> str:
    """Absolute action name, refused if outside the actions' globs."""
    name = absolute_name(raw)
    if not allowed(name, ctx.state.config.action_patterns()):
        raise OpFailure(f"Action {name} is not allowed by actions_glob")
    return name


def same_action_type(asked: str, served: str) -> bool:
    """Whether a goal's `action_type` names the server's type (`pkg/T` or `pkg/action/T`);
    a type string that is no ROS 2 name (ROS 1 habits) is not held against the goal."""
    if not is_valid_type_name(asked):
        return True
    return normalize_type_name(asked, "action") == served


def forward_goal(ctx: Context, session: ClientSession, op: SendActionGoal) -> None:
    name = action_name(ctx, op.action)
    entry = ctx.state.graph.actions.get(name)
    provider = ctx.state.session_of_node(entry.provider) if entry else None
    if entry is None or provider is None:
        raise OpFailure(f"Action {name} does not exist")
    type_name = entry.type_name or op.action_type
    if entry.type_name and not same_action_type(op.action_type, entry.type_name):
        raise OpFailure(f"Action {name} is {entry.type_name}, not {op.action_type}")
    args = filled(ctx, action_spec_part(ctx, type_name, "goal"), op.args)
    entry.goals_sent += 1
    goal_id = f"action_goal:{entry.spelling}:{entry.goals_sent}"
    ctx.state.pending_goals[goal_id] = PendingGoal(
        name, provider.client_id, session.client_id, op.id, op.action, op.feedback
    )
    ctx.send(
        provider.client_id,
        SendActionGoal(
            id=goal_id, action=entry.spelling, action_type=type_name, args=args, feedback=True
        ),
    )


def provider_goal(ctx: Context, session: ClientSession, goal_id: OpId) -> tuple[str, PendingGoal]:
    """The goal `goal_id` this provider was sent (its key and entry), else OpFailure."""
    if isinstance(goal_id, str):
        pending = ctx.state.pending_goals.get(goal_id)
        if pending is not None and pending.provider == session.client_id:
            return goal_id, pending
    raise OpFailure(f"no pending goal with id {goal_id!r} for this provider")


def handle_action_feedback(ctx: Context, session: ClientSession, op: ActionFeedback) -> None:
    _goal_id, pending = provider_goal(ctx, session, op.id)
    if not pending.feedback:
        return
    entry = ctx.state.graph.actions.get(pending.action)
    values = filled(
        ctx, action_spec_part(ctx, entry.type_name if entry else None, "feedback"), op.values
    )
    feedback = ActionFeedback(action=pending.caller_action, values=values, id=pending.caller_id)
    ctx.send(pending.caller, feedback)


def handle_action_result(ctx: Context, session: ClientSession, op: ActionResult) -> None:
    goal_id, pending = provider_goal(ctx, session, op.id)
    del ctx.state.pending_goals[goal_id]
    if op.result is False or isinstance(op.values, str):
        reason = op.values if isinstance(op.values, str) else "Action provider reported failure"
        fail_goal(ctx, pending.caller, pending.caller_action, pending.caller_id, reason)
        return
    entry = ctx.state.graph.actions.get(pending.action)
    try:
        values = filled(
            ctx, action_spec_part(ctx, entry.type_name if entry else None, "result"), op.values
        )
    except OpFailure as exc:
        ctx.problem(session, "action_result", op.id, str(exc))
        fail_goal(ctx, pending.caller, pending.caller_action, pending.caller_id, str(exc))
        return
    ctx.send(
        pending.caller,
        ActionResult(
            action=pending.caller_action,
            values=values,
            status=op.status,
            result=True,
            id=pending.caller_id,
        ),
    )


def handle_cancel_action_goal(ctx: Context, session: ClientSession, op: CancelActionGoal) -> None:
    """Forward the caller's cancel; the provider's eventual result reports CANCELED."""
    for goal_id, pending in ctx.state.pending_goals.items():
        if pending.caller == session.client_id and pending.caller_id == op.id:
            entry = ctx.state.graph.actions.get(pending.action)
            spelling = entry.spelling if entry else pending.action
            ctx.send(pending.provider, CancelActionGoal(id=goal_id, action=spelling))
            return
    raise OpFailure(f"no pending goal with id {op.id!r} to cancel")


def handle_advertise_action(ctx: Context, session: ClientSession, op: AdvertiseAction) -> None:
    name = action_name(ctx, op.action)
    if name in ctx.state.graph.actions:
        remove_action(ctx, name, f"Action {name} was advertised again by another provider")
    type_name = normalize_type_name(op.type, "action") if is_valid_type_name(op.type) else None
    ctx.state.graph.actions[name] = ActionEntry(name, op.action, type_name, session.node)
    session.actions.add(name)


def handle_unadvertise_action(ctx: Context, session: ClientSession, op: UnadvertiseAction) -> None:
    name = absolute_name(op.action)
    entry = ctx.state.graph.actions.get(name)
    if entry is None or entry.provider != session.node:
        raise OpFailure(f"Action {name} has not been advertised by this client")
    remove_action(ctx, name, f"Action {name} was unadvertised")


def remove_action(ctx: Context, name: str, reason: str) -> None:
    """Forget an action server; its pending goals end with `result: false`."""
    entry = ctx.state.graph.actions.pop(name)
    owner = ctx.state.session_of_node(entry.provider)
    if owner is not None:
        owner.actions.discard(name)
    for goal_id, pending in list(ctx.state.pending_goals.items()):
        if pending.action == name:
            del ctx.state.pending_goals[goal_id]
            fail_goal(ctx, pending.caller, pending.caller_action, pending.caller_id, reason)


def release_client(ctx: Context, session: ClientSession) -> None:
    """Disconnect clean-up: provided actions end; goals the client sent are cancelled."""
    for name in list(session.actions):
        remove_action(ctx, name, f"Action {name} provider disconnected")
    for goal_id, pending in list(ctx.state.pending_goals.items()):
        if pending.caller == session.client_id:
            del ctx.state.pending_goals[goal_id]
            entry = ctx.state.graph.actions.get(pending.action)
            if entry is not None:
                ctx.send(pending.provider, CancelActionGoal(id=goal_id, action=entry.spelling))


ROUTES = (
    route(SendActionGoal, handle_send_action_goal),
    route(CancelActionGoal, handle_cancel_action_goal),
    route(ActionFeedback, handle_action_feedback),
    route(ActionResult, handle_action_result),
    route(AdvertiseAction, handle_advertise_action),
    route(UnadvertiseAction, handle_unadvertise_action),
)
