"""ROS interface type names: the ``pkg/Type`` and ``pkg/kind/Type`` spellings.

rosbridge accepts both spellings and tolerates stray slashes (``//std_msgs/String/``);
riverbridge stores every type under the canonical ``pkg/kind/Type`` form.
"""

from __future__ import annotations

import re
from typing import Literal

from schemas.errors import InvalidTypeNameError

TypeKind = Literal["msg", "srv", "action"]

_KINDS = ("msg", "srv", "action")
_IDENTIFIER = re.compile(r"[A-Za-z][A-Za-z0-9_]*\Z")


def _parts(name: object) -> list[str]:
    if not isinstance(name, str):
        raise InvalidTypeNameError(f"type name must be a string, got {type(name).__name__}")
    parts = [p for p in name.split("/") if p]
    if len(parts) not in (2, 3) or not all(_IDENTIFIER.match(p) for p in parts):
        raise InvalidTypeNameError(f"{name!r} is not a valid type string")
    if len(parts) == 3 and parts[1] not in _KINDS:
        raise InvalidTypeNameError(
            f"{name!r} is not a valid type string: middle part must be msg, srv or action"
        )
    return parts


def normalize_type_name(name: str, kind: TypeKind = "msg") -> str:
    """Return the canonical ``pkg/kind/Type`` spelling of ``name``.

    ``'std_msgs/String'``, ``'std_msgs/msg/String'`` and ``'//std_msgs//String/'`` all give
    ``'std_msgs/msg/String'``. A three-part name keeps its own middle part (messages
    generated from services are named ``pkg/srv/T_Request``). Raises
    :class:`InvalidTypeNameError` for anything else (``''``, ``'bad'``, ``'/x'``, ``'a\\b'``).
    """
    parts = _parts(name)
    if len(parts) == 2:
        return f"{parts[0]}/{kind}/{parts[1]}"
    return "/".join(parts)


def short_type_name(name: str) -> str:
    """``'std_msgs/msg/String'`` -> ``'std_msgs/String'`` (the ROS 1 / rosapi spelling)."""
    parts = _parts(name)
    return f"{parts[0]}/{parts[-1]}"


def is_valid_type_name(name: object) -> bool:
    """True if ``name`` is either accepted spelling; never raises."""
    try:
        _parts(name)
    except InvalidTypeNameError:
        return False
    return True
