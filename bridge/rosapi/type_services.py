"""rosapi services about types: message/service definitions and the interface list."""

from __future__ import annotations

from collections.abc import Callable

from bridge.context import Context
from bridge.errors import RosapiError
from bridge.rosapi.common import table, text_arg
from schemas.errors import SchemaError
from schemas.registry import TypeRegistry
from schemas.values import Message

PREFIX = "/rosapi"


def _typedefs(
    ctx: Context, request: Message, name_of: Callable[[TypeRegistry, str], str]
) -> Message:
    """The typedefs of the message `name_of` finds from the request's `type` (a message, or a
    part of a service or action); an unknown type is the call's failure."""
    registry = ctx.state.registry
    try:
        return {"typedefs": registry.typedefs(name_of(registry, text_arg(request, "type")))}
    except SchemaError as exc:
        raise RosapiError(str(exc)) from exc


def message_details(ctx: Context, request: Message) -> Message:
    return _typedefs(ctx, request, lambda registry, name: name)


def service_request_details(ctx: Context, request: Message) -> Message:
    return _typedefs(ctx, request, lambda registry, name: registry.service(name).request.name)


def service_response_details(ctx: Context, request: Message) -> Message:
    return _typedefs(ctx, request, lambda registry, name: registry.service(name).response.name)


def action_goal_details(ctx: Context, request: Message) -> Message:
    return _typedefs(ctx, request, lambda registry, name: registry.action(name).goal.name)


def action_result_details(ctx: Context, request: Message) -> Message:
    return _typedefs(ctx, request, lambda registry, name: registry.action(name).result.name)


def action_feedback_details(ctx: Context, request: Message) -> Message:
    return _typedefs(ctx, request, lambda registry, name: registry.action(name).feedback.name)


def interfaces(ctx: Context, request: Message) -> Message:
    registry = ctx.state.registry
    return {
        "interfaces": [
            *registry.message_names(),
            *registry.service_names(),
            *registry.action_names(),
        ]
    }


SERVICES = table(
    PREFIX,
    {
        "message_details": ("MessageDetails", message_details),
        "service_request_details": ("ServiceRequestDetails", service_request_details),
        "service_response_details": ("ServiceResponseDetails", service_response_details),
        "action_goal_details": ("ActionGoalDetails", action_goal_details),
        "action_result_details": ("ActionResultDetails", action_result_details),
        "action_feedback_details": ("ActionFeedbackDetails", action_feedback_details),
        "interfaces": ("Interfaces", interfaces),
    },
)
