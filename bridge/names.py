"""ROS 2 names for topics, services and actions: validated as rcl does, then made absolute.

A name is checked against rcl's topic-name rules (`rcl_validate_topic_name`): ASCII letters,
digits, `_` and `/`; `~` only as the first character and followed by `/`; `{...}`
substitutions of letters, digits and `_` not starting with a digit; no trailing `/`. It is
then expanded in the bridge's node (`~` -> `/rosbridge_websocket`, `{node}` ->
`rosbridge_websocket`, `{ns}`/`{namespace}` -> the root namespace) and must be a valid fully
qualified name (`rmw_validate_full_topic_name`): no `//`, no token starting with a digit, at
most 247 characters. So `/allowed/../denied` is refused before any glob sees it.
"""

from __future__ import annotations

import re
from fnmatch import fnmatchcase
from functools import lru_cache

from bridge.errors import InvalidNameError
from schemas.safety import echo

BRIDGE_NODE_NAME = "rosbridge_websocket"  # the node rosbridge's own relative names live in
MAX_NAME_CHARS = 255 - 8  # RMW_TOPIC_MAX_NAME_LENGTH: 255 less 8 reserved for DDS prefixes

_ALLOWED = re.compile(r"[A-Za-z0-9_/~{}]*")
_SUBSTITUTION = re.compile(r"\{([^{}/]*)\}")
_FULL_NAME = re.compile(r"(?:/[A-Za-z_][A-Za-z0-9_]*)+")
_SUBSTITUTIONS = {"node": BRIDGE_NODE_NAME, "ns": "", "namespace": ""}


def _refuse(name: str, problem: str) -> InvalidNameError:
    return InvalidNameError(f"{echo(name, 80)} is not a valid ROS name: {problem}")


def _check_relative(name: str) -> None:
    """rcl_validate_topic_name: the rules for a name as a user may write it."""
    if not name:
        raise _refuse(name, "it is empty")
    if not _ALLOWED.fullmatch(name):
        raise _refuse(
            name, "only letters, digits, '_', '/', a leading '~' and {} substitutions are allowed"
        )
    if name.endswith("/"):
        raise _refuse(name, "it must not end with '/'")
    if "~" in name[1:] or (name.startswith("~") and name[1:2] not in ("", "/")):
        raise _refuse(name, "'~' may only start the name and must be followed by '/'")
    if name[0].isdigit():
        raise _refuse(name, "a token must not start with a digit")
    if _SUBSTITUTION.sub("", name).count("{") or _SUBSTITUTION.sub("", name).count("}"):
        raise _refuse(name, "unbalanced or nested '{}'")


def _substitute(match: re.Match[str]) -> str:
    key = match.group(1)
    if key not in _SUBSTITUTIONS:
        raise InvalidNameError(
            f"unknown substitution {{{echo(key, 40)}}} (known: node, ns, namespace)"
        )
    return _SUBSTITUTIONS[key]


def _full_name_problem(expanded: str) -> str:
    if "//" in expanded:
        return "'//' is not allowed"
    if expanded.endswith("/"):
        return f"it expands to {expanded!r}, which ends with '/'"
    return "a token must not start with a digit"


@lru_cache(maxsize=4096)
def absolute_name(name: str) -> str:
    """The fully qualified form of `name` (`rosapi/topics` -> `/rosapi/topics`).

    Raises InvalidNameError naming the rule `name` breaks.
    """
    if not isinstance(name, str):
        raise InvalidNameError(f"a name must be a string, got {type(name).__name__}")
    if len(name) > 2 * MAX_NAME_CHARS:
        raise _refuse(name, f"longer than {MAX_NAME_CHARS} characters")
    _check_relative(name)
    expanded = name
    if expanded.startswith("~"):
        expanded = "/" + BRIDGE_NODE_NAME + expanded[1:]
    if "{" in expanded:
        expanded = _SUBSTITUTION.sub(
            _substitute, expanded.replace("/{ns}", "{ns}").replace("/{namespace}", "{namespace}")
        )
    if not expanded.startswith("/"):
        expanded = "/" + expanded
    if not _FULL_NAME.fullmatch(expanded):
        raise _refuse(name, _full_name_problem(expanded))
    if len(expanded) > MAX_NAME_CHARS:
        raise _refuse(name, f"longer than {MAX_NAME_CHARS} characters")
    return expanded


def allowed(name: str, patterns: tuple[str, ...]) -> bool:
    """True if no glob is configured or `name` matches one of the fnmatch `patterns`."""
    return not patterns or any(fnmatchcase(name, p) for p in patterns)
