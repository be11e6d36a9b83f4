"""The player's state as Foxglove's time and playback state.

`riverbridge play` publishes `riverbridge_msgs/msg/PlaybackState` on `STATE_TOPIC` and answers
`riverbridge_msgs/srv/PlaybackControl` on `bridge.foxglove.session.PLAYBACK_SERVICE`. This
watch is a sink of the graph (`bridge.sinks`) that keeps the state: each state becomes a
`Time` frame for every Foxglove client, a change of status or speed also a `PlaybackState`,
and the recording's window goes into `serverInfo` (`dataStartTime`/`dataEndTime`,
with the `time` and `playbackControl` capabilities). Message timestamps then follow the
playback clock (`message_time`), the one time source the protocol asks for.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING

from bridge.foxglove import wire
from bridge.foxglove.session import stamp_ns
from bridge.host import PluginHost
from bridge.outgoing import TopicMessage

if TYPE_CHECKING:
    from bridge.context import Context

STATE_TOPIC = "/riverbridge/playback/state"
STATE_TYPE = "riverbridge_msgs/msg/PlaybackState"


@dataclass(frozen=True)
class PlayerState:
    status: int
    current_ns: int
    speed: float
    start_ns: int
    end_ns: int
    received_ns: int  # when it entered the bridge (the bridge's wall clock)


class PlaybackWatch:
    """The latest player state, and the frames its changes give Foxglove clients."""

    def __init__(self, host: PluginHost) -> None:
        self.host = host
        self.state: PlayerState | None = None
        self._broadcast: Callable[..., None] | None = None

    def start(self, broadcast: Callable[..., None]) -> None:
        self._broadcast = broadcast
        self.host.add_sink(self)

    def stop(self) -> None:
        self.host.remove_sink(self)

    def accept(self, ctx: Context, message: TopicMessage, origin_node: str) -> None:
        """Every message of the graph passes here; only the player's state is kept."""
        if message.topic == STATE_TOPIC and message.type_name == STATE_TYPE:
            self._take(message)

    def forget(self) -> None:
        """The player left: no time, no playback control for new clients."""
        self.state = None

    def window(self) -> tuple[int, int] | None:
        """The recording's (first, last) log time while a player runs."""
        return None if self.state is None else (self.state.start_ns, self.state.end_ns)

    def message_time(self, received_ns: int) -> int:
        """The timestamp of a message that entered the bridge at `received_ns`: the playback
        time then while a player runs, else `received_ns` itself."""
        state = self.state
        if state is None:
            return received_ns
        if state.status != wire.PLAYING:
            return state.current_ns
        return state.current_ns + max(0, round((received_ns - state.received_ns) * state.speed))

    def _take(self, message: TopicMessage) -> None:
        msg, previous = message.msg, self.state
        state = PlayerState(
            int(msg["status"]),
            stamp_ns(msg["current_time"]),
            float(msg["speed"]),
            stamp_ns(msg["start_time"]),
            stamp_ns(msg["end_time"]),
            message.stamp_ns,
        )
        self.state = state
        if self._broadcast is None:
            return
        self._broadcast(wire.time_frame(state.current_ns), None, "foxglove:time")
        if previous is None or (previous.status, previous.speed) != (state.status, state.speed):
            frame = wire.playback_state(state.status, state.current_ns, state.speed, False, None)
            self._broadcast(frame, lambda connection: connection.playback_control)
