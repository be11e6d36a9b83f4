"""The seam for other message sources and sinks (a ROS 2 DDS mirror later).

Every message published into the graph is handed to each registered sink, together with
the name of the node it came from so a sink can skip messages it injected itself. The
local fan-out to websocket subscribers is just the first sink; a middleware bridge adds a
second one and injects foreign messages with `BridgeCore.publish_external`.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Protocol

if TYPE_CHECKING:
    from bridge.context import Context
    from bridge.outgoing import TopicMessage


class MessageSink(Protocol):
    """Receives every message published in the graph."""

    def accept(self, ctx: Context, message: TopicMessage, origin_node: str) -> None:
        """Take `message` (published by `origin_node`); effects go to `ctx`."""
        ...


class LocalFanout:
    """Delivers messages to the websocket clients subscribed to their topic."""

    def accept(self, ctx: Context, message: TopicMessage, origin_node: str) -> None:
        subscribers = ctx.state.topic_subscriptions.get(message.topic)
        if not subscribers:
            return
        sessions, now_ns = ctx.state.sessions, ctx.now_ns
        for client_id, subscription in list(subscribers.items()):
            session = sessions.get(client_id)
            if session is None:
                continue
            if subscription.passes(now_ns):
                ctx.deliver(session, subscription, message)
            else:
                ctx.release(session, subscription, subscription.offer(message, now_ns))
