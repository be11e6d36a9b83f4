"""Read ``.msg``/``.srv``/``.action`` definition files into rosbags type dictionaries.

A ``.srv`` is request ``---`` response, an ``.action`` goal ``---`` result ``---`` feedback.
Each part becomes a message named ``pkg/srv/T_Request``, ``pkg/action/T_Goal``, ...; the
parsing itself is rosbags' own ``get_types_from_msg``.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from pathlib import Path

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
    return result


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
