"""The bridge's exception tree: every refusal a handler can raise derives from BridgeError.

The core catches `BridgeError` (and schemas' `SchemaError`) around each op, logs one line
and, where a caller waits, answers it; anything else is a bug and is logged with a trace.
"""

from __future__ import annotations


class BridgeError(Exception):
    """Base of every error the bridge raises on purpose."""


class OpFailure(BridgeError):
    """A handler's refusal of an op: logged, and reported to clients that asked for status."""


class InvalidNameError(BridgeError, ValueError):
    """An empty or malformed topic, service or action name."""


class GraphConflictError(BridgeError):
    """A topic declared with a type other than the one already established."""


class RosapiError(BridgeError):
    """A rosapi request that cannot be answered; the text goes back as `values`."""


class DdsStartError(BridgeError):
    """The bridge cannot join its DDS domain (bad interface, Cyclone refused the config)."""


class ZenohStartError(BridgeError):
    """The bridge cannot open its Zenoh session (bad configuration, an endpoint not bound)."""
