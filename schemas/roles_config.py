"""`--roles FILE`: who may do what on the bridge, as a frozen model read from TOML.

A role is a set of allow-lists of ROS name globs (fnmatch, `*` also crosses `/`), one per kind
of action a client can take, and per-client limits. Names are absolute (`/cmd_wrench`); an
empty list allows nothing. The file names the role a rosauth MAC grants (`rosauth_role`) and,
only if it says so, the role of clients that never authenticate (`unauthenticated_role`).
Publishes on `audited_topics` are written to `--audit-log` (docs/bridge.md, "Roles and tokens").

Like the other configuration files, a misspelt key or a wrong type is refused with the field's
dotted path (`load_roles` raises ValueError naming it).
"""

from __future__ import annotations

import tomllib
from enum import StrEnum
from pathlib import Path
from typing import Annotated

from pydantic import BaseModel, ConfigDict, Field, ValidationError, model_validator

Globs = tuple[Annotated[str, Field(min_length=1)], ...]


class Action(StrEnum):
    """What a client asks to do with a name; each is one allow-list of a `Role`."""

    SUBSCRIBE = "subscribe"
    PUBLISH = "publish"  # also advertising a topic
    CALL_SERVICE = "call_service"
    ADVERTISE_SERVICE = "advertise_service"
    SEND_GOAL = "send_goal"  # send_action_goal and cancel_action_goal
    ADVERTISE_ACTION = "advertise_action"
    GET_PARAM = "get_param"  # /rosapi/get_param, has_param, get_param_names
    SET_PARAM = "set_param"  # /rosapi/set_param, delete_param


class RoleLimits(BaseModel):
    """Per-client limits of a role; None = unlimited. Rates are token buckets that hold one
    second's worth, so a client may burst to its rate and then keeps to it."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    messages_per_s: float | None = Field(default=None, gt=0)
    bytes_per_s: float | None = Field(default=None, gt=0)
    topics_advertised: int | None = Field(default=None, ge=0)
    services_advertised: int | None = Field(default=None, ge=0)
    # Connections open at once under one principal (a token's subject).
    connections: int | None = Field(default=None, gt=0)


class Role(BaseModel):
    """One role: an allow-list of name globs per `Action`, and its limits."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    subscribe: Globs = ()
    publish: Globs = ()
    call_service: Globs = ()
    advertise_service: Globs = ()
    send_goal: Globs = ()
    advertise_action: Globs = ()
    get_param: Globs = ()
    set_param: Globs = ()
    # May read GET /metrics when the file sets `metrics_role_only`.
    metrics: bool = False
    limits: RoleLimits = RoleLimits()

    def globs(self, action: Action) -> tuple[str, ...]:
        globs: tuple[str, ...] = getattr(self, action.value)
        return globs


class RolesConfig(BaseModel):
    """The whole roles file."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    roles: dict[Annotated[str, Field(pattern=r"^[A-Za-z0-9_.-]+$")], Role] = Field(min_length=1)
    # The role a client gets from a valid rosauth MAC (no token, so no role of its own).
    rosauth_role: str | None = None
    # The role of clients that have not authenticated; None = they must authenticate.
    unauthenticated_role: str | None = None
    # Topics whose every publish is written to the audit log.
    audited_topics: Globs = ("/cmd_wrench",)
    # GET /metrics only with a bearer token whose role has `metrics = true`.
    metrics_role_only: bool = False

    @model_validator(mode="after")
    def _named_roles_exist(self) -> RolesConfig:
        for field in ("rosauth_role", "unauthenticated_role"):
            name = getattr(self, field)
            if name is not None and name not in self.roles:
                known = ", ".join(self.roles)
                raise ValueError(f"{field} {name!r} is not one of the roles ({known})")
        return self


def load_roles(path: Path) -> RolesConfig:
    """The roles file at `path`; ValueError naming the file and the refused field."""
    try:
        with path.open("rb") as stream:
            data = tomllib.load(stream)
    except (OSError, tomllib.TOMLDecodeError) as exc:
        raise ValueError(f"{path}: {exc}") from None
    try:
        return RolesConfig.model_validate(data)
    except ValidationError as exc:
        raise ValueError(f"{path}: {describe(exc)}") from None


def describe(exc: ValidationError) -> str:
    """Each refused field as `dotted.path: problem, got value`."""
    lines = []
    for error in exc.errors():
        where = ".".join(str(part) for part in error["loc"]) or "(file)"
        shown = error.get("input")
        given = f", got {shown!r}" if error["loc"] and not isinstance(shown, dict) else ""
        lines.append(f"{where}: {error['msg']}{given}")
    return "; ".join(lines)


__all__ = ["Action", "Role", "RoleLimits", "RolesConfig", "describe", "load_roles"]
