"""rosapi services about types: message/service definitions and the interface list."""

from __future__ import annotations

from bridge.context import Context
from bridge.errors import RosapiError
from bridge.rosapi.common import table, text_arg
from schemas.errors import SchemaError
from schemas.values import Message

PREFIX = "/rosapi"


def message_details(ctx: Context, request: Message) -> Message:
    try:
        return {"typedefs": ctx.state.registry.typedefs(text_arg(request, "type"))}
    except SchemaError as exc:
        raise RosapiError(str(exc)) from exc


def _service_part_details(ctx: Context, request: Message, part: str) -> Message:
    try:
        spec = ctx.state.registry.service(text_arg(request, "type"))
        return {"typedefs": ctx.state.registry.typedefs(getattr(spec, part).name)}
    except SchemaError as exc:
        raise RosapiError(str(exc)) from exc


def service_request_details(ctx: Context, request: Message) -> Message:
    return _service_part_details(ctx, request, "request")


def service_response_details(ctx: Context, request: Message) -> Message:
    return _service_part_details(ctx, request, "response")


def _action_part_details(ctx: Context, request: Message, part: str) -> Message:
    try:
        spec = ctx.state.registry.action(text_arg(request, "type"))
        return {"typedefs": ctx.state.registry.typedefs(getattr(spec, part).name)}
    except SchemaError as exc:
        raise RosapiError(str(exc)) from exc


def action_goal_details(ctx: Context, request: Message) -> Message:
    return _action_part_details(ctx, request, "goal")


def action_result_details(ctx: Context, request: Message) -> Message:
    return _action_part_details(ctx, request, "result")


def action_feedback_details(ctx: Context, request: Message) -> Message:
    return _action_part_details(ctx, request, "feedback")


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
