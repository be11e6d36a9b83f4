"""riverbridge's asyncio rosbridge v2 client library.

``RosbridgeClient`` connects (with retry), publishes JSON or CBOR, subscribes as async
iterators of ``Received``, calls and provides services, sends action goals, and resumes all of
it by itself after the bridge restarts. ``clients.protocol`` is its sans-I/O core.
"""

from clients.actions import ActionGoal
from clients.client import RosbridgeClient
from clients.errors import (
    ActionError,
    ClientClosed,
    ConnectionClosed,
    ConnectionFailed,
    ProtocolError,
    RosbridgeError,
    ServiceError,
)
from clients.events import Received
from clients.publisher import PublishStats
from clients.subscription import Subscription, bytes_as_arrays

__all__ = [
    "ActionError",
    "ActionGoal",
    "ClientClosed",
    "ConnectionClosed",
    "ConnectionFailed",
    "ProtocolError",
    "PublishStats",
    "Received",
    "RosbridgeClient",
    "RosbridgeError",
    "ServiceError",
    "Subscription",
    "bytes_as_arrays",
]
