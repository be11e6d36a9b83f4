"""Read ``.msg``/``.srv``/``.action`` definition files into rosbags type dictionaries.

A ``.srv`` is request ``---`` response, an ``.action`` goal ``---`` result ``---`` feedback.
Each part becomes a message named ``pkg/srv/T_Request``, ``pkg/action/T_Goal``, ...; the
parsing itself is rosbags' own ``get_types_from_msg``.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from rosbags.interfaces.typing import Typesdict
from rosbags.typesys import get_types_from_msg
from rosbags.typesys.base import TypesysError

from schemas.errors import SchemaError

_SEPARATOR = re.compile(r"(?m)^\s*---\s*$")
_PARTS = {
    "msg": ("",),
    "srv": ("_Request", "_Response"),
    "action": ("_Goal", "_Result", "_Feedback"),
}


@dataclass
class InterfaceSet:
    """Everything found in one or more definition folders, ready to register.

    ``types`` is a rosbags Typesdict; ``services`` maps ``pkg/srv/T`` to its request and
    response message names; ``actions`` maps ``pkg/action/T`` to goal, result, feedback names.
    """

    types: Typesdict = field(default_factory=dict)
    services: dict[str, tuple[str, str]] = field(default_factory=dict)
    actions: dict[str, tuple[str, str, str]] = field(default_factory=dict)


def parse_interface(pkg: str, kind: str, name: str, text: str) -> InterfaceSet:
    """Parse the text of one ``pkg/<kind>/<name>.<kind>`` file."""
    suffixes = _PARTS[kind]
    sections = _SEPARATOR.split(text)
    if len(sections) != len(suffixes):
        raise SchemaError(
            f"{pkg}/{kind}/{name}: expected {len(suffixes)} section(s) separated by '---', "
            f"found {len(sections)}"
        )
    result = InterfaceSet()
    part_names = []
    for suffix, section in zip(suffixes, sections, strict=True):
        # rosbags resolves relative names against the package's msg folder, which is right
        # for a .srv/.action too; it only accepts message names, so rename afterwards.
        parse_name = f"{pkg}/msg/{name}{suffix}"
        final_name = f"{pkg}/{kind}/{name}{suffix}"
        try:
            parsed = get_types_from_msg(section, parse_name)
        except (TypesysError, ValueError) as exc:
            raise SchemaError(f"{final_name}: cannot parse definition: {exc}") from exc
        result.types[final_name] = parsed.pop(parse_name)
        result.types.update(parsed)
        part_names.append(final_name)
    full_name = f"{pkg}/{kind}/{name}"
    if kind == "srv":
        result.services[full_name] = (part_names[0], part_names[1])
    elif kind == "action":
        result.actions[full_name] = (part_names[0], part_names[1], part_names[2])
        _add_action_wire_types(result, pkg, name)
    return result


# What rosidl generates from an action for rcl_action's wire: the goal, result and feedback
# wrapped with the goal's id, as two services and the feedback topic's message
# (`<pkg>/action/<T>_SendGoal_Request` ... on DDS `<pkg>::action::dds_::<T>_SendGoal_Request_`).
_ACTION_WIRE_PARTS = {
    "_SendGoal_Request": "unique_identifier_msgs/UUID goal_id\n{part}_Goal goal",
    "_SendGoal_Response": "bool accepted\nbuiltin_interfaces/Time stamp",
    "_GetResult_Request": "unique_identifier_msgs/UUID goal_id",
    "_GetResult_Response": "int8 status\n{part}_Result result",
    "_FeedbackMessage": "unique_identifier_msgs/UUID goal_id\n{part}_Feedback feedback",
}
ACTION_SERVICES = ("_SendGoal", "_GetResult")


def _add_action_wire_types(result: InterfaceSet, pkg: str, name: str) -> None:
    """Register `_ACTION_WIRE_PARTS` of action `pkg/action/name` and its two services."""
    parsed_part, action_part = f"{pkg}/msg/{name}", f"{pkg}/action/{name}"
    for suffix, text in _ACTION_WIRE_PARTS.items():
        parse_name = f"{parsed_part}{suffix}"
        parsed = get_types_from_msg(text.format(part=f"{pkg}/{name}"), parse_name)
        consts, fields = parsed.pop(parse_name)
        # rosbags read `{pkg}/{name}_Goal` as a msg; the goal, result, feedback are action parts
        result.types[f"{action_part}{suffix}"] = (
            consts,
            [
                (field_name, _in_action(node, parsed_part, action_part))
                for field_name, node in fields
            ],
        )
    for service in ACTION_SERVICES:
        result.services[f"{action_part}{service}"] = (
            f"{action_part}{service}_Request",
            f"{action_part}{service}_Response",
        )


def _in_action(node: Any, parsed_part: str, action_part: str) -> Any:
    kind, detail = node
    if isinstance(detail, str) and detail.startswith(parsed_part + "_"):
        return (kind, action_part + detail[len(parsed_part) :])
    return node


def _package_dirs(root: Path) -> list[Path]:
    """``root`` itself if it is a package folder, else its sub-folders that are packages."""
    if any((root / kind).is_dir() for kind in _PARTS):
        return [root]
    return sorted(p for p in root.iterdir() if p.is_dir() and not p.name.startswith("."))


def load_directory(root: Path) -> InterfaceSet:
    """Parse every ``<pkg>/{msg,srv,action}/<Type>.<ext>`` file below ``root``."""
    root = Path(root)
    if not root.is_dir():
        raise SchemaError(f"interface folder {root} does not exist")
    found = InterfaceSet()
    for pkg_dir in _package_dirs(root):
        for kind in _PARTS:
            for path in sorted((pkg_dir / kind).glob(f"*.{kind}")):
                part = parse_interface(pkg_dir.name, kind, path.stem, path.read_text("utf-8"))
                found.types.update(part.types)
                found.services.update(part.services)
                found.actions.update(part.actions)
    return found
