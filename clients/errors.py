"""The one exception tree of the client library.

Everything the library raises derives from :class:`RosbridgeError`, so a caller can catch the
whole family with one clause. Errors of the lower layers (``websockets``, ``OSError`` from the
socket, the codecs of :mod:`schemas`) are translated into this tree in exactly one place,
:func:`clients.connection.translate_transport_error`; nothing else in the library lets a
``websockets`` exception escape.

``TimeoutError`` (the built-in) is raised for deadlines, as asyncio does, and is not part of the
tree: ``except TimeoutError`` keeps working as Python programmers expect.
"""

from __future__ import annotations

from typing import Any


class RosbridgeError(Exception):
    """Base class of every error raised by :mod:`clients`."""


class ConnectionFailed(RosbridgeError):
    """The client could not open a websocket to the bridge within its ``connect_timeout``."""


class ConnectionClosed(RosbridgeError):
    """The websocket closed (or was never open) while an operation needed it.

    Raised by operations that cannot be deferred (a service call, a publish on a client
    without ``reconnect``) and used to fail every pending call when the connection drops, so
    no caller waits for an answer that cannot come.
    """


class ClientClosed(ConnectionClosed):
    """The client was closed by its owner (``close()`` or leaving ``async with``)."""


class ProtocolError(RosbridgeError):
    """A frame from the bridge could not be understood (bad JSON/CBOR, an op without fields)."""


class ServiceError(RosbridgeError):
    """A service answered ``result: false``.

    ``values`` is what the bridge sent in the response: by protocol a string describing the
    failure (rosbridge's exception text), but kept as received in case a server sends an
    object.
    """

    def __init__(self, values: Any, *, service: str = "") -> None:
        self.values = values
        self.service = service
        text = values if isinstance(values, str) else repr(values)
        super().__init__(f"{service}: {text}" if service else text)


class ActionError(RosbridgeError):
    """An action goal ended with ``result: false`` (the server's exception text in ``values``)."""

    def __init__(self, values: Any, *, action: str = "", status: int = 0) -> None:
        self.values = values
        self.action = action
        self.status = status
        text = values if isinstance(values, str) else repr(values)
        super().__init__(f"{action}: {text} (status {status})" if action else text)
